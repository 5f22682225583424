// The cart state machine (core/cart) in closed loop with a tiny simulated plant.
//
// Plant: a kinematic differential drive whose measuring wheels are the driven wheels. Each
// 8 ms tick, each wheel's speed follows its PWM with a first-order lag,
//   v_wheel += (pwm / 1000 * 1.0 m/s - v_wheel) * 0.1      (time constant ~ 80 ms),
// the body moves along the exact arc the two wheel travels describe, and each wheel's travel is
// turned into encoder counts (2000 per revolution of the 0.021 m wheel) with the fractional
// part carried, as a real quadrature counter would. The counts feed the next Cart::tick.
//
// Settings are the defaults of config/robot.toml: v_max 0.5 m/s, a_max 1 m/s^2, alpha_max
// 12 rad/s^2, rho_kp 6 /s, phase_kp 8 /s, tol_final 0.005 m, tol_pass 0.08 m, manual timeout
// 0.5 s, reset pose (1.88, 0, 0).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "cart.hpp"
#include "protocol_table.hpp"

namespace {

constexpr double kPiD = 3.14159265358979323846;
constexpr double kH = 0.008;
constexpr double kRadius = 0.021;
constexpr double kTrack = 0.305;
constexpr double kMetresPerCount = 2.0 * kPiD * kRadius / 2000.0;
namespace id = params::settings;

struct Plant {
  double v_left = 0.0, v_right = 0.0;      // wheel ground speeds, m/s
  double travel_left = 0.0, travel_right = 0.0;
  long counted_left = 0, counted_right = 0;
  double x = 0.0, y = 0.0, theta = 0.0;    // ground truth

  static int16_t counts(double travel, long& counted) {
    const long total = static_cast<long>(std::floor(travel / kMetresPerCount));
    const long n = total - counted;
    counted = total;
    return static_cast<int16_t>(n);
  }

  core::TickInput step(const core::MotorOutput& out) {
    const double u_left = out.enabled ? out.pwm.left / 1000.0 : 0.0;
    const double u_right = out.enabled ? out.pwm.right / 1000.0 : 0.0;
    v_left += (u_left * 1.0 - v_left) * 0.1;
    v_right += (u_right * 1.0 - v_right) * 0.1;
    const double ds_l = v_left * kH, ds_r = v_right * kH;
    const double ds = 0.5 * (ds_l + ds_r), dth = (ds_r - ds_l) / kTrack;
    if (std::fabs(dth) < 1e-12) {
      x += ds * std::cos(theta);
      y += ds * std::sin(theta);
    } else {
      const double r = ds / dth;
      x += r * (std::sin(theta + dth) - std::sin(theta));
      y -= r * (std::cos(theta + dth) - std::cos(theta));
    }
    theta += dth;
    travel_left += ds_l;
    travel_right += ds_r;
    core::TickInput in;
    in.counts_left = counts(travel_left, counted_left);
    in.counts_right = counts(travel_right, counted_right);
    return in;
  }
  double speed() const { return 0.5 * (v_left + v_right); }
};

struct Rig {
  core::Settings settings;
  core::Path path;
  core::Cart cart{settings, path};
  Plant plant;
  core::TickInput next;  // counts measured during the last period
  int ticks = 0;

  core::MotorOutput tick(bool switch_left = false, bool switch_right = false) {
    core::TickInput in = next;
    in.switch_left = switch_left;
    in.switch_right = switch_right;
    const core::MotorOutput out = cart.tick(in);
    next = plant.step(out);
    ++ticks;
    return out;
  }
  // Ticks until the cart leaves `mode` (or max_ticks); returns the ticks taken.
  int run_while(proto::Mode mode, int max_ticks) {
    int n = 0;
    while (cart.mode() == mode && n < max_ticks) {
      tick();
      ++n;
    }
    return n;
  }
  void place(double x, double y, double theta) {
    plant.x = x;
    plant.y = y;
    plant.theta = theta;
    cart.set_pose(core::Pose{static_cast<float>(x), static_cast<float>(y), static_cast<float>(theta)});
  }
  bool flag(unsigned f) const { return (cart.flags() & f) != 0; }
  double truth_distance_to(double x, double y) const { return std::hypot(plant.x - x, plant.y - y); }
  double odo_distance_to(double x, double y) const {
    return std::hypot(cart.odometry().pose().x_m - x, cart.odometry().pose().y_m - y);
  }
};

std::vector<float> flat(const std::vector<core::Point>& pts, size_t first = 0, size_t n = SIZE_MAX) {
  std::vector<float> xy;
  for (size_t i = first; i < pts.size() && i < first + n; ++i) xy.insert(xy.end(), {pts[i].x_m, pts[i].y_m});
  return xy;
}

// A host streaming `pts` as docs/protocol.md asks: the first frame, then, every `every` ticks,
// as many points as the window has room for, in frames of up to 15.
struct Streamer {
  const std::vector<core::Point>& pts;
  int every = 5;  // ticks: the telemetry period at 25 Hz
  int countdown = 0;

  void begin(Rig& rig) {
    const size_t first = std::min<size_t>(pts.size(), 15);
    const std::vector<float> xy = flat(pts, 0, first);
    ASSERT_EQ(rig.cart.begin_path(static_cast<float>(pts.size()), xy.data(), static_cast<uint8_t>(first)), 0);
  }
  void refill(Rig& rig) {
    if (countdown-- > 0) return;
    countdown = every - 1;
    while (rig.path.room() > 0) {
      const uint16_t n = std::min<uint16_t>(rig.path.room(), 15);
      const std::vector<float> xy = flat(pts, rig.path.received(), n);
      ASSERT_EQ(rig.cart.append_path(rig.path.received(), xy.data(), static_cast<uint8_t>(n)), 0);
    }
  }
};

void expect_stopped_on_arrival(const Rig& rig) {
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  // Declared only once nearly stopped (arrive_speed_mps = 0.02), not while rolling through.
  EXPECT_LT(std::fabs(rig.cart.odometry().v_mps()), params::control::arrive_speed_mps);
  EXPECT_TRUE(rig.flag(proto::FLAG_ARRIVED));
  EXPECT_FALSE(rig.flag(proto::FLAG_MOTORS_ENABLED));
  EXPECT_FALSE(rig.cart.output().enabled);
  EXPECT_EQ(rig.cart.output().pwm.left, 0);
  EXPECT_EQ(rig.cart.output().pwm.right, 0);
}

// ---- Power-up, HOLD, STOP -----------------------------------------------------------------

TEST(CartLoop, PowersUpIdleWithMotorsDisabled) {
  Rig rig;
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_FALSE(rig.flag(proto::FLAG_MOTORS_ENABLED));
  // Pushed by hand: no motor output, but odometry keeps counting (100 ticks x 20 counts =
  // 2000 counts = one wheel turn = 2 pi 0.021 = 0.13195 m).
  core::TickInput pushed;
  pushed.counts_left = pushed.counts_right = 20;
  for (int i = 0; i < 100; ++i) {
    const core::MotorOutput out = rig.cart.tick(pushed);
    ASSERT_FALSE(out.enabled);
    ASSERT_EQ(out.pwm.left, 0);
    ASSERT_EQ(out.pwm.right, 0);
  }
  EXPECT_NEAR(rig.cart.odometry().pose().x_m, 2000 * kMetresPerCount, 1e-4);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
}

TEST(CartLoop, StartWithoutAPathHoldsWithZeroPwmAndMotorsEnabled) {
  Rig rig;
  rig.cart.start();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_HOLD);
  // The seed's flaw: PWM 0 switched the output off and silently disabled control.
  for (int i = 0; i < 250; ++i) {
    const core::MotorOutput out = rig.tick();
    ASSERT_TRUE(out.enabled) << i;
    ASSERT_EQ(out.pwm.left, 0) << i;
    ASSERT_EQ(out.pwm.right, 0) << i;
    ASSERT_TRUE(rig.flag(proto::FLAG_MOTORS_ENABLED)) << i;
    ASSERT_EQ(rig.cart.mode(), proto::MODE_HOLD);
  }
  // Still under control: pushed forwards (10 counts per tick = 0.082 m/s), it pushes back.
  core::TickInput pushed;
  pushed.counts_left = pushed.counts_right = 10;
  core::MotorOutput out;
  for (int i = 0; i < 3; ++i) out = rig.cart.tick(pushed);
  EXPECT_TRUE(out.enabled);
  EXPECT_LT(out.pwm.left, 0);
  EXPECT_LT(out.pwm.right, 0);
}

TEST(CartLoop, StopDisablesTheMotorsAndKeepsThePath) {
  Rig rig;
  rig.cart.go_to(core::Point{2.0f, 0.0f});
  for (int i = 0; i < 100; ++i) rig.tick();
  ASSERT_EQ(rig.cart.mode(), proto::MODE_PATH);
  ASSERT_GT(rig.plant.speed(), 0.2);
  rig.cart.stop();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_FALSE(rig.cart.output().enabled);
  EXPECT_FALSE(rig.flag(proto::FLAG_MOTORS_ENABLED));
  EXPECT_FALSE(rig.flag(proto::FLAG_ARRIVED));
  const core::MotorOutput out = rig.tick();
  EXPECT_FALSE(out.enabled);
  EXPECT_EQ(out.pwm.left, 0);
  EXPECT_EQ(out.pwm.right, 0);
  EXPECT_TRUE(rig.path.active());
  // START resumes the kept path and still ends on the goal.
  for (int i = 0; i < 100; ++i) rig.tick();  // coast to a stop
  rig.cart.start();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  rig.run_while(proto::MODE_PATH, 2000);
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.odo_distance_to(2.0, 0.0), rig.settings.get(id::tol_final_m));
}

// ---- GOTO ---------------------------------------------------------------------------------

TEST(CartLoop, GotoAheadStopsItselfWithinTheFinalTolerance) {
  Rig rig;
  const double d = 1.0;
  rig.cart.go_to(core::Point{static_cast<float>(d), 0.0f});
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  EXPECT_TRUE(rig.tick().enabled);
  const int ticks = 1 + rig.run_while(proto::MODE_PATH, 3000);

  expect_stopped_on_arrival(rig);
  const double tol = rig.settings.get(id::tol_final_m);  // 0.005 m
  EXPECT_LT(rig.odo_distance_to(d, 0.0), tol);
  // Odometry and truth differ by the count quantisation (6.6e-5 m) only on a straight line.
  EXPECT_LT(rig.truth_distance_to(d, 0.0), tol + 2.0 * kMetresPerCount);
  EXPECT_LT(std::fabs(rig.plant.theta), 0.01);
  // Plausible duration. Faster than physics allows is impossible: ramp to 0.5 m/s at 1 m/s^2
  // (0.5 s, 0.125 m) and cruise the rest: 0.5 + 0.875 / 0.5 = 2.25 s = 281 ticks.
  // The P law v = kp * d makes the last 0.5 m an exponential: from 0.5 m to 0.005 m takes
  // ln(100) / kp = 4.6 s; plus ~1.5 s for the first 0.5 m and ~1 s of lag: < 7.5 s = 938 ticks.
  EXPECT_GE(ticks, 281);
  EXPECT_LE(ticks, 938);
}

TEST(CartLoop, ArrivedCartStaysStoppedAndANewGoalClearsTheFlag) {
  Rig rig;
  rig.cart.go_to(core::Point{0.3f, 0.0f});
  rig.tick();
  rig.run_while(proto::MODE_PATH, 3000);
  ASSERT_TRUE(rig.flag(proto::FLAG_ARRIVED));
  for (int i = 0; i < 50; ++i) EXPECT_FALSE(rig.tick().enabled);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  rig.cart.go_to(core::Point{0.3f, 0.3f});
  EXPECT_FALSE(rig.flag(proto::FLAG_ARRIVED));
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
}

TEST(CartLoop, GotoBehindDrivesBackwards) {
  Rig rig;
  rig.cart.go_to(core::Point{-0.5f, 0.0f});
  double max_abs_theta = 0.0;
  for (int i = 0; i < 30; ++i) {
    rig.tick();
    ASSERT_LT(rig.cart.v_ref_mps(), 0.0f) << i;
  }
  EXPECT_LT(rig.plant.speed(), -0.05);  // really moving backwards
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 3000) {
    rig.tick();
    max_abs_theta = std::fmax(max_abs_theta, std::fabs(rig.plant.theta));
  }
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.truth_distance_to(-0.5, 0.0), rig.settings.get(id::tol_final_m) + 2.0 * kMetresPerCount);
  // It backed up; it did not turn round (a turn would take theta through pi).
  EXPECT_LT(max_abs_theta, 0.05);
}

TEST(CartLoop, GoalBehindWithReverseNotAllowedIsFacedThenDrivenForwards) {
  // reverse_allowed = 0 (the gateway sets it while it sees with its forward-looking camera):
  // the cart turns round on the spot and drives forwards, never backing up more than
  // the final 2 cm of an overshoot.
  Rig rig;
  ASSERT_EQ(rig.settings.set(id::reverse_allowed, 0.0f), 0);
  rig.cart.go_to(core::Point{-0.5f, 0.0f});
  double backwards_m = 0.0, longest_backwards_m = 0.0, max_abs_theta = 0.0;
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 3000) {
    const double x = rig.plant.x, y = rig.plant.y;
    rig.tick();
    const double along = (rig.plant.x - x) * std::cos(rig.plant.theta) + (rig.plant.y - y) * std::sin(rig.plant.theta);
    backwards_m = along < 0.0 ? backwards_m - along : 0.0;
    longest_backwards_m = std::fmax(longest_backwards_m, backwards_m);
    max_abs_theta = std::fmax(max_abs_theta, std::fabs(rig.plant.theta));
  }
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.truth_distance_to(-0.5, 0.0), rig.settings.get(id::tol_final_m) + 2.0 * kMetresPerCount);
  EXPECT_GT(max_abs_theta, 3.0);           // it turned round
  EXPECT_LT(longest_backwards_m, 0.02);    // and did not back up
}

TEST(CartLoop, GotoSideways) {
  // A target 90 deg to the left: the cart turns and drives there, ending within tolerance.
  Rig rig;
  rig.cart.go_to(core::Point{0.0f, 0.4f});
  rig.run_while(proto::MODE_PATH, 3000);
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.odo_distance_to(0.0, 0.4), rig.settings.get(id::tol_final_m));
  EXPECT_LT(rig.truth_distance_to(0.0, 0.4), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, GotoANearbyPointOffToTheSideIsReached) {
  // Goals inside the 0.02 m final-approach radius but well off the heading line. A
  // differential-drive cart cannot close a sideways offset by driving straight: it has to turn
  // first. (Before the fix in core/polar_controller.cpp the cart closed the along-track
  // distance, stopped abeam of the goal 0.01-0.019 m away and waited there for ever in PATH
  // mode, motors on.) Bound: turning ~90 deg and creeping 0.02 m takes well under 5 s.
  struct Case {
    float x;
    float y;
  };
  for (const Case c : {Case{0.0f, 0.015f}, Case{0.01f, 0.015f}, Case{-0.005f, 0.012f}, Case{0.0f, -0.019f},
                       Case{-0.013f, -0.013f}}) {
    SCOPED_TRACE(testing::Message() << c.x << "," << c.y);
    Rig rig;
    rig.cart.go_to(core::Point{c.x, c.y});
    rig.tick();
    const int ticks = rig.run_while(proto::MODE_PATH, 5000);
    expect_stopped_on_arrival(rig);
    EXPECT_LE(ticks, 625);
    EXPECT_LT(rig.truth_distance_to(c.x, c.y), rig.settings.get(id::tol_final_m) + 5e-4);
  }
}

TEST(CartLoop, WaypointOnTheSameCircleAroundTheOriginIsNotReached) {
  // The seed's flaw: arrival compared |robot| with |waypoint| (distances from the origin), so a
  // cart at (0.5, 0) "reached" (0, 0.5) at once. Arrival is judged on robot-to-waypoint distance.
  Rig rig;
  rig.place(0.5, 0.0, 0.0);
  rig.cart.go_to(core::Point{0.0f, 0.5f});
  rig.tick();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  EXPECT_FALSE(rig.flag(proto::FLAG_ARRIVED));
  EXPECT_TRUE(rig.cart.output().enabled);
  EXPECT_NEAR(rig.cart.distance_to_waypoint_m(), std::hypot(0.5, 0.5), 1e-3);
  rig.run_while(proto::MODE_PATH, 3000);
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.truth_distance_to(0.0, 0.5), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, IntermediateWaypointOnTheSameCircleIsNotPassed) {
  Rig rig;
  rig.place(0.5, 0.0, 0.0);
  const float xy[] = {0.0f, 0.5f, 0.0f, 1.0f};
  ASSERT_EQ(rig.cart.begin_path(2.0f, xy, 2), 0);
  for (int i = 0; i < 5; ++i) rig.tick();
  EXPECT_EQ(rig.path.index(), 0);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
}

TEST(CartLoop, RollingThroughTheFinalToleranceIsNotArrival) {
  // At (0.998, 0) heading +x, goal (1, 0). One tick of 12 counts per wheel: the odometry moves
  // 12 * 6.5973e-5 = 7.9e-4 m to 0.99879 (1.2 mm from the goal, inside tol_final = 5 mm) at
  // 12 * 6.5973e-5 / 0.008 = 0.099 m/s, above arrive_speed_mps (0.02): not arrived yet.
  Rig rig;
  rig.place(0.998, 0.0, 0.0);
  rig.cart.go_to(core::Point{1.0f, 0.0f});
  core::TickInput rolling;
  rolling.counts_left = rolling.counts_right = 12;
  rig.cart.tick(rolling);
  EXPECT_LT(rig.odo_distance_to(1.0, 0.0), rig.settings.get(id::tol_final_m));
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  EXPECT_FALSE(rig.flag(proto::FLAG_ARRIVED));
  // Then no counts: standing inside the tolerance -> arrived at the next run of the position
  // loop (it runs every kPositionDivider ticks).
  for (int i = 0; i < core::kPositionDivider; ++i) rig.cart.tick(core::TickInput());
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_TRUE(rig.flag(proto::FLAG_ARRIVED));
}

TEST(CartLoop, IntermediateWaypointPassingRule) {
  // Path (1, 0) -> (2, 0) uploaded at the origin; the odometry is then moved to `pose` and one
  // tick decides whether waypoint 0 counts as passed: within tol_pass (0.08 m), or beyond it
  // along its segment and within 4 tol_pass (0.32 m).
  struct Case {
    float x;
    float y;
    uint8_t index;
  };
  const Case cases[] = {
      {0.96f, 0.0f, 1},   // 0.04 m short: within tol_pass
      {1.0f, 0.045f, 1},  // abeam at 0.045 m
      {0.9f, 0.0f, 0},    // 0.1 m short, not beyond: keep going for it
      {0.97f, 0.1f, 0},   // 0.104 m off to the side, not beyond
      {1.1f, 0.05f, 1},   // overshot by 0.1 m along the segment (0.112 m away): passed
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(testing::Message() << c.x << "," << c.y);
    Rig rig;
    const float xy[] = {1.0f, 0.0f, 2.0f, 0.0f};
    ASSERT_EQ(rig.cart.begin_path(2.0f, xy, 2), 0);
    rig.cart.set_pose(core::Pose{c.x, c.y, 0.0f});
    rig.cart.tick(core::TickInput());
    EXPECT_EQ(rig.path.index(), c.index);
    EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  }
}

// ---- Multi-waypoint path -------------------------------------------------------------------

TEST(CartLoop, GentlePathIsFollowedWithoutStoppingAtIntermediateWaypoints) {
  // Gently curving: headings 0, 7.1, 14.0, 20.6, 26.6 deg; turns of ~7 deg, so every
  // intermediate exit speed is v_max cos(7 deg) ~ 0.496 m/s.
  const std::vector<core::Point> pts{{0.4f, 0.0f}, {0.8f, 0.05f}, {1.2f, 0.15f}, {1.6f, 0.3f}, {2.0f, 0.5f}};
  Rig rig;
  const std::vector<float> xy = flat(pts);
  ASSERT_EQ(rig.cart.begin_path(5.0f, xy.data(), 5), 0);
  EXPECT_FALSE(rig.flag(proto::FLAG_UPLOAD_OPEN));

  std::vector<double> speed_at_switch;
  std::vector<double> closest(pts.size(), 1e9);
  double min_speed_between = 1e9;
  uint8_t index = rig.path.index();
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 5000) {
    rig.tick();
    for (size_t i = 0; i < pts.size(); ++i)
      closest[i] = std::fmin(closest[i], rig.truth_distance_to(pts[i].x_m, pts[i].y_m));
    if (rig.path.index() != index && rig.path.index() < pts.size()) {
      speed_at_switch.push_back(rig.cart.odometry().v_mps());
      index = rig.path.index();
    }
    // From the first waypoint until the last one is targeted, the cart keeps going.
    if (rig.path.index() >= 1 && rig.path.index() < pts.size() - 1)
      min_speed_between = std::fmin(min_speed_between, rig.plant.speed());
  }
  expect_stopped_on_arrival(rig);
  ASSERT_EQ(speed_at_switch.size(), pts.size() - 1);  // advanced through every waypoint
  for (size_t i = 0; i < speed_at_switch.size(); ++i)
    EXPECT_GT(speed_at_switch[i], 0.35) << "passing waypoint " << i;
  EXPECT_GT(min_speed_between, 0.35);
  // Intermediate waypoints are passed close by (within tol_pass, 0.08 m, on this gentle path).
  for (size_t i = 0; i + 1 < pts.size(); ++i)
    EXPECT_LT(closest[i], rig.settings.get(id::tol_pass_m)) << "waypoint " << i;
  EXPECT_LT(rig.odo_distance_to(2.0, 0.5), rig.settings.get(id::tol_final_m));
  EXPECT_LT(rig.truth_distance_to(2.0, 0.5), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, SharpCornerIsTakenSlowlyButStillReached) {
  // A right-angle corner: its exit speed is 0 and, once it is passed, the next waypoint lies
  // ~90 deg off the heading, so the commanded speed (v * cos(heading error)) collapses while the
  // cart turns: well below v_max, unlike the gentle path above. It then ends on the last point.
  Rig rig;
  const float xy[] = {0.6f, 0.0f, 0.6f, 0.6f};
  ASSERT_EQ(rig.cart.begin_path(2.0f, xy, 2), 0);
  int switch_tick = -1;
  double min_v_ref_after_switch = 1e9;
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 5000) {
    const uint8_t before = rig.path.index();
    rig.tick();
    if (before == 0 && rig.path.index() == 1) switch_tick = rig.ticks;
    if (switch_tick > 0 && rig.ticks <= switch_tick + 60)
      min_v_ref_after_switch = std::fmin(min_v_ref_after_switch, rig.cart.v_ref_mps());
  }
  expect_stopped_on_arrival(rig);
  ASSERT_GT(switch_tick, 0);
  EXPECT_LT(min_v_ref_after_switch, 0.3 * rig.settings.get(id::v_max_mps));
  EXPECT_LT(rig.truth_distance_to(0.6, 0.6), rig.settings.get(id::tol_final_m) + 2e-3);
}

// ---- Streamed paths and replacements --------------------------------------------------------

TEST(CartLoop, AStreamedPathDrivesOnItsFirstPointsAndStopsSmoothlyOnTheLastReceived) {
  // 3 points along x, 0.4 m apart; only the first 2 have arrived. The cart drives at once,
  // brakes within the acceleration limit and stops on (0.8, 0) without declaring arrival,
  // flagging STARVED; when the last point arrives it drives on and arrives there.
  Rig rig;
  const double dv_max = rig.settings.get(id::a_max_mps2) * kH;
  const float first[] = {0.4f, 0.0f, 0.8f, 0.0f};
  ASSERT_EQ(rig.cart.begin_path(3.0f, first, 2), 0);
  EXPECT_TRUE(rig.flag(proto::FLAG_UPLOAD_OPEN));
  float v_prev = 0.0f, v_peak = 0.0f;
  for (int i = 0; i < 500; ++i) {
    rig.tick();
    ASSERT_EQ(rig.cart.mode(), proto::MODE_PATH) << i;
    ASSERT_LE(std::fabs(rig.cart.v_ref_mps() - v_prev), dv_max + 1e-6) << i;
    v_prev = rig.cart.v_ref_mps();
    v_peak = std::fmax(v_peak, v_prev);
  }
  EXPECT_GT(v_peak, 0.4f);  // it did not wait for the whole path
  EXPECT_EQ(rig.path.index(), 1);
  EXPECT_LT(std::fabs(rig.plant.speed()), 0.005);
  EXPECT_LT(rig.truth_distance_to(0.8, 0.0), rig.settings.get(id::tol_final_m) + 2e-3);
  EXPECT_FALSE(rig.flag(proto::FLAG_ARRIVED));
  EXPECT_TRUE(rig.flag(proto::FLAG_STARVED));
  EXPECT_TRUE(rig.cart.output().enabled);  // holding still, waiting

  const float last[] = {1.2f, 0.0f};
  ASSERT_EQ(rig.cart.append_path(2.0f, last, 1), 0);
  EXPECT_FALSE(rig.flag(proto::FLAG_STARVED));
  rig.tick();
  rig.tick();
  // Standing on the point before the last, it must not take the arrival there for the last's.
  EXPECT_EQ(rig.cart.mode(), proto::MODE_PATH);
  rig.run_while(proto::MODE_PATH, 3000);
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.truth_distance_to(1.2, 0.0), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, ALongStreamedPathIsDrivenAtFullSpeedAcrossEveryWindowBoundary) {
  // 400 points 2 cm apart on a gentle wave (8 m; the window holds 0.6 m of it), refilled every
  // 40 ms: never STARVED, never below 0.45 m/s between the first and the last metre.
  std::vector<core::Point> pts;
  for (int i = 1; i <= 400; ++i) {
    const float x = 0.02f * static_cast<float>(i);
    pts.push_back(core::Point{x, 0.1f * std::sin(x)});
  }
  Rig rig;
  Streamer host{pts};
  host.begin(rig);
  double min_speed = 1e9;
  int starved_ticks = 0;
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 5000) {
    host.refill(rig);
    rig.tick();
    if (rig.plant.x > 1.0 && rig.plant.x < 7.0) min_speed = std::fmin(min_speed, rig.plant.speed());
    if (rig.flag(proto::FLAG_STARVED)) ++starved_ticks;
  }
  expect_stopped_on_arrival(rig);
  EXPECT_EQ(rig.path.index(), 400);
  EXPECT_GT(min_speed, 0.45);
  EXPECT_EQ(starved_ticks, 0);
  EXPECT_LT(rig.truth_distance_to(pts.back().x_m, pts.back().y_m), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, AHostThatFallsBehindMakesTheCartStopOnTheLastPointNotOvershootIt) {
  // The same kind of path, but the host sends its second frame only after 3 s: the cart stops
  // on point 14 (0.3 m), then drives the rest.
  std::vector<core::Point> pts;
  for (int i = 1; i <= 60; ++i) pts.push_back(core::Point{0.02f * static_cast<float>(i), 0.0f});
  Rig rig;
  Streamer host{pts, 375};
  host.countdown = 375;
  host.begin(rig);
  double max_x_while_waiting = 0.0;
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 3000) {
    host.refill(rig);
    rig.tick();
    if (rig.ticks < 375) max_x_while_waiting = std::fmax(max_x_while_waiting, rig.plant.x);
  }
  EXPECT_LT(max_x_while_waiting, 0.3 + 0.004);
  EXPECT_GT(max_x_while_waiting, 0.3 - 0.006);
  expect_stopped_on_arrival(rig);
  EXPECT_LT(rig.truth_distance_to(1.2, 0.0), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, AReplacementWhileDrivingIsAtomicAndCarriesTheSpeedThroughTheLimiter) {
  // Driving along x at full speed towards (3, 0); at x = 1 a new path replaces it: on along x to
  // (1.8, 0), then a left turn up to (1.8, 0.6). The cart follows the new path only (it never
  // heads on for the old points beyond x = 1.8), the references change by at most a_max * h and
  // alpha_max * h per tick, and it does not slow down on the straight part of the new path.
  Rig rig;
  const double dv_max = rig.settings.get(id::a_max_mps2) * kH;
  const double dw_max = rig.settings.get(id::alpha_max_radps2) * kH;
  std::vector<core::Point> old_pts;
  for (int i = 1; i <= 15; ++i) old_pts.push_back(core::Point{0.2f * static_cast<float>(i), 0.0f});
  const std::vector<float> old_xy = flat(old_pts);
  ASSERT_EQ(rig.cart.begin_path(15.0f, old_xy.data(), 15), 0);
  while (rig.plant.x < 1.0) rig.tick();
  ASSERT_NEAR(rig.cart.v_ref_mps(), 0.5, 1e-3);
  // A refused replacement changes nothing.
  ASSERT_EQ(rig.cart.begin_path(0.0f, nullptr, 0), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(rig.path.count(), 15);
  const std::vector<core::Point> fresh{{1.3f, 0.0f}, {1.55f, 0.0f}, {1.8f, 0.0f}, {1.8f, 0.3f}, {1.8f, 0.6f}};
  const std::vector<float> xy = flat(fresh);
  ASSERT_EQ(rig.cart.begin_path(5.0f, xy.data(), 5), 0);
  EXPECT_EQ(rig.path.index(), 0);
  EXPECT_EQ(rig.path.current().x_m, 1.3f);
  float v_prev = rig.cart.v_ref_mps(), w_prev = rig.cart.omega_ref_radps();
  double min_v_straight = 1e9, max_x = 0.0;
  while (rig.cart.mode() == proto::MODE_PATH && rig.ticks < 5000) {
    rig.tick();
    const float v = rig.cart.v_ref_mps(), w = rig.cart.omega_ref_radps();
    ASSERT_LE(std::fabs(v - v_prev), dv_max + 1e-6) << rig.ticks;
    ASSERT_LE(std::fabs(w - w_prev), dw_max + 1e-6) << rig.ticks;
    v_prev = v;
    w_prev = w;
    if (rig.plant.x < 1.4) min_v_straight = std::fmin(min_v_straight, rig.plant.speed());
    max_x = std::fmax(max_x, rig.plant.x);
  }
  expect_stopped_on_arrival(rig);
  EXPECT_GT(min_v_straight, 0.45);
  EXPECT_LT(max_x, 1.8 + 0.02);
  EXPECT_LT(rig.truth_distance_to(1.8, 0.6), rig.settings.get(id::tol_final_m) + 2e-3);
}

TEST(CartLoop, AReplacementWithoutPointsBrakesAtTheLimitsAndWaitsForThem) {
  Rig rig;
  const double dv_max = rig.settings.get(id::a_max_mps2) * kH;
  const float far[] = {3.0f, 0.0f};
  ASSERT_EQ(rig.cart.begin_path(1.0f, far, 1), 0);
  while (rig.plant.x < 1.0) rig.tick();
  ASSERT_EQ(rig.cart.begin_path(10.0f, nullptr, 0), 0);
  float v_prev = rig.cart.v_ref_mps();
  for (int i = 0; i < 150; ++i) {
    rig.tick();
    ASSERT_EQ(rig.cart.mode(), proto::MODE_PATH);
    ASSERT_LE(std::fabs(rig.cart.v_ref_mps() - v_prev), dv_max + 1e-6) << i;
    ASSERT_LE(rig.cart.v_ref_mps(), v_prev + 1e-7) << i;  // only slowing down
    v_prev = rig.cart.v_ref_mps();
  }
  EXPECT_EQ(rig.cart.v_ref_mps(), 0.0f);
  EXPECT_TRUE(rig.flag(proto::FLAG_STARVED));
  const double x_stopped = rig.plant.x;
  EXPECT_LT(x_stopped, 1.0 + 0.16);  // v^2 / (2 a) = 0.125 m, plus the wheels' lag
  const float pts[] = {static_cast<float>(x_stopped) + 0.5f, 0.0f};
  ASSERT_EQ(rig.cart.append_path(0.0f, pts, 1), 0);
  for (int i = 0; i < 100; ++i) rig.tick();
  EXPECT_GT(rig.plant.x, x_stopped + 0.1);
}

// ---- Acceleration limiting ----------------------------------------------------------------

TEST(CartLoop, ReferenceSpeedsChangeAtMostAMaxTimesHPerTick) {
  Rig rig;
  const double dv_max = rig.settings.get(id::a_max_mps2) * kH;        // 1 * 0.008 = 0.008 m/s
  const double dw_max = rig.settings.get(id::alpha_max_radps2) * kH;  // 12 * 0.008 = 0.096 rad/s
  rig.cart.go_to(core::Point{1.0f, 0.6f});
  rig.tick();
  // From rest towards a far target, the first step is exactly one acceleration step.
  EXPECT_NEAR(rig.cart.v_ref_mps(), dv_max, 1e-6);
  float v_prev = rig.cart.v_ref_mps(), w_prev = rig.cart.omega_ref_radps();
  int saw_limit = 0;
  for (int i = 0; i < 400; ++i) {
    if (i == 150) rig.cart.go_to(core::Point{-1.0f, -0.5f});  // sudden reversal mid-run
    rig.tick();
    ASSERT_EQ(rig.cart.mode(), proto::MODE_PATH);
    const float v = rig.cart.v_ref_mps(), w = rig.cart.omega_ref_radps();
    ASSERT_LE(std::fabs(v - v_prev), dv_max + 1e-6) << i;
    ASSERT_LE(std::fabs(w - w_prev), dw_max + 1e-6) << i;
    if (std::fabs(v - v_prev) > 0.99 * dv_max) ++saw_limit;
    v_prev = v;
    w_prev = w;
  }
  EXPECT_GT(saw_limit, 10);  // the limiter was actually binding
}

// ---- Manual drive -------------------------------------------------------------------------

TEST(CartLoop, ManualDriveRunsAndStopsWhenNotRefreshed) {
  Rig rig;
  ASSERT_EQ(rig.cart.drive(0.3f, 0.0f), 0);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_MANUAL);
  // Refreshed every 40 ticks (0.32 s < 0.5 s) for 400 ticks: keeps driving.
  for (int i = 0; i < 400; ++i) {
    if (i % 40 == 0) {
      ASSERT_EQ(rig.cart.drive(0.3f, 0.0f), 0);
    }
    ASSERT_TRUE(rig.tick().enabled) << i;
  }
  EXPECT_EQ(rig.cart.mode(), proto::MODE_MANUAL);
  EXPECT_NEAR(rig.plant.speed(), 0.3, 0.02);
  // Last refresh, then silence. A VELOCITY command is good for round(0.5 s * 125 Hz) = 63 ticks.
  ASSERT_EQ(rig.cart.drive(0.3f, 0.0f), 0);
  for (int i = 1; i <= 63; ++i) {
    ASSERT_TRUE(rig.tick().enabled) << i;
    ASSERT_EQ(rig.cart.mode(), proto::MODE_MANUAL) << i;
  }
  const core::MotorOutput out = rig.tick();  // 64th tick: 0.512 s without a command
  EXPECT_FALSE(out.enabled);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_TRUE(rig.flag(proto::FLAG_MANUAL_TIMEOUT));
  EXPECT_FALSE(rig.flag(proto::FLAG_MOTORS_ENABLED));
  // A new command clears the flag.
  ASSERT_EQ(rig.cart.drive(0.1f, 0.0f), 0);
  EXPECT_FALSE(rig.flag(proto::FLAG_MANUAL_TIMEOUT));
}

TEST(CartLoop, ManualTurnRate) {
  // v = 0, omega = 1 rad/s: turns on the spot, counter-clockwise.
  Rig rig;
  for (int i = 0; i < 200; ++i) {
    if (i % 40 == 0) {
      ASSERT_EQ(rig.cart.drive(0.0f, 1.0f), 0);
    }
    rig.tick();
  }
  EXPECT_NEAR(rig.cart.odometry().omega_radps(), 1.0, 0.1);
  EXPECT_LT(std::hypot(rig.plant.x, rig.plant.y), 0.01);
  EXPECT_GT(rig.plant.theta, 1.0);
}

TEST(CartLoop, ManualDriveBeyondTheLimitsIsRefusedAndChangesNothing) {
  struct Case {
    float v;
    float w;
  };
  // v_max = 0.5 m/s, w_max = pi rad/s.
  for (const Case c : {Case{0.6f, 0.0f}, Case{-0.51f, 0.0f}, Case{0.0f, 3.2f}, Case{0.1f, -4.0f}}) {
    SCOPED_TRACE(testing::Message() << c.v << "," << c.w);
    Rig idle;
    EXPECT_EQ(idle.cart.drive(c.v, c.w), proto::REASON_OUT_OF_RANGE);
    EXPECT_EQ(idle.cart.mode(), proto::MODE_IDLE);
    EXPECT_FALSE(idle.tick().enabled);

    // While driving: the old command continues and its timeout is NOT refreshed.
    Rig driving;
    ASSERT_EQ(driving.cart.drive(0.2f, 0.0f), 0);
    for (int i = 0; i < 40; ++i) driving.tick();
    EXPECT_EQ(driving.cart.drive(c.v, c.w), proto::REASON_OUT_OF_RANGE);
    for (int i = 40; i < 63; ++i) driving.tick();
    EXPECT_EQ(driving.cart.mode(), proto::MODE_MANUAL);
    EXPECT_NEAR(driving.cart.v_ref_mps(), 0.2f, 1e-6f);
    EXPECT_NEAR(driving.cart.omega_ref_radps(), 0.0f, 1e-6f);
    driving.tick();  // tick 64 after the only accepted command
    EXPECT_EQ(driving.cart.mode(), proto::MODE_IDLE);
    EXPECT_TRUE(driving.flag(proto::FLAG_MANUAL_TIMEOUT));
  }
}

// ---- Front switches ------------------------------------------------------------------------

TEST(CartLoop, AFrontSwitchClosingWhileDrivingForwardsStopsAtOnce) {
  for (const bool left : {true, false}) {
    Rig rig;
    for (int i = 0; i < 60; ++i) {
      if (i % 40 == 0) ASSERT_EQ(rig.cart.drive(0.3f, 0.0f), 0);
      rig.tick();
    }
    ASSERT_TRUE(rig.cart.output().enabled);
    const core::MotorOutput out = rig.tick(left, !left);  // the bumper touches
    EXPECT_FALSE(out.enabled);
    EXPECT_EQ(proto::MODE_IDLE, rig.cart.mode());
    EXPECT_TRUE(rig.flag(proto::FLAG_BUMPER));
  }
}

TEST(CartLoop, WithAFrontSwitchClosedOnlyBackingAwayIsAllowed) {
  Rig rig;
  rig.tick(true, false);
  EXPECT_EQ(proto::REASON_BLOCKED, rig.cart.drive(0.2f, 0.0f));
  EXPECT_EQ(proto::MODE_IDLE, rig.cart.mode());
  ASSERT_EQ(0, rig.cart.drive(-0.2f, 0.0f));
  for (int i = 0; i < 30; ++i) EXPECT_TRUE(rig.tick(true, false).enabled) << i;
  EXPECT_LT(rig.plant.speed(), -0.1);  // backing away
  EXPECT_FALSE(rig.flag(proto::FLAG_BUMPER));
  ASSERT_EQ(0, rig.cart.drive(0.0f, 1.0f));  // turning on the spot is allowed too
  EXPECT_TRUE(rig.tick(true, false).enabled);
}

TEST(CartLoop, APathIntoAContactStops) {
  Rig rig;
  rig.cart.go_to(core::Point{1.0f, 0.0f});
  for (int i = 0; i < 50; ++i) rig.tick();
  ASSERT_EQ(proto::MODE_PATH, rig.cart.mode());
  rig.tick(false, true);
  EXPECT_EQ(proto::MODE_IDLE, rig.cart.mode());
  EXPECT_TRUE(rig.flag(proto::FLAG_BUMPER));
  EXPECT_FALSE(rig.cart.output().enabled);
}

TEST(CartLoop, APathThatBacksAwayFromAContactIsDriven) {
  Rig rig;
  rig.cart.go_to(core::Point{-0.3f, 0.0f});
  for (int i = 0; i < 100; ++i) rig.tick(true, true);
  EXPECT_EQ(proto::MODE_PATH, rig.cart.mode());
  EXPECT_LT(rig.plant.x, -0.05);
  EXPECT_FALSE(rig.flag(proto::FLAG_BUMPER));
}

// ---- Reset routine -------------------------------------------------------------------------

TEST(CartLoop, ResetRoutineCreepsSquaresUpAndSetsThePose) {
  Rig rig;
  rig.cart.start_reset_routine();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE);
  const float creep = params::control::reset_routine_speed_mps;  // 0.1 m/s

  // No switch for 3 s: both wheels creep forwards (the PI settles in ~2 s on this plant).
  for (int i = 0; i < 375; ++i) ASSERT_TRUE(rig.tick().enabled);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE);
  EXPECT_EQ(rig.cart.wheel_targets().left_mps, creep);
  EXPECT_EQ(rig.cart.wheel_targets().right_mps, creep);
  EXPECT_NEAR(rig.plant.v_left, creep, 0.01);
  EXPECT_NEAR(rig.plant.v_right, creep, 0.01);
  EXPECT_GT(rig.plant.x, 0.2);  // ~0.1 m/s for ~3 s, less the start-up
  EXPECT_LT(std::fabs(rig.plant.theta), 0.01);

  // Left switch closes: left wheel target 0, the right keeps creeping, the cart yaws left.
  const double theta_before = rig.plant.theta;
  for (int i = 0; i < 250; ++i) rig.tick(true, false);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE);
  EXPECT_EQ(rig.cart.wheel_targets().left_mps, 0.0f);
  EXPECT_EQ(rig.cart.wheel_targets().right_mps, creep);
  EXPECT_NEAR(rig.plant.v_left, 0.0, 0.01);
  EXPECT_NEAR(rig.plant.v_right, creep, 0.01);
  EXPECT_GT(rig.plant.theta, theta_before + 0.01);
  EXPECT_TRUE(rig.flag(proto::FLAG_SWITCH_LEFT));
  EXPECT_FALSE(rig.flag(proto::FLAG_SWITCH_RIGHT));

  // Both closed: 4 ticks are not enough to be sure ...
  for (int i = 0; i < 4; ++i) {
    rig.tick(true, true);
    ASSERT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE) << i;
  }
  // ... the 5th (40 ms) completes it.
  rig.tick(true, true);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_FALSE(rig.cart.output().enabled);
  EXPECT_FALSE(rig.flag(proto::FLAG_ROUTINE_FAILED));
  const core::Pose& p = rig.cart.odometry().pose();
  EXPECT_EQ(p.x_m, rig.settings.get(id::reset_x_m));  // 1.88 by default
  EXPECT_EQ(p.y_m, rig.settings.get(id::reset_y_m));
  EXPECT_EQ(p.theta_rad, rig.settings.get(id::reset_theta_rad));
  EXPECT_EQ(p.x_m, 1.88f);
}

TEST(CartLoop, ResetRoutineNeedsBothSwitchesSteadyAndUsesTheConfiguredPose) {
  Rig rig;
  ASSERT_EQ(rig.settings.set(id::reset_x_m, -0.5f), 0);
  ASSERT_EQ(rig.settings.set(id::reset_y_m, 0.25f), 0);
  ASSERT_EQ(rig.settings.set(id::reset_theta_rad, 1.5f), 0);
  rig.cart.start_reset_routine();
  for (int i = 0; i < 50; ++i) rig.tick();
  // A bounce: 4 ticks both closed, one tick the right one opens, then 4 more: not settled.
  for (int i = 0; i < 4; ++i) rig.tick(true, true);
  rig.tick(true, false);
  for (int i = 0; i < 4; ++i) rig.tick(true, true);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE);
  rig.tick(true, true);
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_EQ(rig.cart.odometry().pose().x_m, -0.5f);
  EXPECT_EQ(rig.cart.odometry().pose().y_m, 0.25f);
  EXPECT_EQ(rig.cart.odometry().pose().theta_rad, 1.5f);
}

TEST(CartLoop, ResetRoutineGivesUpAfterFortySeconds) {
  Rig rig;
  rig.cart.start_reset_routine();
  // 40 s = 5000 ticks: still searching just before (4999 ticks = 39.992 s) ...
  for (int i = 1; i <= 4999; ++i) {
    rig.tick();
    ASSERT_EQ(rig.cart.mode(), proto::MODE_RESET_ROUTINE) << i;
  }
  EXPECT_FALSE(rig.flag(proto::FLAG_ROUTINE_FAILED));
  // ... and given up, motors off, within one tick after the 40 s.
  rig.tick();
  rig.tick();
  EXPECT_EQ(rig.cart.mode(), proto::MODE_IDLE);
  EXPECT_TRUE(rig.flag(proto::FLAG_ROUTINE_FAILED));
  EXPECT_FALSE(rig.cart.output().enabled);
  EXPECT_FALSE(rig.flag(proto::FLAG_MOTORS_ENABLED));
  // The pose is NOT overwritten with the reset pose: no wall was found.
  EXPECT_NE(rig.cart.odometry().pose().x_m, rig.settings.get(id::reset_x_m));
}

}  // namespace
