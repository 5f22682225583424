// The polar position controller (core/polar_controller): forward and reverse approach,
// saturation, the braking cap, the final approach, the 1 - |tan(heading error)| scaling and
// the look-ahead point.
//
// Gains are round numbers for hand computation, rho_kp = 1 /s, phase_kp = 4 /s (the defaults
// are in config/robot.toml); limits are the defaults: v_max = 0.5 m/s, w_max = pi rad/s,
// a_max = 1 m/s^2. The cart is at the origin heading +x
// unless a case says otherwise.
#include <gtest/gtest.h>

#include <cmath>

#include "polar_controller.hpp"

namespace {

constexpr double kPiD = 3.14159265358979323846;
const core::PolarGains kGains{1.0f, 4.0f};
const core::MotionLimits kLimits{0.5f, 3.14159265f, 1.0f};
const core::Pose kOrigin{};

// The heading error comes from an arctangent approximation good to 2e-5 rad (num.hpp), so
// omega = phase_kp * error is exact to phase_kp * 2e-5.
constexpr double kOmegaTolerance = 4.0 * 2e-5;

core::Approach final_point(float x, float y) { return core::Approach{x, y, 0.0f, true}; }
// A via point with `beyond_m` of the path received beyond it (by default far more than the
// braking distance from v_max: the window does not limit the speed).
core::Approach via_point(float x, float y, float exit_mps, float beyond_m = 10.0f) {
  core::Approach a{x, y, exit_mps, false};
  a.beyond_m = beyond_m;
  return a;
}

TEST(PolarController, TargetAheadDrivesForwardWithoutTurning) {
  // 0.2 m ahead: v = min(kp * 0.2 = 0.2, v_max 0.5, sqrt(2 * 1 * 0.2) = 0.632) = 0.2 m/s.
  const core::PolarOutput out = core::polar_control(kOrigin, final_point(0.2f, 0.0f), kGains, kLimits);
  EXPECT_NEAR(out.v_mps, 0.2f, 1e-5f);
  EXPECT_NEAR(out.omega_radps, 0.0f, 1e-5f);
  EXPECT_NEAR(out.rho_m, 0.2f, 1e-6f);
  EXPECT_FALSE(out.behind);
}

TEST(PolarController, TargetLeftTurnsLeftAndRightTurnsRight) {
  // Bearing atan2(0.2, 1) = 0.19740 rad -> omega = 4 * 0.19740 = 0.78961 rad/s (below w_max).
  const core::PolarOutput left = core::polar_control(kOrigin, final_point(1.0f, 0.2f), kGains, kLimits);
  EXPECT_GT(left.omega_radps, 0.0f);
  EXPECT_NEAR(left.omega_radps, 4.0 * std::atan2(0.2, 1.0), kOmegaTolerance);
  EXPECT_GT(left.v_mps, 0.0f);
  const core::PolarOutput right = core::polar_control(kOrigin, final_point(1.0f, -0.2f), kGains, kLimits);
  EXPECT_LT(right.omega_radps, 0.0f);
  EXPECT_NEAR(right.omega_radps, -left.omega_radps, 1e-5f);
}

TEST(PolarController, HeadingErrorIsRelativeToThePose) {
  // Cart at (1, 1) heading +y (pi/2); target at (1, 2): straight ahead in its own frame.
  const core::Pose pose{1.0f, 1.0f, static_cast<float>(kPiD / 2)};
  const core::PolarOutput out = core::polar_control(pose, final_point(1.0f, 1.3f), kGains, kLimits);
  EXPECT_NEAR(out.omega_radps, 0.0f, 1e-4f);
  EXPECT_NEAR(out.v_mps, 0.3f, 1e-4f);  // min(1 * 0.3, 0.5, sqrt(0.6) = 0.775)
  // Target to its left is -x in the world: (0.8, 1.3) -> bearing 123.7 deg, heading error
  // +33.7 deg = 0.58800 rad -> omega = 2.352 rad/s.
  const core::PolarOutput left = core::polar_control(pose, final_point(0.8f, 1.3f), kGains, kLimits);
  EXPECT_NEAR(left.omega_radps, 4.0 * std::atan2(0.2, 0.3), kOmegaTolerance);
}

TEST(PolarController, TargetExactlyBehindIsApproachedBackwards) {
  // The seed's reverse case: bearing pi, |error| > pi/2 -> rho := -rho, error := error + pi = 0.
  // v = -min(1 * 0.3, 0.5, sqrt(0.6)) = -0.3 m/s, no turning.
  const core::PolarOutput out = core::polar_control(kOrigin, final_point(-0.3f, 0.0f), kGains, kLimits);
  EXPECT_TRUE(out.behind);
  EXPECT_NEAR(out.rho_m, -0.3f, 1e-6f);
  EXPECT_NEAR(out.v_mps, -0.3f, 1e-5f);
  EXPECT_NEAR(out.omega_radps, 0.0f, 1e-4f);
}

TEST(PolarController, TargetBehindToTheLeftSwingsTheTailLeft) {
  // Target (-1, 0.2): bearing 168.69 deg, error folded to -11.31 deg = -0.19740 rad:
  // turning clockwise points the tail (-heading) towards +y, where the target is.
  const core::PolarOutput out = core::polar_control(kOrigin, final_point(-1.0f, 0.2f), kGains, kLimits);
  EXPECT_TRUE(out.behind);
  EXPECT_LT(out.v_mps, 0.0f);
  EXPECT_NEAR(out.rho_m, -std::hypot(1.0, 0.2), 1e-5);
  EXPECT_NEAR(out.omega_radps, -4.0 * std::atan2(0.2, 1.0), kOmegaTolerance);
}

// Reverse not allowed (setting reverse_allowed = 0, while the gateway sees with a camera that
// looks forwards only): a waypoint behind is faced first, turning on the spot, never backed to.
const core::PolarGains kForwardOnly{1.0f, 4.0f, false};

TEST(PolarController, ForwardOnlyTurnsOnTheSpotTowardsATargetBehind) {
  // Target (-1, 0.2): bearing 168.69 deg = 2.94419 rad to the left; 4 * 2.944 > w_max: +pi.
  const core::PolarOutput left = core::polar_control(kOrigin, final_point(-1.0f, 0.2f), kForwardOnly, kLimits);
  EXPECT_TRUE(left.behind);
  EXPECT_EQ(left.v_mps, 0.0f);
  EXPECT_NEAR(left.omega_radps, 3.14159265f, 1e-5f);
  EXPECT_NEAR(left.rho_m, -std::hypot(1.0, 0.2), 1e-5);  // still reported as behind
  // Mirrored: turns right.
  const core::PolarOutput right =
      core::polar_control(kOrigin, final_point(-1.0f, -0.2f), kForwardOnly, kLimits);
  EXPECT_EQ(right.v_mps, 0.0f);
  EXPECT_NEAR(right.omega_radps, -3.14159265f, 1e-5f);
  // A via point behind (the replanned path's first) too, and exactly behind: it turns (left).
  const core::PolarOutput via = core::polar_control(kOrigin, via_point(-0.5f, 0.0f, 0.5f), kForwardOnly, kLimits);
  EXPECT_EQ(via.v_mps, 0.0f);
  EXPECT_NEAR(via.omega_radps, 3.14159265f, 1e-5f);
}

TEST(PolarController, ForwardOnlyHeadingErrorBehindIsTheTrueAngle) {
  // Below saturation (phase_kp 0.5 /s): omega = 0.5 * 2.94419 rad (bearing of (-1, 0.2)).
  const core::PolarGains gentle{1.0f, 0.5f, false};
  const core::PolarOutput out = core::polar_control(kOrigin, final_point(-1.0f, 0.2f), gentle, kLimits);
  EXPECT_NEAR(out.omega_radps, 0.5 * std::atan2(0.2, -1.0), 0.5 * 2e-5);
}

TEST(PolarController, ForwardOnlyDrivesForwardsOnceFacingTheTarget) {
  // Having turned to face (-1, 0.2) (heading 168.69 deg), it drives forwards towards it.
  const core::Pose facing{0.0f, 0.0f, static_cast<float>(std::atan2(0.2, -1.0))};
  const core::PolarOutput out = core::polar_control(facing, final_point(-1.0f, 0.2f), kForwardOnly, kLimits);
  EXPECT_FALSE(out.behind);
  EXPECT_NEAR(out.v_mps, 0.5f, 1e-5f);
  EXPECT_NEAR(out.omega_radps, 0.0f, 1e-4f);
  // Half way round (90 deg off, target to the left): still only turning, never backwards.
  const core::Pose half{0.0f, 0.0f, static_cast<float>(std::atan2(0.2, -1.0) - kPiD / 2.0)};
  const core::PolarOutput turning = core::polar_control(half, final_point(-1.0f, 0.2f), kForwardOnly, kLimits);
  EXPECT_GE(turning.v_mps, 0.0f);
  EXPECT_LT(turning.v_mps, 1e-3f);
  EXPECT_GT(turning.omega_radps, 0.0f);
}

TEST(PolarController, ForwardOnlyStillClosesAnOvershootOfTheLastCentimetres) {
  // 1 cm past the final waypoint, on the heading line: it creeps back over ground it just drove.
  const core::PolarOutput out = core::polar_control(kOrigin, final_point(-0.01f, 0.0f), kForwardOnly, kLimits);
  EXPECT_NEAR(out.v_mps, -0.01f, 1e-6f);
  EXPECT_EQ(out.omega_radps, 0.0f);
}

TEST(PolarController, FoldingWorksAcrossThePiBoundary) {
  // Heading pi (facing -x), target at (+0.5, 0) is straight behind: backwards, no turn.
  const core::Pose pose{0.0f, 0.0f, static_cast<float>(kPiD)};
  const core::PolarOutput out = core::polar_control(pose, final_point(0.5f, 0.0f), kGains, kLimits);
  EXPECT_TRUE(out.behind);
  EXPECT_LT(out.v_mps, 0.0f);
  EXPECT_NEAR(out.omega_radps, 0.0f, 1e-4f);
  // Facing -pi + 0.1 with the target straight ahead of it (-x): not behind.
  const core::Pose pose2{0.0f, 0.0f, static_cast<float>(-kPiD + 0.1)};
  const core::PolarOutput out2 = core::polar_control(
      pose2, final_point(static_cast<float>(0.5 * std::cos(-kPiD + 0.1)), static_cast<float>(0.5 * std::sin(-kPiD + 0.1))),
      kGains, kLimits);
  EXPECT_FALSE(out2.behind);
  EXPECT_GT(out2.v_mps, 0.0f);
  EXPECT_NEAR(out2.omega_radps, 0.0f, 1e-3f);
}

TEST(PolarController, SpeedSaturatesAtVMax) {
  // 10 m ahead: kp * 10 = 10 m/s and the braking cap sqrt(16) = 4 m/s, both above v_max.
  for (const float x : {10.0f, -10.0f}) {
    const core::PolarOutput out = core::polar_control(kOrigin, final_point(x, 0.0f), kGains, kLimits);
    EXPECT_NEAR(std::fabs(out.v_mps), kLimits.v_max_mps, 1e-6f) << x;
  }
}

TEST(PolarController, TurnRateSaturatesAtWMax) {
  // Error 60 deg: 4 * 1.0472 = 4.19 rad/s > pi -> clamped to +-pi.
  const float c = static_cast<float>(std::cos(kPiD / 3)), s = static_cast<float>(std::sin(kPiD / 3));
  const core::PolarOutput left = core::polar_control(kOrigin, final_point(c, s), kGains, kLimits);
  EXPECT_NEAR(left.omega_radps, kLimits.w_max_radps, 1e-6f);
  const core::PolarOutput right = core::polar_control(kOrigin, final_point(c, -s), kGains, kLimits);
  EXPECT_NEAR(right.omega_radps, -kLimits.w_max_radps, 1e-6f);
}

TEST(PolarController, BrakingCapLetsTheCartSlowToTheExitSpeedInTime) {
  struct Case {
    float distance_m;
    float exit_mps;
    float a_max;
  };
  // A via point: no P law on its distance, so only the cap (or v_max) can bind. The cap plans
  // to brake at 0.8 a_max (the wheels' lag): v <= sqrt(exit^2 + 2 * 0.8 a d), e.g. d = 0.05,
  // exit 0.1, a 1: sqrt(0.01 + 0.08) = 0.3 m/s.
  for (const Case c : {Case{0.05f, 0.1f, 1.0f}, Case{0.02f, 0.0f, 1.0f}, Case{0.1f, 0.2f, 0.5f},
                       Case{0.3f, 0.0f, 0.2f}, Case{1.0f, 0.0f, 1.0f}}) {
    const core::MotionLimits limits{0.5f, 3.14159265f, c.a_max};
    const core::PolarOutput out =
        core::polar_control(kOrigin, via_point(c.distance_m, 0.0f, c.exit_mps), kGains, limits);
    const double cap = std::sqrt(c.exit_mps * c.exit_mps + 2.0 * 0.8 * c.a_max * c.distance_m);
    SCOPED_TRACE(testing::Message() << "d=" << c.distance_m << " exit=" << c.exit_mps << " a=" << c.a_max);
    EXPECT_LE(out.v_mps, cap + 1e-5);
    EXPECT_NEAR(out.v_mps, std::fmin(cap, 0.5), 1e-5);  // the cap or v_max, whichever is lower
  }
}

TEST(PolarController, ViaPointIsPassedAtSpeedWhenThePathGoesOn) {
  // 0.05 m from a straight-on via point (exit = v_max): no P law, cap sqrt(0.25 + 0.08) = 0.57
  // -> v = v_max = 0.5.
  const core::PolarOutput out = core::polar_control(kOrigin, via_point(0.05f, 0.0f, 0.5f), kGains, kLimits);
  EXPECT_NEAR(out.v_mps, 0.5f, 1e-5f);
  // The same point as the FINAL one: min(kp * 0.05, sqrt(0.1)) = 0.05.
  const core::PolarOutput stop = core::polar_control(kOrigin, final_point(0.05f, 0.0f), kGains, kLimits);
  EXPECT_NEAR(stop.v_mps, 0.05f, 1e-5f);
}

TEST(PolarController, TheCartCanAlwaysStopWhereTheReceivedPointsEnd) {
  // A straight-on via point 0.05 m ahead with `beyond` received after it: the speed is capped
  // to sqrt(2 * 0.8 * a * (0.05 + beyond)); `stopping` says the cap is below v_max.
  struct Case {
    float beyond_m;
    float expected_mps;
    bool stopping;
  };
  const Case cases[] = {
      {0.0f, 0.28284271f, true},    // sqrt(1.6 * 0.05)
      {0.05f, 0.4f, true},          // sqrt(1.6 * 0.1)
      {0.1f, 0.48989795f, true},    // sqrt(1.6 * 0.15)
      {0.107f, 0.5f, false},        // 1.6 * 0.157 > 0.25: v_max
      {10.0f, 0.5f, false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.beyond_m);
    const core::PolarOutput out =
        core::polar_control(kOrigin, via_point(0.05f, 0.0f, 0.5f, c.beyond_m), kGains, kLimits);
    EXPECT_NEAR(out.v_mps, c.expected_mps, 1e-5f);
    EXPECT_EQ(out.stopping, c.stopping);
  }
  EXPECT_TRUE(core::polar_control(kOrigin, final_point(1.0f, 0.0f), kGains, kLimits).stopping);
}

TEST(PolarController, FinalApproachStopsSteeringAndClosesAlongTheHeading) {
  struct Case {
    float x;
    float y;
    float expected_v;  // sign(along) * min(kp |along|, sqrt(2 a |along|), v_max), along = x here
  };
  // All inside kFinalApproachRadius (0.02 m) and within 45 deg of the heading line.
  // (0.01, 0.005): along = 0.01 -> v = 0.01; (-0.01, 0.005): the target is behind,
  // along = -0.01 -> v = -0.01 (backs up, no turn); (-0.015, -0.01): behind, 33.7 deg off the
  // line -> v = -0.015.
  for (const Case c : {Case{0.01f, 0.005f, 0.01f}, Case{-0.01f, 0.005f, -0.01f}, Case{0.012f, -0.011f, 0.012f},
                       Case{-0.015f, -0.01f, -0.015f}}) {
    ASSERT_LT(std::hypot(c.x, c.y), core::kFinalApproachRadius_m);
    const core::PolarOutput out = core::polar_control(kOrigin, final_point(c.x, c.y), kGains, kLimits);
    SCOPED_TRACE(testing::Message() << c.x << "," << c.y);
    EXPECT_EQ(out.omega_radps, 0.0f);
    EXPECT_NEAR(out.v_mps, c.expected_v, 1e-6f);
  }
}

TEST(PolarController, FinalApproachAlongTrackUsesTheCartHeading) {
  // Cart heading +y: the target at (0.005, 0.01) is 0.01 m ahead along y, v = +0.01.
  const core::Pose pose{0.0f, 0.0f, static_cast<float>(kPiD / 2)};
  const core::PolarOutput out = core::polar_control(pose, final_point(0.005f, 0.01f), kGains, kLimits);
  EXPECT_EQ(out.omega_radps, 0.0f);
  EXPECT_NEAR(out.v_mps, 0.01f, 1e-6f);
}

TEST(PolarController, FinalWaypointCloseButAbeamIsStillTurnedTowards) {
  // 0.015 m away but 86 deg to the left: closing "along the heading" would stop the cart
  // abeam of it, 0.015 m away (> tol_final) for ever. It must turn towards it instead:
  // omega = clamp(4 * 1.504 rad, +-pi) = pi, and v = 0 (beyond 45 deg it turns on the spot).
  const core::PolarOutput left = core::polar_control(kOrigin, final_point(0.001f, 0.015f), kGains, kLimits);
  EXPECT_GT(left.omega_radps, 1.0f);
  EXPECT_NEAR(left.v_mps, 0.0f, 1e-6f);
  // Behind and to the right, 70 deg off the (backward) heading line: turns too.
  const core::PolarOutput behind = core::polar_control(kOrigin, final_point(-0.005f, -0.014f), kGains, kLimits);
  EXPECT_TRUE(behind.behind);
  EXPECT_NE(behind.omega_radps, 0.0f);
}

TEST(PolarController, ViaPointNearbyStillSteers) {
  // The final-approach rule is only for the last waypoint: a via point 0.011 m away at
  // 26.6 deg is still steered for: omega = 4 * atan2(0.005, 0.01) = 1.8546 rad/s.
  const core::PolarOutput out = core::polar_control(kOrigin, via_point(0.01f, 0.005f, 0.5f), kGains, kLimits);
  EXPECT_NEAR(out.omega_radps, 4.0 * std::atan2(0.005, 0.01), kOmegaTolerance);
}

TEST(PolarController, SpeedFallsWithTheHeadingErrorAndIsZeroFrom45Degrees) {
  // Same distance 0.3 m (v before the heading factor = min(0.3, 0.5, 0.775) = 0.3). The factor
  // is 1 - |tan e|: at 20 deg 1 - 0.36397 = 0.63603, so v = 0.19081; from 45 deg on the cart
  // turns on the spot (v = 0).
  const auto at = [](double degrees) {
    const double a = degrees * kPiD / 180.0;
    return core::polar_control(
        kOrigin, final_point(static_cast<float>(0.3 * std::cos(a)), static_cast<float>(0.3 * std::sin(a))), kGains,
        kLimits);
  };
  EXPECT_NEAR(at(0).v_mps, 0.3f, 1e-5f);
  EXPECT_NEAR(at(20).v_mps, 0.3 * 0.63603, 1e-4);
  EXPECT_GT(at(40).v_mps, 0.0f);
  EXPECT_NEAR(at(50).v_mps, 0.0f, 1e-6f);
  EXPECT_NEAR(at(90).v_mps, 0.0f, 1e-6f);
  EXPECT_GT(at(50).omega_radps, 1.0f);  // turning towards it meanwhile
}

TEST(PolarController, OffTheLineItSteersForTheLookAheadPointOnTheSegment) {
  // Segment along +x into (1, 0); the cart at (0.2, 0.1) heading +x. The waypoint lies 0.8 m
  // ahead along the segment, beyond the 0.15 m look-ahead: the aim is (0.35, 0), i.e. 0.15 m
  // ahead and 0.1 m to the right: omega = 4 * atan2(-0.1, 0.15) = -2.3522 rad/s (towards the
  // line; steering for the waypoint would give only 4 * atan2(-0.1, 0.8) = -0.4974).
  core::Approach target = final_point(1.0f, 0.0f);
  target.dir_x = 1.0f;
  target.dir_y = 0.0f;
  const core::Pose off{0.2f, 0.1f, 0.0f};
  const core::PolarOutput out = core::polar_control(off, target, kGains, kLimits);
  EXPECT_NEAR(out.omega_radps, 4.0 * std::atan2(-0.1, 0.15), kOmegaTolerance);
  EXPECT_NEAR(out.rho_m, std::hypot(0.8, 0.1), 1e-5);  // speeds still follow the waypoint
  // Within the look-ahead of the waypoint it steers for the waypoint itself.
  const core::Pose near{0.9f, 0.05f, 0.0f};
  EXPECT_NEAR(core::polar_control(near, target, kGains, kLimits).omega_radps, 4.0 * std::atan2(-0.05, 0.1),
              kOmegaTolerance);
}

}  // namespace
