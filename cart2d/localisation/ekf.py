"""The cart's pose in `map`: an extended Kalman filter of (x, y, θ) with the odometry's steps as
the motion and tag fixes as measurements (docs/localisation.md, "Fusion").

A short implementation rather than filterpy (unreleased since 2018): the state is three numbers,
the motion a compounding of poses, the measurement the pose itself (H = I), so the filter is the
textbook's few lines (Thrun, Burgard & Fox, Probabilistic Robotics, 3.3 and 5.4).

The motion's noise grows with what the wheels did: the distance's sigma in proportion to the
distance, the heading's to the turn and the distance (ODOMETRY_NOISE, a slipping wheel's worth). A fix whose
Mahalanobis distance from the prediction is beyond the χ² gate (3 degrees of freedom, 99.9 %) is
doubted, not believed; FIXES_TO_REJOIN such fixes in a row that agree with each other mean the
cart was carried: the filter starts again from the last of them.

The result is `map → odom`: the firmware keeps its continuous odometry (odom → base_link), and
map → odom = map → base ⊕ (odom → base)⁻¹.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Pose2 = tuple[float, float, float]

GATE_CHI2 = 16.27  # χ²(3) at 99.9 %
FIXES_TO_REJOIN = 4
REJOIN_AGREE_M = 0.1  # the doubted fixes that mean a carried cart lie this close together
REJOIN_AGREE_RAD = math.radians(10.0)
# (a_dist, a_turn, a_turn_per_m): a step's sigma of distance a_dist |d|,
# of turn a_turn |dth| + a_turn_per_m |d|
# a_turn_per_m: a wheel slipping 2.5 % more than the other turns the cart 0.08 rad per metre
ODOMETRY_NOISE = (0.05, 0.05, math.radians(12.0))
MIN_STEP_VARIANCE = 1e-10


def wrap(angle: float) -> float:
    return math.remainder(angle, math.tau)


def compose(a: Pose2, b: Pose2) -> Pose2:
    """a ⊕ b: the pose b, given in a's frame, in a's parent's."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2])


def inverse(a: Pose2) -> Pose2:
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], wrap(-a[2])


def between(a: Pose2, b: Pose2) -> Pose2:
    """a⁻¹ ⊕ b: b in a's frame (an odometry step from a to b)."""
    return compose(inverse(a), b)


@dataclass
class PoseFilter:
    """The pose of base_link in `map` and its covariance; None until the first fix."""

    noise: tuple[float, float, float] = ODOMETRY_NOISE
    gate_chi2: float = GATE_CHI2
    pose: Pose2 | None = None
    covariance: FloatArray = field(default_factory=lambda: np.diag([1e6, 1e6, 10.0]))
    odom: Pose2 | None = None  # the odometry pose the state was last brought to
    doubted: list[Pose2] = field(default_factory=list)  # the doubted fixes' map -> odom
    accepted: int = 0
    rejected: int = 0

    @property
    def trusted(self) -> bool:
        return self.pose is not None

    def forget(self) -> None:
        """The cart may be anywhere (a restart, carried): untrusted until the next fix."""
        self.pose, self.odom = None, None
        self.covariance = np.diag([1e6, 1e6, 10.0])
        self.doubted.clear()

    def start_at(self, pose: Pose2, covariance: FloatArray, odom: Pose2 | None = None) -> None:
        """A pose set by the user (or accepted): believed as it is."""
        self.pose, self.covariance, self.odom = pose, np.array(covariance, dtype=np.float64), odom
        self.doubted.clear()

    def predict(self, odom: Pose2) -> None:
        """The odometry's pose now: the state moves by the step since the last one."""
        if self.odom is None or self.pose is None:
            self.odom = odom
            return
        step = between(self.odom, odom)
        self.odom = odom
        dx, dy, dth = step
        th = self.pose[2]
        c, s = math.cos(th), math.sin(th)
        f = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy], [0.0, 0.0, 1.0]])
        g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # step (in base) -> map
        d = math.hypot(dx, dy)
        a_d, a_t, a_td = self.noise
        q = np.diag(
            [
                (a_d * d) ** 2 + MIN_STEP_VARIANCE,
                (a_d * d) ** 2 + MIN_STEP_VARIANCE,
                (a_t * abs(dth) + a_td * d) ** 2 + MIN_STEP_VARIANCE,
            ]
        )
        self.pose = compose(self.pose, step)
        self.covariance = f @ self.covariance @ f.T + g @ q @ g.T

    def innovation(self, z: Pose2) -> tuple[FloatArray, FloatArray]:
        assert self.pose is not None
        y = np.array([z[0] - self.pose[0], z[1] - self.pose[1], wrap(z[2] - self.pose[2])])
        return y, self.covariance

    def update(self, z: Pose2, r: FloatArray) -> str:
        """A fix z (x, y, θ in map) with covariance r: 'started', 'accepted', 'doubted' or 'rejoined'."""
        if self.pose is None:
            self.start_at(z, r, self.odom)
            self.accepted += 1
            return "started"
        y, p = self.innovation(z)
        s = p + r
        d2 = float(y @ np.linalg.solve(s, y))
        if d2 > self.gate_chi2:
            self.rejected += 1
            # kept as the map -> odom each implies: a carried cart's fixes agree on that as it drives
            self.doubted.append(compose(z, inverse(self.odom)) if self.odom is not None else z)
            recent = self.doubted[-FIXES_TO_REJOIN:]
            if len(recent) == FIXES_TO_REJOIN and _together(recent, self.odom):
                self.start_at(z, r, self.odom)
                return "rejoined"
            return "doubted"
        self.doubted.clear()
        k = p @ np.linalg.inv(s)
        dx = k @ y
        self.pose = (self.pose[0] + dx[0], self.pose[1] + dx[1], wrap(self.pose[2] + dx[2]))
        i_kh = np.eye(3) - k
        self.covariance = i_kh @ p @ i_kh.T + k @ r @ k.T  # Joseph form: stays symmetric, positive
        self.accepted += 1
        return "accepted"

    def map_to_odom(self) -> Pose2 | None:
        """map → odom: where the odometry's origin lies in `map`."""
        if self.pose is None or self.odom is None:
            return None
        return compose(self.pose, inverse(self.odom))


def _together(maps_to_odom: list[Pose2], odom: Pose2 | None) -> bool:
    """Whether the doubted fixes put the cart in one place now: each one's map -> odom applied
    to the odometry's pose now (their translations alone differ by the distance to odom's origin
    times the fixes' small heading errors)."""
    here = [compose(m, odom) if odom is not None else m for m in maps_to_odom]
    xs = [p[0] for p in here]
    ys = [p[1] for p in here]
    turns = [wrap(p[2] - here[0][2]) for p in here]
    return (
        max(xs) - min(xs) < REJOIN_AGREE_M
        and max(ys) - min(ys) < REJOIN_AGREE_M
        and max(turns) - min(turns) < REJOIN_AGREE_RAD
    )


def to_map(map_to_odom: Pose2, odom_pose: Pose2) -> Pose2:
    return compose(map_to_odom, odom_pose)


def to_odom(map_to_odom: Pose2, map_pose: Pose2) -> Pose2:
    return compose(inverse(map_to_odom), map_pose)
