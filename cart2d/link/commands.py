"""What each protocol command does to the cart, as the link must know it: which commands start
or steer the motors (a stop cancels them), which only read (the firmware answers them again
without harm), which leave the firmware as one execution does when executed twice, and which
leave the firmware's settings as they were (every other command may change them, so the
settings the gateway keeps are read again after it). By name, as in docs/protocol.md; a command
added to the protocol later counts as one that may change settings and is neither motion, nor a
read, nor repeatable until it is named here."""

from __future__ import annotations

from functools import cache

from cart2d.spec import load_spec

# Commands that make the motors turn: GOTO, a path upload (it starts once complete), START
# (resumes a path), VELOCITY, the reset routine (it drives to the wall).
MOTION = frozenset({"GOTO", "WAIT_XY_ARRAY", "XY_APPEND", "START", "VELOCITY", "RESET_ROUTINE"})
# Commands that change nothing on the firmware.
READS = frozenset(
    {"POSE", "STATUS", "VERSION", "HEARTBEAT", "PARAM_GET", "KPID_GET", "TOL_GET", "MAX_SPEED_GET"}
)
# Commands that leave every setting as it was (SAVE writes them to EEPROM unchanged; REBOOT and
# LOAD reload them, TELEMETRY sets telemetry_hz, the *_SET commands set them).
KEEP_SETTINGS = READS | MOTION | {"STOP", "SET_POSE", "RESET", "SAVE"}
# Commands that leave the firmware as one execution does when executed twice: the reads, STOP and
# the writes of absolute values. One whose reply never came within the retransmission window may
# be asked again as a new request (a new SEQ). Not SET_POSE or RESET (the cart may have moved in
# between), not SAVE, LOAD or REBOOT (a second EEPROM write, a second reload or restart).
REPEATABLE = READS | {"STOP", "PARAM_SET", "KPID_SET", "TOL_SET", "MAX_SPEED_SET", "TELEMETRY"}


@cache
def codes(names: frozenset[str]) -> frozenset[int]:
    spec = load_spec()
    return frozenset(spec.code(name) for name in names)


def is_motion(code: int) -> bool:
    return code in codes(MOTION)


def is_read(code: int) -> bool:
    return code in codes(READS)


def keeps_settings(code: int) -> bool:
    return code in codes(KEEP_SETTINGS)


def is_repeatable(code: int) -> bool:
    return code in codes(REPEATABLE)


@cache
def reply_results(code: int) -> int:
    """How many results the command's reply carries (0 for a code the protocol lacks)."""
    spec = load_spec()
    command = next((c for c in spec.commands.values() if c.code == code), None)
    return command.result_count if command is not None else 0
