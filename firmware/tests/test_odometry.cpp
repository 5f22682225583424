// Dead reckoning (core/odometry): hand-computed poses and speeds from encoder counts.
//
// Reference robot (config/robot.toml): measuring-wheel radius r = 0.021 m, track B = 0.305 m,
// 1000 pulses x 2 edges = 2000 counts per revolution, h = 8 ms. One count is
//   2*pi*r/2000 = 2*pi*0.021/2000 = 6.5973e-5 m of wheel travel.
// Expected values are computed in double from those formulas, never taken from the code.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <ostream>
#include <string>

#include "odometry.hpp"

namespace {

constexpr double kPiD = 3.14159265358979323846;
constexpr double kRadius = 0.021;
constexpr double kTrack = 0.305;
constexpr double kCountsPerRev = 2000.0;
constexpr double kH = 0.008;
constexpr double kMetresPerCount = 2.0 * kPiD * kRadius / kCountsPerRev;  // 6.5973e-5 m

const core::WheelGeometry kReference{0.021f, 0.021f, 0.305f, 2000.0f};

// Feed the same counts for n ticks.
void run(core::Odometry& odo, int16_t left, int16_t right, int n, const core::WheelGeometry& g = kReference,
         float h = static_cast<float>(kH)) {
  for (int i = 0; i < n; ++i) odo.update(left, right, g, h);
}

TEST(Odometry, StartsAtTheOriginStandingStill) {
  core::Odometry odo;
  EXPECT_EQ(odo.pose().x_m, 0.0f);
  EXPECT_EQ(odo.pose().y_m, 0.0f);
  EXPECT_EQ(odo.pose().theta_rad, 0.0f);
  EXPECT_EQ(odo.v_mps(), 0.0f);
  EXPECT_EQ(odo.omega_radps(), 0.0f);
}

TEST(Odometry, EqualCountsDriveStraightAlongTheHeading) {
  struct Case {
    int16_t counts;
    int ticks;
  };
  // 100 counts x 50 ticks = 5000 counts = 2.5 rev -> 5000 * 6.5973e-5 = 0.32987 m.
  for (const Case c : {Case{100, 50}, Case{1, 2000}, Case{-37, 120}}) {
    core::Odometry odo;
    run(odo, c.counts, c.counts, c.ticks);
    const double expected_x = c.ticks * c.counts * kMetresPerCount;
    SCOPED_TRACE(c.counts);
    EXPECT_NEAR(odo.pose().x_m, expected_x, 1e-5 * std::fabs(expected_x) + 1e-7);
    EXPECT_EQ(odo.pose().y_m, 0.0f);
    EXPECT_EQ(odo.pose().theta_rad, 0.0f);
  }
}

TEST(Odometry, StraightLineFollowsAnInitialHeading) {
  // Heading 30 deg, 1000 counts per wheel: 0.065973 m along (cos 30, sin 30) = (0.057134, 0.032987).
  core::Odometry odo;
  odo.set_pose(core::Pose{1.0f, -2.0f, static_cast<float>(kPiD / 6.0)});
  run(odo, 100, 100, 10);
  const double d = 1000 * kMetresPerCount;
  EXPECT_NEAR(odo.pose().x_m, 1.0 + d * std::cos(kPiD / 6.0), 1e-6);
  EXPECT_NEAR(odo.pose().y_m, -2.0 + d * std::sin(kPiD / 6.0), 1e-6);
  EXPECT_NEAR(odo.pose().theta_rad, kPiD / 6.0, 1e-6);
}

TEST(Odometry, OppositeCountsRotateInPlace) {
  // -50 / +50 counts: ds_r - ds_l = 100 * 6.5973e-5 = 6.5973e-3 m -> dtheta = 6.5973e-3 / 0.305
  // = 0.021631 rad per tick; 20 ticks = 0.43261 rad. The midpoint ds is exactly 0.
  core::Odometry odo;
  odo.set_pose(core::Pose{0.5f, 0.25f, 0.0f});
  run(odo, -50, 50, 20);
  EXPECT_NEAR(odo.pose().theta_rad, 20 * 100 * kMetresPerCount / kTrack, 1e-5);
  EXPECT_EQ(odo.pose().x_m, 0.5f);
  EXPECT_EQ(odo.pose().y_m, 0.25f);

  // And back clockwise with the roles swapped: theta returns to 0.
  run(odo, 50, -50, 20);
  EXPECT_NEAR(odo.pose().theta_rad, 0.0, 1e-5);
  EXPECT_EQ(odo.pose().x_m, 0.5f);
}

// Constant counts per tick drive a circular arc of radius R = ds / dtheta. Starting at the
// origin heading +x, after heading change phi the exact pose is
//   x = R sin(phi),  y = R (1 - cos(phi)),  theta = phi.
// Midpoint integration moves each step along the chord direction exactly but by the arc length
// ds instead of the chord 2R sin(dtheta/2): a relative length error of dtheta^2/24 per step,
// so the position error is at most (path length) * dtheta^2 / 24 (plus float rounding).
struct ArcCase {
  const char* name;
  int16_t left;
  int16_t right;
  int ticks;
  core::WheelGeometry geometry;
};

void PrintTo(const ArcCase& c, std::ostream* os) { *os << c.name << " (" << c.left << ", " << c.right << ") x " << c.ticks; }

class OdometryArc : public ::testing::TestWithParam<ArcCase> {};

TEST_P(OdometryArc, MatchesTheExactCircularArc) {
  const ArcCase& c = GetParam();
  const double ds_l = c.left * 2.0 * kPiD * c.geometry.radius_left_m / c.geometry.counts_per_rev;
  const double ds_r = c.right * 2.0 * kPiD * c.geometry.radius_right_m / c.geometry.counts_per_rev;
  const double ds = 0.5 * (ds_l + ds_r);
  const double dtheta = (ds_r - ds_l) / c.geometry.track_m;
  ASSERT_NE(dtheta, 0.0);
  const double radius = ds / dtheta;
  const double phi = c.ticks * dtheta;

  core::Odometry odo;
  run(odo, c.left, c.right, c.ticks, c.geometry);

  const double path_length = std::fabs(ds) * c.ticks;
  const double tol = path_length * dtheta * dtheta / 24.0 + 2e-4;
  EXPECT_NEAR(odo.pose().x_m, radius * std::sin(phi), tol);
  EXPECT_NEAR(odo.pose().y_m, radius * (1.0 - std::cos(phi)), tol);
  EXPECT_NEAR(odo.pose().theta_rad, std::remainder(phi, 2.0 * kPiD), 1e-4);
}

const core::WheelGeometry kCalibrated{0.0205f, 0.0215f, 0.301f, 2000.0f};

INSTANTIATE_TEST_SUITE_P(
    Arcs, OdometryArc,
    ::testing::Values(
        // 80/120 counts: R = B/2 * (120+80)/(120-80) = 0.1525 * 5 = 0.7625 m, dtheta = 8.652e-3
        // rad per tick; 300 ticks = 2.5957 rad (past +pi/2, the quadrant changes).
        ArcCase{"left_turn", 80, 120, 300, kReference},
        // Mirror image: turns right, y < 0.
        ArcCase{"right_turn", 120, 80, 300, kReference},
        // Reversing on an arc: both counts negative, the cart backs around to its right.
        ArcCase{"reverse_arc", -60, -20, 400, kReference},
        // Arc crossing the +-pi boundary: 10/90 counts, R = 0.1525 * 100/80 = 0.19063 m,
        // dtheta = 80 * 6.5973e-5 / 0.305 = 0.017304 rad; 250 ticks = 4.3261 rad > pi.
        ArcCase{"past_pi", 10, 90, 250, kReference},
        // Calibrated unequal radii (UMBmark): equal counts still turn, because the right wheel
        // is larger: ds_r - ds_l = 100 * 2 pi (0.0215 - 0.0205) / 2000 per tick.
        ArcCase{"unequal_radii_equal_counts", 100, 100, 300, kCalibrated}),
    [](const ::testing::TestParamInfo<ArcCase>& info) { return std::string(info.param.name); });

TEST(Odometry, FullCircleReturnsToTheStart) {
  // Chosen so that a whole number of ticks makes one turn: r = 0.02 m, B = 0.3 m, counts 80/120:
  // dtheta = 40 * (2 pi 0.02 / 2000) / 0.3 = 2 pi / 750 -> exactly 750 ticks per turn.
  // The midpoint steps are the sides of a regular 750-gon, which closes exactly.
  const core::WheelGeometry g{0.02f, 0.02f, 0.3f, 2000.0f};
  core::Odometry odo;
  double max_distance = 0.0;
  for (int i = 0; i < 750; ++i) {
    odo.update(80, 120, g, static_cast<float>(kH));
    max_distance = std::fmax(max_distance, std::hypot(odo.pose().x_m, odo.pose().y_m));
  }
  // R = 0.15 * 200 / 40 = 0.75 m: halfway round the cart is a diameter (1.5 m) from the start.
  EXPECT_NEAR(max_distance, 1.5, 1e-3);
  EXPECT_NEAR(odo.pose().x_m, 0.0, 5e-4);
  EXPECT_NEAR(odo.pose().y_m, 0.0, 5e-4);
  EXPECT_NEAR(std::remainder(static_cast<double>(odo.pose().theta_rad), 2.0 * kPiD), 0.0, 1e-4);
}

TEST(Odometry, HeadingWrapsAcrossPlusPi) {
  // From theta = 3.1 rad, +0.1 rad (in place) -> 3.2 rad, i.e. 3.2 - 2 pi = -3.08319 rad.
  // 0.1 rad = (ds_r - ds_l) / B -> ds_r - ds_l = 0.0305 m = 462.31 counts: use 231/-231 counts
  // (462 counts -> 462 * 6.5973e-5 / 0.305 = 0.099934 rad).
  core::Odometry odo;
  odo.set_pose(core::Pose{0.0f, 0.0f, 3.1f});
  odo.update(-231, 231, kReference, static_cast<float>(kH));
  const double expected = 3.1 + 462 * kMetresPerCount / kTrack - 2.0 * kPiD;
  EXPECT_NEAR(odo.pose().theta_rad, expected, 1e-5);
  EXPECT_GE(odo.pose().theta_rad, -kPiD);
}

TEST(Odometry, HeadingWrapsAcrossMinusPi) {
  core::Odometry odo;
  odo.set_pose(core::Pose{0.0f, 0.0f, -3.1f});
  odo.update(231, -231, kReference, static_cast<float>(kH));
  const double expected = -3.1 - 462 * kMetresPerCount / kTrack + 2.0 * kPiD;
  EXPECT_NEAR(odo.pose().theta_rad, expected, 1e-5);
  EXPECT_LE(odo.pose().theta_rad, kPiD);
}

TEST(Odometry, HeadingStaysInRangeOverManyTurns) {
  // 10 turns in place, 0.021631 rad per tick (see OppositeCountsRotateInPlace): theta must stay
  // in [-pi, pi] and agree with the unwrapped total modulo 2 pi.
  core::Odometry odo;
  double total = 0.0;
  const double step = 100 * kMetresPerCount / kTrack;
  for (int i = 0; i < 2905; ++i) {
    odo.update(-50, 50, kReference, static_cast<float>(kH));
    total += step;
    ASSERT_LE(std::fabs(odo.pose().theta_rad), kPiD + 1e-6) << "tick " << i;
  }
  EXPECT_NEAR(odo.pose().theta_rad, std::remainder(total, 2.0 * kPiD), 2e-3);
}

TEST(Odometry, WrappedHeadingDoesNotBendTheTrack) {
  // Driving along -x (theta = pi) while the heading wobbles across the +-pi boundary: one tick
  // 100/101 counts (turns left by d = 1 count * 6.5973e-5 / 0.305 = 2.1631e-4 rad, theta wraps
  // to -pi + d), the next 101/100 (back to pi). The midpoint heading is pi + d/2 in both ticks
  // (written -pi + d/2 after the wrap: the same direction), so each tick moves
  // ds = 100.5 counts = 6.6303e-3 m along angle pi + d/2. After 200 ticks:
  //   x = -200 ds cos(d/2) = -1.32606 m,  y = -200 ds sin(d/2) = -1.4341e-4 m.
  // A wrap handled wrongly (e.g. a midpoint of (pi + (-pi + d)) / 2 = d/2) would send the cart
  // along +x instead.
  core::Odometry odo;
  odo.set_pose(core::Pose{0.0f, 0.0f, static_cast<float>(kPiD)});
  for (int i = 0; i < 100; ++i) {
    odo.update(100, 101, kReference, static_cast<float>(kH));
    odo.update(101, 100, kReference, static_cast<float>(kH));
  }
  const double d = kMetresPerCount / kTrack;
  const double ds = 100.5 * kMetresPerCount;
  EXPECT_NEAR(odo.pose().x_m, -200 * ds * std::cos(d / 2), 1e-4);
  EXPECT_NEAR(odo.pose().y_m, -200 * ds * std::sin(d / 2), 1e-5);
  EXPECT_NEAR(std::fabs(odo.pose().theta_rad), kPiD, 1e-3);
}

TEST(Odometry, SpeedsAreCountsOverThePeriod) {
  struct Case {
    int16_t left;
    int16_t right;
    double h;
  };
  // e.g. 30 / 50 counts in 8 ms: v_l = 30 * 6.5973e-5 / 0.008 = 0.24740 m/s,
  // v_r = 0.41233 m/s, v = 0.32987 m/s, omega = (0.41233 - 0.24740) / 0.305 = 0.54076 rad/s.
  for (const Case c : {Case{30, 50, 0.008}, Case{-40, 40, 0.008}, Case{-120, -90, 0.008}, Case{30, 50, 0.004},
                       Case{0, 0, 0.008}}) {
    core::Odometry odo;
    odo.update(c.left, c.right, kReference, static_cast<float>(c.h));
    const double v_l = c.left * kMetresPerCount / c.h;
    const double v_r = c.right * kMetresPerCount / c.h;
    SCOPED_TRACE(testing::Message() << c.left << "/" << c.right << " h=" << c.h);
    EXPECT_NEAR(odo.v_left_mps(), v_l, 1e-5);
    EXPECT_NEAR(odo.v_right_mps(), v_r, 1e-5);
    EXPECT_NEAR(odo.v_mps(), 0.5 * (v_l + v_r), 1e-5);
    EXPECT_NEAR(odo.omega_radps(), (v_r - v_l) / kTrack, 1e-4);
  }
}

TEST(Odometry, SpeedsFallToZeroWhenTheCountsStop) {
  core::Odometry odo;
  odo.update(100, 60, kReference, static_cast<float>(kH));
  const core::Pose moved = odo.pose();
  odo.update(0, 0, kReference, static_cast<float>(kH));
  EXPECT_EQ(odo.v_left_mps(), 0.0f);
  EXPECT_EQ(odo.v_right_mps(), 0.0f);
  EXPECT_EQ(odo.v_mps(), 0.0f);
  EXPECT_EQ(odo.omega_radps(), 0.0f);
  EXPECT_EQ(odo.pose().x_m, moved.x_m);
  EXPECT_EQ(odo.pose().y_m, moved.y_m);
  EXPECT_EQ(odo.pose().theta_rad, moved.theta_rad);
}

TEST(Odometry, CalibratedRadiiScaleEachWheel) {
  // One tick of 100 counts per wheel with r_l = 0.0205, r_r = 0.0215, B = 0.301:
  // ds_l = 100 * 2 pi 0.0205 / 2000 = 6.4403e-3 m, ds_r = 6.7544e-3 m,
  // v_l = 0.80503 m/s, v_r = 0.84430 m/s, omega = (v_r - v_l) / 0.301 = 0.13046 rad/s.
  core::Odometry odo;
  odo.update(100, 100, kCalibrated, static_cast<float>(kH));
  const double ds_l = 100 * 2.0 * kPiD * 0.0205 / 2000.0;
  const double ds_r = 100 * 2.0 * kPiD * 0.0215 / 2000.0;
  EXPECT_NEAR(odo.v_left_mps(), ds_l / kH, 1e-5);
  EXPECT_NEAR(odo.v_right_mps(), ds_r / kH, 1e-5);
  EXPECT_NEAR(odo.omega_radps(), (ds_r - ds_l) / 0.301 / kH, 1e-4);
  EXPECT_NEAR(odo.pose().theta_rad, (ds_r - ds_l) / 0.301, 1e-6);
}

}  // namespace
