#include <gtest/gtest.h>

#include <cmath>

#include "cart.hpp"
#include "motor.hpp"

namespace cart2d {
namespace {

TEST(Motor, NoLoadTopSpeedIsAboutOneMetrePerSecond) {
  const MotorParams m;
  const double omega = steady_speed_radps(m, m.battery_v);
  // (k·V/R − τc) / (k²/R + b) with the robot.toml values.
  const double k = m.torque_constant_nm_per_a, r = m.resistance_ohm;
  EXPECT_NEAR(omega, (k * m.battery_v / r - m.coulomb_friction_nm) / (k * k / r + m.viscous_friction_nms), 1e-12);
  const double v = omega * CartParams{}.body.wheel_radius_m;
  EXPECT_GT(v, 0.9);
  EXPECT_LT(v, 1.1);
}

TEST(Motor, SteadySpeedIsOddAndZeroBelowStiction) {
  const MotorParams m;
  EXPECT_DOUBLE_EQ(steady_speed_radps(m, -6.0), -steady_speed_radps(m, 6.0));
  // Drive torque k·V/R below Coulomb friction: the motor does not turn.
  const double v_stiction = m.coulomb_friction_nm * m.resistance_ohm / m.torque_constant_nm_per_a;
  EXPECT_EQ(steady_speed_radps(m, 0.9 * v_stiction), 0.0);
}

TEST(Motor, TerminalVoltageFollowsSignedDuty) {
  const MotorParams m;
  EXPECT_DOUBLE_EQ(terminal_voltage_v(m, 0.5), 6.0);
  EXPECT_DOUBLE_EQ(terminal_voltage_v(m, -0.25), -3.0);
  EXPECT_DOUBLE_EQ(terminal_voltage_v(m, 2.0), 12.0);  // clamped
}

TEST(Motor, TorqueLawBelowAndAtTheCurrentLimit) {
  MotorParams m;
  const double k = m.torque_constant_nm_per_a, r = m.resistance_ohm;
  TorqueLaw law = torque_law(m, 12.0, 10.0);
  EXPECT_DOUBLE_EQ(law.drive_nm, k * 12.0 / r);
  EXPECT_DOUBLE_EQ(law.damping_nms, k * k / r + m.viscous_friction_nms);
  // Full reverse voltage against full forward speed: (−12 − k·30)/R ≈ −9.1 A; limit it at 5 A.
  m.current_limit_a = 5.0;
  law = torque_law(m, -12.0, 30.0);
  EXPECT_DOUBLE_EQ(law.drive_nm, -k * 5.0);
  EXPECT_DOUBLE_EQ(law.damping_nms, m.viscous_friction_nms);
  EXPECT_DOUBLE_EQ(current_a(m, -12.0, 30.0), -5.0);
}

// Table: the cart reaches the analytic steady speed at several duties. Each motor settles where
// its torque balances its gearbox's friction and its half of the trailing caster's rolling
// resistance c_rr·N_c (0.24 N: 0.2 % off the free-running speed).
class SteadyState : public ::testing::TestWithParam<double> {};

TEST_P(SteadyState, CartSpeedMatchesAnalyticMotorSpeed) {
  const double duty = GetParam();
  const CartParams p;
  Cart cart(p);
  World world(ArenaParams{0.2, 10, 1000.0});  // walls far away
  cart.set_caster_angle(duty > 0 ? 0.0 : 3.14159265358979323846);  // trailing: the cart runs straight
  cart.place(Pose{0, 0, 0});
  for (int i = 0; i < 4 * 4000; ++i) cart.step(0.00025, duty, duty, world);  // 4 s ≫ time constant
  const double caster_drag_nm = p.body.caster.rolling_resistance * cart.body().loads().caster_n * p.body.wheel_radius_m;
  const double expected =
      steady_speed_radps(p.motor, terminal_voltage_v(p.motor, duty), caster_drag_nm / 2) * p.body.wheel_radius_m;
  EXPECT_NEAR(cart.twist().v_mps, expected, 1e-4 * std::fabs(expected) + 1e-9);
  EXPECT_NEAR(cart.twist().omega_radps, 0.0, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Duties, SteadyState, ::testing::Values(0.1, 0.25, 0.5, 0.75, 1.0, -0.5));

}  // namespace
}  // namespace cart2d
