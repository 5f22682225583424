"""Any protocol request sent through the gateway (the generic command form, POST /api/command),
with what the gateway must know of it: STOP is the emergency stop, a REBOOT restarts the MCU on
purpose, SET_POSE and RESET give the pose, a path or manual driving of the user's replaces the
mission's, START resumes the mission a stop ended, and the reset routine is followed to its end."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence

from cart2d.gateway.missions import Missions
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.routine import ResetRoutine
from cart2d.gateway.state import RESET_POSE_SETTINGS, pose_text
from cart2d.link import CommandRefused, Link, LinkError, firmware
from cart2d.link.protocol import Reply
from cart2d.params import setting_id
from cart2d.spec import load_spec

USERS_PATH = ("WAIT_XY_ARRAY", "XY_APPEND", "GOTO")  # the mission's stream must not add to it
USERS_MOTION = (*USERS_PATH, "VELOCITY", "RESET_ROUTINE")  # the firmware's path is no longer the mission's


class Commands:
    def __init__(
        self,
        link: Link,
        restarts: Restarts,
        missions: Missions,
        routine: ResetRoutine,
        read_pose: Callable[[], tuple[float, float, float]],
        wake: Callable[[], None],
    ) -> None:
        """`read_pose`: POSE; `wake`: the monitor looks at STATUS now (monitor.py)."""
        self.link = link
        self.restarts = restarts
        self.missions = missions
        self.routine = routine
        self._read_pose = read_pose
        self._wake = wake

    def command(self, code: int, args: Sequence[float], token: int | None = None) -> Reply:
        """Sends the request and does what follows it (module docstring). A motion command
        belongs to `token` (see Missions.go_to)."""
        name = load_spec().name_of(code).removeprefix("COMMAND_")
        if name == "STOP" and not args:
            return self.missions.stop()
        if name == "REBOOT":
            return self._reboot(code, args)
        if name == "RESET_ROUTINE":
            x, y, theta = (firmware.read_setting(self.link, setting_id(n)) for n in RESET_POSE_SETTINGS)
        if name in USERS_PATH:
            self.missions.cancel_stream()
        if name in USERS_MOTION:
            self.missions.path_replaced()
        reply = self.link.request(code, args, token=token)
        if not reply.ok:
            return reply
        if name == "START":
            self.missions.resume(token)
        elif name == "SAVE":
            self.status_after_save()
        elif name in ("SET_POSE", "RESET"):
            self.restarts.trust(f"the pose was set to {pose_text(*self._read_pose())} with {name}")
        elif name == "RESET_ROUTINE":
            self.routine.start((x, y, theta))  # the mission it replaces ends (RoutineStarted)
            self._wake()
        return reply

    def _reboot(self, code: int, args: Sequence[float]) -> Reply:
        """A REBOOT restarts the MCU on purpose: its restart is the gateway's doing, waited for."""
        self.restarts.read_status()  # the baseline the restart is noticed against
        noticed = self.restarts.resets_noticed
        with self.restarts.resetting("a REBOOT sent through the gateway", certain=False):
            reply = self.link.request(code, args)
            if reply.ok:
                self.restarts.wait_for_restart(noticed, 5.0)
        return reply

    def status_after_save(self) -> None:
        # /api/status answers from the last STATUS read (status_cache.py): read one now, so that
        # from this answer on it shows the EEPROM busy, not the STATUS from before the SAVE.
        with contextlib.suppress(LinkError, CommandRefused):
            self.restarts.read_status()
