"""What the gateway asks of the firmware, in words instead of command codes: compatibility,
status, resets and their causes, settings by stable id (paths of any length: path_stream.py).
Built on a Link."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from cart2d.link.transport import Link, LinkError, Priority
from cart2d.params import settings_table
from cart2d.spec import load_spec

SETTINGS_SOURCES = {0: "eeprom", 1: "defaults (blank EEPROM)", 2: "defaults (corrupt EEPROM)"}


class IncompatibleFirmware(LinkError):
    """The firmware was built from a different protocol table than this gateway."""


@dataclass(frozen=True)
class Version:
    protocol: int
    firmware: str
    dictionary_hash: int
    settings_layout: int
    waypoint_capacity: int
    setting_count: int


@dataclass(frozen=True)
class Status:
    mode: str
    flags: list[str]
    waypoint_index: int
    waypoint_count: int
    loop_overruns: int
    cpu_load_pct: int
    cpu_max_pct: int
    rx_errors: int
    settings_source: str
    eeprom_busy: bool
    uptime_s: float
    last_error: str | None
    reset_cause: list[str]  # why the MCU last restarted (docs/protocol.md, Reset causes)
    boot_count: int  # boots since the MCU's RAM was last lost
    replies_dropped: int
    waypoints_received: int  # points of the path the firmware has received (absolute)

    def has(self, flag: str) -> bool:
        return flag in self.flags

    def path_outcome(self) -> str | None:
        """None while the firmware drives a path; "" once it has arrived; else why it stopped."""
        if self.mode == "PATH":
            return None
        if self.has("ARRIVED"):
            return ""
        if self.has("BUMPER"):
            return "the cart touched something in front: a front switch closed and the firmware stopped it"
        if self.has("STALLED"):
            return "a wheel stalled: the cart is blocked"
        return f"the firmware stopped the path (mode {self.mode})"

    def restarted_since(self, earlier: Status) -> bool:
        """Whether the MCU restarted between `earlier` and this STATUS: its boot count changed
        (a reset that kept the RAM), or its uptime went backwards (one that lost it)."""
        return self.boot_count != earlier.boot_count or self.uptime_s < earlier.uptime_s

    def reset_words(self, trigger_known: bool = False) -> str:
        """Why the MCU last restarted, in words (docs/protocol.md, Reset causes); see
        reset_cause_words for `trigger_known`."""
        return reset_cause_words(self.reset_cause, trigger_known)


# What each reset cause means for someone standing by the cart. WATCHDOG is also how REBOOT
# works, so with REBOOT it is not a hang.
RESET_CAUSE_WORDS = {
    "POWER_ON": "the controller was powered up",
    "EXTERNAL": "the reset button, or the serial port was reopened (a Nano resets when its port opens)",
    "BROWN_OUT": "the controller's supply dipped (brown-out)",
    "WATCHDOG": "the firmware stopped running and the watchdog restarted it",
    "REBOOT": "a REBOOT command restarted the firmware",
}


# Behind the Nano's Optiboot 4.4 the firmware finds MCUSR cleared and tells only what the RAM
# says: a reset that kept it is EXTERNAL and WATCHDOG at once (docs/protocol.md, Reset causes).
BEHIND_BOOTLOADER_WORDS = (
    "a reset that kept the RAM: the reset button, the serial port reopened (a Nano resets when its "
    "port opens), or the watchdog after a hang (behind the Optiboot bootloader the firmware cannot "
    "tell them apart)"
)


# What those flags still say when the host knows what reset the MCU: its trigger is not one of
# the ones they cannot tell apart.
KEPT_RAM_WORDS = "a reset that kept the RAM"
KNOWN_EXTERNAL_WORDS = "an external reset (the RESET pin)"


def reset_cause_words(causes: Sequence[str], trigger_known: bool = False) -> str:
    """The causes in words. `trigger_known`: the host knows what reset the MCU (it asked for the
    restart, or its port's opening reset the Nano), so the triggers the flags cannot tell apart
    (the reset button, the port reopened, a hang) are not listed: only what the flags add."""
    if "REBOOT" in causes:
        causes = [c for c in causes if c != "WATCHDOG"]
    elif "EXTERNAL" in causes and "WATCHDOG" in causes:
        rest = [RESET_CAUSE_WORDS.get(c, c) for c in causes if c not in ("EXTERNAL", "WATCHDOG")]
        return "; ".join([KEPT_RAM_WORDS if trigger_known else BEHIND_BOOTLOADER_WORDS, *rest])
    known = {"EXTERNAL": KNOWN_EXTERNAL_WORDS} if trigger_known else {}
    words = [known.get(cause) or RESET_CAUSE_WORDS.get(cause, cause) for cause in causes]
    return "; ".join(words) or "no cause recorded (a jump to address 0, or a bootloader that kept the flags)"


class ControllerRestarted(LinkError):
    """The MCU restarted while something depended on its state (a path, a calibration run)."""

    def __init__(self, status: Status) -> None:
        super().__init__(f"the controller restarted (boot {status.boot_count}): {status.reset_words()}")
        self.status = status


class ResetWatch:
    """Notices a restart of the MCU between the STATUS replies it is shown. The first one is
    the baseline. Show it the replies of one thread, in the order they were read: replies read
    by several threads may reach it out of order and look like an uptime going backwards."""

    def __init__(self, baseline: Status | None = None) -> None:
        self.last = baseline

    def saw(self, status: Status) -> bool:
        """True if the MCU restarted since the last STATUS shown; `status` becomes the last."""
        restarted = self.last is not None and status.restarted_since(self.last)
        self.last = status
        return restarted

    def check(self, status: Status) -> Status:
        """`status`, or ControllerRestarted if the MCU restarted since the last one."""
        if self.saw(status):
            raise ControllerRestarted(status)
        return status

    def read(self, link: Link) -> Status:
        return self.check(read_status(link))


def wait_path_end(
    link: Link, expired: Callable[[], bool], poll_s: float, watch: ResetWatch | None = None
) -> Status | None:
    """Polls STATUS until the firmware leaves PATH mode and returns that status (its
    path_outcome() says how the path ended); None once expired() says the time is up. With a
    watch, a restart of the MCU raises ControllerRestarted (a reset loses the path)."""
    while True:
        status = read_status(link) if watch is None else watch.read(link)
        if status.path_outcome() is not None:
            return status
        if expired():
            return None
        time.sleep(poll_s)


def flag_names(word: int) -> list[str]:
    return [name for name, bit in load_spec().flags.items() if word & bit]


def mode_name(code: int) -> str:
    """The firmware mode's name from the specification; "mode N" for a code it lacks."""
    return load_spec().modes.get(code, f"mode {code}")


def read_version(link: Link) -> Version:
    protocol, firmware, dictionary, layout, capacity, count = link.call("VERSION")
    fw = int(firmware)
    return Version(
        protocol=int(protocol),
        firmware=f"{fw // 10000}.{fw // 100 % 100}.{fw % 100}",
        dictionary_hash=int(dictionary),
        settings_layout=int(layout),
        waypoint_capacity=int(capacity),
        setting_count=int(count),
    )


# A Nano resets when its port opens and the firmware answers once Optiboot has let it go: ~0.5 s
# when requests come at once, 1.5 s at most (docs/firmware.md, "Start-up time after a reset").
FIRST_ANSWER_S = 10.0


def wait_for_version(link: Link, wait_s: float = FIRST_ANSWER_S) -> Version:
    """VERSION, asked again until the firmware answers or wait_s have passed (then LinkError)."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            return read_version(link)
        except LinkError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def check_compatible(version: Version) -> None:
    """Refuses a firmware that speaks another protocol table (Klipper's dictionary idea)."""
    spec = load_spec()
    if version.protocol != spec.version or version.dictionary_hash != spec.dictionary_hash:
        raise IncompatibleFirmware(
            f"the firmware speaks protocol {version.protocol} (table {version.dictionary_hash:#06x}), "
            f"this gateway {spec.version} (table {spec.dictionary_hash:#06x}): update one of them"
        )
    if version.setting_count != len(settings_table()):
        raise IncompatibleFirmware("the firmware has a different settings table: update one of them")


def read_status(link: Link) -> Status:
    r = link.call("STATUS")
    spec = load_spec()
    last_error = int(r[11])
    return Status(
        mode=mode_name(int(r[0])),
        flags=flag_names(int(r[1])),
        waypoint_index=int(r[2]),
        waypoint_count=int(r[3]),
        loop_overruns=int(r[4]),
        cpu_load_pct=int(r[5]),
        cpu_max_pct=int(r[6]),
        rx_errors=int(r[7]),
        settings_source=SETTINGS_SOURCES.get(int(r[8]), "unknown"),
        eeprom_busy=bool(r[9]),
        uptime_s=r[10],
        last_error=spec.reasons.get(last_error) if last_error else None,
        reset_cause=[name for name, bit in spec.reset_causes.items() if int(r[12]) & bit],
        boot_count=int(r[13]),
        replies_dropped=int(r[14]),
        waypoints_received=int(r[15]),
    )


def read_settings(link: Link, priority: Priority = Priority.COMMAND) -> list[dict[str, object]]:
    """Every firmware setting with its current value, range and unit (from robot.toml)."""
    out: list[dict[str, object]] = []
    for entry in settings_table():
        out.append({**entry, "value": read_setting(link, entry["id"], priority)})
    return out


def read_setting(link: Link, setting_id: int, priority: Priority = Priority.COMMAND) -> float:
    _, value, _low, _high = link.call("PARAM_GET", setting_id, priority=priority)
    return value


class SettingsCache:
    """The firmware's settings as last read, read again only once they may have changed: after
    any command that may change them (the link's settings_epoch moves), a reopened port or a
    restart of the MCU. One reader fills it at a time, behind every other request; readers that
    come meanwhile wait for it and share what it read."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self._lock = threading.Lock()
        self._values: list[dict[str, object]] | None = None
        self._epoch = -1
        self.fills = 0  # times it read the settings from the firmware

    def read(self) -> list[dict[str, object]]:
        with self._lock:
            epoch = self.link.settings_epoch
            if self._values is not None and self._epoch == epoch:
                return [dict(entry) for entry in self._values]
            values = read_settings(self.link, Priority.BACKGROUND)
            self.fills += 1
            if self.link.settings_epoch == epoch:  # nothing changed them while they were read
                self._values, self._epoch = values, epoch
            return [dict(entry) for entry in values]


def write_setting(link: Link, setting_id: int, value: float) -> float:
    return link.call("PARAM_SET", setting_id, value)[1]
