"""Restarts of the MCU and how far the gateway trusts the pose (docs/protocol.md, Reset causes).

Every STATUS the gateway reads goes through read_status(), in the order read: a restart shows as
a new boot count or an uptime that went backwards. The first STATUS is the baseline: opening a
Nano's port resets it. A restart ends any mission (the `abort_motion` the gateway gives), is told
to viewers and the log in words, and, unless the gateway asked for it and the firmware kept its
pose, leaves the pose untrusted: no goal is planned from it until the user sets the pose, runs
the reset routine or accepts the pose the firmware has.

The pose's trust is untrusted before the mission is ended, and read without a lock (a frozen
object, replaced whole): a goal planned meanwhile is either refused or ended by the restart."""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict

from cart2d.gateway.bus import EventBus, PoseCorrected, Restarted, ViewerMessage
from cart2d.gateway.messages import PoseTrustMessage, ResetMessage
from cart2d.gateway.state import WAYS_OUT, PoseOutsideArena, PoseTrust, ResetReport, pose_text
from cart2d.gateway.status_cache import StatusCache
from cart2d.link import CommandRefused, Link, LinkError, firmware

log = logging.getLogger(__name__)

Pose = tuple[float, float, float]


class Restarts:
    def __init__(
        self,
        link: Link,
        status_cache: StatusCache,
        bus: EventBus,
        read_pose: Callable[[], Pose],
        abort_motion: Callable[[str, str], tuple[float, float] | None],
        press_reset: Callable[[], None] | None = None,
    ) -> None:
        """`read_pose`: POSE, kept for /api/status; `abort_motion(reason, routine_reason)`: ends
        the mission and the reset routine a restart cut short, returns the mission's goal if one
        ended; `press_reset`: restarts the MCU as its reset button does (the simulator's), else
        soft_reset() sends REBOOT."""
        self.link = link
        self.status_cache = status_cache
        self.bus = bus
        self._read_pose = read_pose
        self._abort_motion = abort_motion
        self._press_reset = press_reset
        self._status_lock = threading.Lock()  # STATUS reads reach the watch in the order read
        self._lock = threading.Lock()  # guards what follows
        self._resets = firmware.ResetWatch()
        self._opens_seen = 0  # the link's port openings at the last STATUS
        self._expected_reset = ""  # what the gateway is doing that restarts the MCU, if anything
        self._expected_untrusts = ""  # why a pose kept through that restart is not trusted ("": it is)
        self.last_reset: ResetReport | None = None
        self.resets_noticed = 0
        self.pose_trust = PoseTrust()

    def read_status(self, restarted_for_sure: bool = False) -> firmware.Status:
        """STATUS, shown to the restart watch in the order read; a restart is handled here
        (`restarted_for_sure`: the gateway knows the MCU restarted since the last look)."""
        with self._status_lock:
            try:
                status = firmware.read_status(self.link)
            except (LinkError, CommandRefused) as exc:
                self.status_cache.read_failed(str(exc))
                raise
            self.status_cache.status_read(status)
            restarted = self._resets.saw(status) or restarted_for_sure
            reopened = self.link.opens != self._opens_seen
            self._opens_seen = self.link.opens
        if restarted:
            self._on_restart(status, reopened)
        return status

    def soft_reset(self) -> ResetReport | None:
        """Restarts the MCU (REBOOT; the reset button in the simulator) and waits until the
        restart is noticed; returns its report (None if it was not noticed within 5 s)."""
        self.read_status()  # the baseline it is compared with
        noticed = self.resets_noticed
        with self.resetting("a soft reset asked for through the gateway", certain=False):
            if self._press_reset is not None:
                self._press_reset()
            else:
                self.link.call("REBOOT")
            return self.wait_for_restart(noticed, 5.0)

    def wait_for_restart(self, noticed: int, wait_s: float) -> ResetReport | None:
        """Reads STATUS until a restart after the `noticed` ones is noticed; its report, or
        None after wait_s."""
        deadline = time.monotonic() + wait_s
        while self.resets_noticed == noticed and time.monotonic() < deadline:
            time.sleep(0.02)
            with contextlib.suppress(LinkError, CommandRefused):  # it may still be starting
                self.read_status()
        with self._lock:
            return self.last_reset if self.resets_noticed != noticed else None

    @contextlib.contextmanager
    def resetting(self, what: str, certain: bool, untrusts: str = "") -> Iterator[None]:
        """Restarts noticed inside the block are the gateway's doing (`what`), not faults.
        `certain`: the block restarts the MCU whatever STATUS shows (a new simulator, avrdude's
        reset), so a restart is reported at its end if none was noticed: a fresh MCU whose uptime
        has overtaken the old one's and whose boot count is 1 again looks like no restart.
        `untrusts`: why a pose the firmware restored from RAM is not trusted after this restart
        (a firmware update: FLASHED_POSE); "" when it is (a REBOOT, a soft reset of the same
        firmware at rest, over in a second)."""
        with self._lock:
            self._expected_reset = what
            self._expected_untrusts = untrusts
            noticed = self.resets_noticed
        try:
            yield
        finally:
            if self.link.connected.is_set():
                with contextlib.suppress(LinkError, CommandRefused):
                    self.read_status(certain and self.resets_noticed == noticed)  # while it is expected
            with self._lock:
                self._expected_reset = ""

    def set_pose(self, x: float, y: float, theta: float, arena: dict[str, float]) -> dict[str, float]:
        """SET_POSE from the user, who knows where the cart is (within `arena`, the map's walls):
        the pose is trusted again; PoseOutsideArena sends nothing."""
        if not (arena["x_min"] <= x <= arena["x_max"] and arena["y_min"] <= y <= arena["y_max"]):
            raise PoseOutsideArena(
                f"the pose ({x:.3f}, {y:.3f}) lies beyond the arena's walls (x from {arena['x_min']:g} "
                f"to {arena['x_max']:g} m, y from {arena['y_min']:g} to {arena['y_max']:g} m)"
            )
        self.link.call("SET_POSE", x, y, theta)
        pose = self._read_pose()
        self.trust(f"the pose was set to {pose_text(*pose)}")
        return dict(zip(("x", "y", "theta"), pose, strict=True))

    def accept_pose(self) -> tuple[dict[str, float], str]:
        """Trusts the pose the firmware has; returns it and what it is, in words."""
        status = self.read_status()
        pose = self._read_pose()
        where = pose_text(*pose)
        if self.pose_trust.trusted:
            words = f"the pose was trusted already: {where}"
        elif status.has("POSE_RESTORED"):
            words = (
                f"accepted the pose the firmware restored from RAM, {where}: the pose at the reset, "
                "blind to any motion during it"
            )
        else:
            words = (
                f"accepted the pose the firmware has, {where}: it restarted at (0, 0, 0) and has "
                "counted the motion since"
            )
        self.trust(words)
        return dict(zip(("x", "y", "theta"), pose, strict=True)), words

    def trust(self, how: str, corrected: PoseCorrected | None = None) -> None:
        """The pose is right again (`how`, in words: set, accepted, squared up, found at a
        marker: then `corrected` is the filter's event, published instead of a bare one)."""
        self.pose_trust = PoseTrust()
        log.info("pose trusted: %s", how)
        self.bus.publish(ViewerMessage(PoseTrustMessage(trusted=True, reason="", how=how)))
        self.bus.publish(corrected or PoseCorrected(how))

    def _on_restart(self, status: firmware.Status, reopened: bool) -> None:
        self.link.settings_may_change()  # the firmware loaded its settings from EEPROM again
        try:
            pose: Pose | None = self._read_pose()
        except (LinkError, CommandRefused):
            pose = None
        with self._lock:
            caused_by, untrusts = self._expected_reset, self._expected_untrusts
        port_reset = reopened and not caused_by and "EXTERNAL" in status.reset_cause
        # What reset it is known when the gateway did it or its port's opening did: the
        # flags' other possible triggers (the button, a hang) are then not listed.
        cause = status.reset_words(trigger_known=bool(caused_by) or port_reset)
        if port_reset:
            cause += " (here the link to the robot was lost and its port reopened)"
        restored = status.has("POSE_RESTORED")
        when = time.strftime("%H:%M:%S")
        if not (caused_by and restored and not untrusts):  # untrusted before the mission ends
            what = "kept the pose it had" if restored else "restarted at (0, 0, 0)"
            if restored and caused_by:
                what += f", not trusted after {caused_by} ({untrusts})"
            self.pose_trust = PoseTrust(False, f"the controller restarted at {when} ({cause}) and {what}")
        goal = self._abort_motion(
            f"the controller restarted: {cause}", "the controller restarted before it squared up"
        )
        report = self._report(status, cause, caused_by, untrusts, pose, goal, when)
        with self._lock:
            self.last_reset = report
            self.resets_noticed += 1
        trust = self.pose_trust
        if goal is not None:  # the firmware is idle after a restart, unless a path reached it since
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.stop()
        (log.info if caused_by else log.warning)("%s", report.message)
        self.bus.publish(ViewerMessage(ResetMessage(**asdict(report), pose_trust=asdict(trust))))
        self.bus.publish(Restarted(bool(caused_by), caused_by, trust.trusted, goal is not None))

    def _report(
        self,
        status: firmware.Status,
        cause: str,
        caused_by: str,
        untrusts: str,
        pose: Pose | None,
        goal: tuple[float, float] | None,
        when: str,
    ) -> ResetReport:
        """The restart in words and fields, for the log, /api/status and viewers."""
        restored = status.has("POSE_RESTORED")
        sentences = [
            f"The controller restarted at {when} (boot {status.boot_count}), "
            + (f"as the gateway asked ({caused_by}): " if caused_by else "unexpectedly: ")
            + f"{cause}."
        ]
        if goal is not None:
            sentences.append(f"The mission to ({goal[0]:.2f}, {goal[1]:.2f}) failed.")
        where = pose_text(*pose) if pose else "unknown"
        if restored:
            sentences.append(
                f"The firmware restored its pose from RAM, {where}: the pose at the reset, blind to any "
                "motion during it."
            )
            if caused_by and untrusts:
                sentences.append(f"It is not trusted after {caused_by}: {untrusts}.")
        else:
            sentences.append("Its pose restarted at (0, 0, 0).")
        if not self.pose_trust.trusted:
            sentences.append(f"No goal is planned from it until you {WAYS_OUT}.")
        return ResetReport(
            time=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            cause=list(status.reset_cause),
            cause_words=cause,
            expected=bool(caused_by),
            caused_by=caused_by,
            boot_count=status.boot_count,
            pose_restored=restored,
            pose=dict(zip(("x", "y", "theta"), pose, strict=True)) if pose else None,
            mission_ended=goal is not None,
            message=" ".join(sentences),
        )
