#include <gtest/gtest.h>

#include <cmath>

#include "cart.hpp"
#include "measuring_wheels.hpp"

namespace cart2d {
namespace {

constexpr double kH = 0.00025;

struct Arena {
  World world{ArenaParams{}};  // walls 0.25 m outside [0, 1.8]²
  Cart cart{CartParams{}};
};

// With the caster trailing straight behind, the cart is symmetric: equal duties drive it straight
// (a misaligned caster would steer it: test_caster.cpp). The solver's row order breaks the
// symmetry only at rounding level.
TEST(Cart, EqualDutiesDriveStraight) {
  Arena a;
  a.cart.set_caster_angle(0.0);
  a.cart.place({0.2, 0.9, 0.0});
  for (int i = 0; i < 2 * 4000; ++i) a.cart.step(kH, 0.3, 0.3, a.world);
  EXPECT_GT(a.cart.pose().x_m, 0.5);
  EXPECT_NEAR(a.cart.pose().y_m, 0.9, 1e-12);
  EXPECT_NEAR(a.cart.pose().theta_rad, 0.0, 1e-12);
  EXPECT_NEAR(a.cart.wheel_speed_l_radps(), a.cart.wheel_speed_r_radps(), 1e-9);
}

// Turning on the spot the axle centre no longer stays exactly put (it did when the centre of mass
// sat on the axle and nothing else touched the floor): the centre of mass 3 cm behind the axle
// pulls it back with m·x_g·ω² (1.6 N at 3 rad/s) and the caster's rolling resistance pushes it
// around; the motors yield a little to both. The centre circles ~4 mm around (open loop).
TEST(Cart, OppositeDutiesTurnOnTheSpot) {
  Arena a;
  a.cart.place({0.9, 0.9, 0.0});
  for (int i = 0; i < 4000; ++i) a.cart.step(kH, -0.3, 0.3, a.world);
  EXPECT_NEAR(a.cart.pose().x_m, 0.9, 0.01);
  EXPECT_NEAR(a.cart.pose().y_m, 0.9, 0.01);
  EXPECT_GT(a.cart.twist().omega_radps, 1.0);  // counter-clockwise: right wheel forward
}

// Braking, the gearboxes' dry friction and the caster's rolling resistance bring the cart to rest
// and hold it there (to the solver's tolerance, 1e-10 m/s; RestStaysPut in test_body.cpp).
TEST(Cart, ZeroDutyBrakesToAStop) {
  Arena a;
  a.cart.place({0.2, 0.9, 0.0});
  for (int i = 0; i < 4000; ++i) a.cart.step(kH, 0.5, 0.5, a.world);
  for (int i = 0; i < 4000; ++i) a.cart.step(kH, 0.0, 0.0, a.world);
  EXPECT_NEAR(a.cart.twist().v_mps, 0.0, 1e-10);
  EXPECT_NEAR(a.cart.twist().omega_radps, 0.0, 1e-10);
}

TEST(Cart, WallStopsTheCartAndClosesBothSwitches) {
  Arena a;
  const double wall_x = a.world.arena().x_max();  // 2.05 m
  const double bumper = a.cart.params().geometry.bumper_x_m;
  a.cart.place({1.5, 0.9, 0.0});
  ContactMonitor monitor;
  for (int i = 0; i < 3 * 4000; ++i) {
    a.cart.step(kH, 0.3, 0.3, a.world);
    monitor.update(i * kH, a.world, a.cart.pose(), a.cart.params().geometry, a.cart.probes());
    ASSERT_LE(a.cart.pose().x_m + bumper, wall_x + 1e-9) << "penetrated at step " << i;
  }
  EXPECT_NEAR(a.cart.pose().x_m, wall_x - bumper, 1e-6);
  EXPECT_NEAR(a.cart.twist().v_mps, 0.0, 1e-9);
  EXPECT_TRUE(a.cart.switch_left());
  EXPECT_TRUE(a.cart.switch_right());
  EXPECT_EQ(monitor.wall_contacts(), 1);
  EXPECT_EQ(monitor.collisions(), 0);
  // At 30 % the motors push 2 × 15 N, less than the floor's 2 × 16 N: the tyres hold and the
  // motors stall at V·duty/R (at full duty the wheels spin: test_drivetrain.cpp).
  EXPECT_NEAR(a.cart.current_l_a(), 12.0 * 0.3 / a.cart.params().motor.resistance_ohm, 1e-6);
  EXPECT_EQ(a.cart.slip_l_mps(), 0.0);
}

TEST(Cart, SwitchesStayOpenAwayFromWalls) {
  Arena a;
  a.cart.place({0.9, 0.9, 0.5});
  a.cart.sense(a.world);
  EXPECT_FALSE(a.cart.switch_left());
  EXPECT_FALSE(a.cart.switch_right());
}

// The reset routine's physics: approach at an angle, one switch touches first; holding that side
// and pushing the other squares the bumper against the wall without ever penetrating it.
TEST(Cart, SquaringUpAgainstTheWall) {
  Arena a;
  a.cart.place({1.5, 0.9, 0.2});  // heading slightly left: the right switch leads
  bool right_first = false, seen_any = false;
  int both_for = 0;
  for (int i = 0; i < 20 * 4000 && both_for < 400; ++i) {
    const bool l = a.cart.switch_left(), r = a.cart.switch_right();
    if (!seen_any && (l || r)) {
      seen_any = true;
      right_first = r && !l;
    }
    both_for = l && r ? both_for + 1 : 0;
    a.cart.step(kH, l ? 0.0 : 0.15, r ? 0.0 : 0.15, a.world);
    for (const auto& p : a.cart.probes()) ASSERT_GE(p.gap_m, -1e-6) << "penetration at step " << i;
  }
  EXPECT_TRUE(right_first);
  EXPECT_GE(both_for, 400);
  EXPECT_NEAR(a.cart.pose().theta_rad, 0.0, 0.02);
  EXPECT_NEAR(a.cart.pose().x_m, a.world.arena().x_max() - a.cart.params().geometry.bumper_x_m, 0.005);
}

TEST(Cart, BackingIntoAWallStopsOnTheFootprintDisc) {
  Arena a;
  a.cart.place({0.2, 0.9, 0.0});
  for (int i = 0; i < 3 * 4000; ++i) a.cart.step(kH, -0.3, -0.3, a.world);
  EXPECT_NEAR(a.cart.pose().x_m, a.world.arena().x_min() + a.cart.params().geometry.footprint_radius_m, 1e-6);
  EXPECT_FALSE(a.cart.switch_left());
}

TEST(MeasuringWheels, NominalAndFaultyAngles) {
  const MeasuringWheelParams p;
  Faults f;
  WheelAdvance a = advance_measuring_wheels(p, f, {0.1, 0.0}, 1.0);
  EXPECT_NEAR(a.angle_l_rad, 0.1 / p.radius_m, 1e-12);
  EXPECT_NEAR(a.angle_r_rad, 0.1 / p.radius_m, 1e-12);
  a = advance_measuring_wheels(p, f, {0.0, 1.0}, 1.0);  // spin: wheels at ±track/2
  EXPECT_NEAR(a.dist_r_m, p.track_m / 2, 1e-12);
  EXPECT_NEAR(a.dist_l_m, -p.track_m / 2, 1e-12);
  f.enc_radius_scale_l = 1.01;
  f.enc_slip_r = 0.1;
  f.enc_track_error_m = 0.01;
  a = advance_measuring_wheels(p, f, {0.1, 1.0}, 1.0);
  EXPECT_NEAR(a.angle_l_rad, (0.1 - (p.track_m + 0.01) / 2) / (p.radius_m * 1.01), 1e-12);
  EXPECT_NEAR(a.angle_r_rad, (0.1 + (p.track_m + 0.01) / 2) * 0.9 / p.radius_m, 1e-12);
}

}  // namespace
}  // namespace cart2d
