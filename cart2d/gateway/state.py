"""What the gateway knows besides the map: the mission, the reset routine as started through
it, how far it trusts the pose, the restarts it noticed, and the errors that
refuse a goal."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

from cart2d.planning import Plan, PlanError

MissionState = Literal["idle", "driving", "arrived", "failed"]
MissionEnd = Literal["arrived", "failed"]
RoutineState = Literal["idle", "running", "done", "failed"]
RoutineEnd = Literal["done", "failed"]


class PathTooLong(PlanError):
    """More waypoints than a firmware path holds (docs/protocol.md: 65 535)."""


class PoseOutsideArena(PlanError):
    """A pose the user gave that lies beyond the arena's walls."""


class Refused(RuntimeError):
    """The gateway refuses what it was asked, now, and the sentence says why (the API's 409)."""


class PoseUntrusted(Refused):
    """No goal is planned from a pose the gateway knows may be wrong (after an MCU restart)."""


STATUS_POLL_S = 0.25  # STATUS reads while nothing moves: a restart is noticed within this
BUSY_POLL_S = 0.1  # while a mission or the reset routine runs
# How far the pose may lie from the configured reset pose once the reset routine ended for it
# to count as squared up (the cart rests against the wall; a stop before that leaves it far off).
ROUTINE_POSE_TOLERANCE_M = 0.005
ROUTINE_HEADING_TOLERANCE_RAD = 0.01
RESET_POSE_SETTINGS = ("reset_x_m", "reset_y_m", "reset_theta_rad")
WAYS_OUT = "set the pose, run the reset routine, or accept the pose the firmware has"


def pose_text(x: float, y: float, theta: float) -> str:
    return f"({x:.3f} m, {y:.3f} m, {math.degrees(theta):.1f}°)"


@dataclass(frozen=True)
class ResetReport:
    """An MCU restart the gateway noticed, for the log, /api/status and viewers."""

    time: str  # when the gateway noticed it, ISO 8601 UTC
    cause: list[str]  # STATUS reset_cause (docs/protocol.md, Reset causes)
    cause_words: str
    expected: bool  # the gateway caused it (a soft reset, a firmware update)
    caused_by: str  # what the gateway did, if it did
    boot_count: int
    pose_restored: bool  # flag POSE_RESTORED: the pose at the reset, from RAM
    pose: dict[str, float] | None  # the firmware's pose once it restarted
    mission_ended: bool
    message: str  # all of the above in sentences


@dataclass(frozen=True)
class PoseTrust:
    trusted: bool = True
    reason: str = ""  # why not, in words

    def refusal(self) -> str:
        return (
            f"the pose is not trusted: {self.reason}; {WAYS_OUT} (POST /api/pose, "
            "/api/pose/reset-routine or /api/pose/accept) before the next goal"
        )


@dataclass(frozen=True)
class Routine:
    """The reset routine as started through the gateway."""

    state: RoutineState = "idle"
    words: str = ""
    expected_pose: tuple[float, float, float] | None = None


@dataclass
class Mission:
    state: MissionState = "idle"
    goal: tuple[float, float] | None = None
    reason: str = ""
    started_s: float = 0.0
    ended_s: float = 0.0
    plan: Plan | None = field(default=None, repr=False)  # rendered for people by Gateway.mission_view
    # Ended by a stop with its path still in the firmware: a START resumes it (Gateway.command).
    resumable: bool = False
    # The route in the firmware: where it started and its waypoints as sent; the stop generation
    # of the request that began the mission (a replan sent after a stop is refused); a count of
    # the paths sent (a STATUS asked for before a replacement says nothing about it); replans.
    token: int | None = None
    route_start: tuple[float, float] = (0.0, 0.0)
    route: tuple[tuple[float, float], ...] = ()
    via: tuple[tuple[float, float], ...] = ()  # stops before the goal not passed yet (through.py)
    generation: int = 0
    replans: list[Any] = field(default_factory=list, repr=False)
    last_replan_s: float = 0.0


SimulatorRun = Literal["running", "restarting", "failed"]


@dataclass(frozen=True)
class SimulatorState:
    """The simulator a gateway drives (cart2d sim; its supervisor, cart2d/simulation/supervisor.py):
    whether it runs, and its restarts after it exited on its own (a crash, a kill from outside).
    Here, not in the simulation package, as /api/status and the /ws `simulator` message show it."""

    state: SimulatorRun = "running"
    restarts: int = 0  # times the supervisor started it again after it exited
    message: str = ""  # the last exit and restart, in sentences
