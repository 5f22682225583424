"""A Link whose firmware is a few lines of Python: no port, no thread, no simulator. Paths are
taken and driven only when a test says so (arrive()), a restart is a new boot count, and a
stop's token rules are the real link's (Link.stopping, motion_token, stopped_since)."""

from __future__ import annotations

from collections.abc import Sequence

from cart2d.link import Link
from cart2d.link.protocol import CONTROL_OK, Reply
from cart2d.link.transport import Priority
from cart2d.spec import load_spec

MOTION = {"WAIT_XY_ARRAY", "XY_APPEND", "GOTO", "VELOCITY", "RESET_ROUTINE"}


class FakeFirmware(Link):
    def __init__(self) -> None:
        super().__init__("fake")
        self.connected.set()
        self.pose = [0.5, 0.5, 0.0]
        self.mode = "IDLE"
        self.flags: set[str] = set()
        self.path: list[tuple[float, float]] = []
        self.index = 0
        self.boot_count = 1
        self.uptime_s = 10.0
        self.requests: list[str] = []

    # -- what a test does to the cart ----------------------------------------------------------
    def arrive(self) -> None:
        """The cart drove its path to its end."""
        self.pose[0], self.pose[1] = self.path[-1]
        self.mode, self.index, self.flags = "IDLE", len(self.path) - 1, {"ARRIVED"}

    def restart(self, keep_pose: bool = False) -> None:
        """The MCU restarted (its watchdog): idle, a new boot count, at (0, 0, 0) unless it kept
        its pose in RAM (POSE_RESTORED)."""
        self.mode, self.path = "IDLE", []
        self.flags = {"POSE_RESTORED"} if keep_pose else set()
        if not keep_pose:
            self.pose = [0.0, 0.0, 0.0]
        self.boot_count += 1
        self.uptime_s = 0.5

    # -- the firmware --------------------------------------------------------------------------
    def request(
        self,
        command: str | int,
        args: Sequence[float] = (),
        timeout_s: float | None = None,
        *,
        priority: Priority = Priority.COMMAND,
        token: int | None = None,
    ) -> Reply:
        spec = load_spec()
        code = spec.code(command) if isinstance(command, str) else command
        name = spec.name_of(code).removeprefix("COMMAND_")
        if name in MOTION and token is not None:
            self._refuse_if_stopped(code, token)  # as the real link: refused unsent
        self.requests.append(name)
        return Reply(0, CONTROL_OK, code, self._results(name, list(args)))

    def _results(self, name: str, args: list[float]) -> tuple[float, ...]:
        spec = load_spec()
        if name == "STATUS":
            mode = next(code for code, known in spec.modes.items() if known == self.mode)
            flags = sum(spec.flags[f] for f in self.flags)
            self.uptime_s += 0.1
            status = [0.0] * 16
            status[0:4] = [mode, flags, self.index, len(self.path)]
            status[10], status[13], status[15] = self.uptime_s, self.boot_count, len(self.path)
            return tuple(float(v) for v in status)
        if name == "POSE":
            return tuple(self.pose)
        if name == "SET_POSE":
            self.pose = args[:3]
        elif name == "WAIT_XY_ARRAY":
            count, points = int(args[0]), args[1:]
            self.path = [(points[i], points[i + 1]) for i in range(0, len(points), 2)]
            assert len(self.path) == count, "the fake takes whole paths in one frame"
            self.mode, self.index, self.flags = "PATH", 0, set()
            return (float(count), 0.0, 0.0)  # received, index, room
        elif name == "REBOOT":
            self.restart(keep_pose=True)
        elif name in ("STOP", "VELOCITY"):
            self.mode = "IDLE"
        elif name == "START":  # resumes the path it keeps (a stop keeps it), else holds still
            self.mode = "PATH" if self.path and "ARRIVED" not in self.flags else "HOLD"
        elif name == "RESET_ROUTINE":
            self.mode, self.flags = "RESET_ROUTINE", set()
        elif name == "VERSION":
            return (1.0, 10000.0, 0.0, 0.0, 32.0, 0.0)
        elif name == "PARAM_GET":
            return (args[0], 0.0, 0.0, 1.0)
        return ()
