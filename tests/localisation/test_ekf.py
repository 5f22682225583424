"""The pose filter against simulated truth (a seeded random walk, no simulator, no clock): its
errors are as large as its covariance says (NEES within the χ² bounds), a fix far off is doubted,
a carried cart is found again."""

from __future__ import annotations

import math

import numpy as np

from cart2d.localisation.ekf import Pose2, PoseFilter, between, compose, inverse, to_map, to_odom, wrap

FIX_COVARIANCE = np.diag([0.01**2, 0.015**2, math.radians(1.5) ** 2])
RUNS, STEPS, FIX_EVERY = 40, 200, 10
# χ²(3·RUNS) / RUNS at 0.5 % and 99.5 %: the bounds of the NEES averaged over the runs at one step
NEES_LOW, NEES_HIGH = 2.16, 3.98


def noisy_step(rng: np.random.Generator, step: Pose2, noise: tuple[float, float, float]) -> Pose2:
    """The odometry's step: the true one with the noise the filter's model says it has."""
    dx, dy, dth = step
    d = math.hypot(dx, dy)
    a_d, a_t, a_td = noise
    sd, st = a_d * d, a_t * abs(dth) + a_td * d
    return dx + rng.normal(0, sd), dy + rng.normal(0, sd), dth + rng.normal(0, st)


def error_of(f: PoseFilter, truth: Pose2) -> np.ndarray:
    assert f.pose is not None
    return np.array([f.pose[0] - truth[0], f.pose[1] - truth[1], wrap(f.pose[2] - truth[2])])


def run(seed: int) -> list[float]:
    rng = np.random.default_rng(seed)
    f = PoseFilter()
    truth: Pose2 = (0.0, 0.0, 0.0)
    odom: Pose2 = (0.3, -0.2, 0.1)  # odometry's origin is not map's
    f.start_at(truth, np.diag([1e-6, 1e-6, 1e-6]), odom)
    nees = []
    for k in range(STEPS):
        step = (0.02, 0.0, 0.15 * math.sin(k / 15.0))
        truth = compose(truth, step)
        odom = compose(odom, noisy_step(rng, step, f.noise))
        f.predict(odom)
        if k % FIX_EVERY == FIX_EVERY - 1:
            z = tuple(np.array(truth) + rng.multivariate_normal(np.zeros(3), FIX_COVARIANCE))
            f.update((z[0], z[1], z[2]), FIX_COVARIANCE)
        e = error_of(f, truth)
        nees.append(float(e @ np.linalg.solve(f.covariance, e)))
    assert f.rejected <= 1  # the gate is at 99.9 %: one good fix in a thousand is doubted
    return nees


def test_the_errors_are_as_large_as_the_covariance_says() -> None:
    nees = np.array([run(seed) for seed in range(RUNS)]).mean(axis=0)
    inside = np.mean((nees > NEES_LOW) & (nees < NEES_HIGH))
    assert inside > 0.95, f"the averaged NEES within its 99 % bounds at {inside:.0%} of the steps"
    assert 2.6 < nees.mean() < 3.4


def test_a_fix_far_from_the_prediction_is_doubted() -> None:
    f = PoseFilter()
    f.start_at((1.0, 1.0, 0.0), np.diag([1e-4, 1e-4, 1e-4]), (0.0, 0.0, 0.0))
    assert f.update((1.5, 1.0, 0.0), FIX_COVARIANCE) == "doubted"
    assert f.pose == (1.0, 1.0, 0.0)
    assert f.update((1.01, 1.0, 0.0), FIX_COVARIANCE) == "accepted"


def test_a_cart_carried_elsewhere_is_found_at_its_first_tag_and_again_when_carried() -> None:
    f = PoseFilter()
    f.predict((0.0, 0.0, 0.0))
    assert not f.trusted and f.map_to_odom() is None
    assert f.update((2.0, 1.0, math.pi / 2), FIX_COVARIANCE) == "started"
    assert f.map_to_odom() == (2.0, 1.0, math.pi / 2)
    # carried 1 m away: the fixes disagree with the odometry, then agree among themselves
    odom: Pose2 = (0.0, 0.0, 0.0)
    outcomes = []
    for _ in range(5):
        odom = compose(odom, (0.05, 0.0, 0.0))
        f.predict(odom)
        truth = compose((3.0, 1.0, math.pi / 2), odom)
        outcomes.append(f.update(truth, FIX_COVARIANCE))
    assert outcomes[:3] == ["doubted"] * 3 and outcomes[3] == "rejoined"
    assert f.pose is not None and abs(f.pose[0] - 3.0) < 1e-9


def test_map_and_odom_poses_are_each_others_inverse() -> None:
    m2o = (0.5, -0.25, 0.7)
    p = (1.0, 2.0, -0.3)
    back = to_map(m2o, to_odom(m2o, p))
    assert np.allclose(back, p)
    assert np.allclose(between(p, compose(p, (0.1, 0.2, 0.3))), (0.1, 0.2, 0.3))
    assert np.allclose(compose(p, inverse(p)), (0.0, 0.0, 0.0))
