#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "body.hpp"
#include "cart.hpp"

namespace cart2d {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kH = 0.00025;

TEST(ProjectContacts, FreeVelocityKeptWhenFeasible) {
  const Twist free{0.3, 0.1};
  const Twist out = project_contacts(free, 6.0, 0.1, std::vector<VelocityConstraint>{{-1.0, 0.0, -1.0}});
  EXPECT_DOUBLE_EQ(out.v_mps, 0.3);
  EXPECT_DOUBLE_EQ(out.omega_radps, 0.1);
}

TEST(ProjectContacts, HeadOnWallRemovesOnlyTheApproachingSpeed) {
  // Constraint −v ≥ 0 (a wall ahead): v is cut to 0, ω untouched (M is diagonal).
  const Twist out = project_contacts({0.3, 0.7}, 6.0, 0.1, std::vector<VelocityConstraint>{{-1.0, 0.0, 0.0}});
  EXPECT_NEAR(out.v_mps, 0.0, 1e-12);
  EXPECT_NEAR(out.omega_radps, 0.7, 1e-12);
}

TEST(ProjectContacts, TwoContactsPinBothComponents) {
  const Twist out =
      project_contacts({0.3, 0.7}, 6.0, 0.1, std::vector<VelocityConstraint>{{-1.0, -0.1, 0.0}, {-1.0, 0.1, 0.0}});
  EXPECT_NEAR(out.v_mps, 0.0, 1e-12);
  EXPECT_NEAR(out.omega_radps, 0.0, 1e-12);
}

TEST(ProjectContacts, MovingAwayIsAllowed) {
  const Twist out =
      project_contacts({-0.3, 0.0}, 6.0, 0.1, std::vector<VelocityConstraint>{{-1.0, -0.1, 0.0}, {-1.0, 0.1, 0.0}});
  EXPECT_DOUBLE_EQ(out.v_mps, -0.3);
}

TEST(Body, ArcIntegrationIsExact) {
  Body body{BodyParams{}};
  body.place({0, 0, 0});
  // Quarter circle of radius 1 m at constant twist: ends at (1, 1, π/2).
  const double w = 0.5;
  const int n = 3000;
  const double h = kPi / 2 / w / n;
  for (int i = 0; i < n; ++i) body.advance_kinematic(h, {w * 1.0, w});
  EXPECT_NEAR(body.pose().x_m, 1.0, 1e-9);
  EXPECT_NEAR(body.pose().y_m, 1.0, 1e-9);
  EXPECT_NEAR(body.pose().theta_rad, kPi / 2, 1e-9);
}

TEST(Body, WrapAngle) {
  EXPECT_NEAR(wrap_angle(3 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(-3 * kPi / 2), kPi / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(0.25), 0.25, 1e-15);
}

// The weight rests on three points; the loads must balance it in force and in both moments
// (robot.toml: 23.3 N per tyre and 12.2 N on the trailing caster).
TEST(Body, SupportLoadsBalanceTheWeight) {
  const BodyParams p;
  for (double caster : {0.0, 0.7, kPi / 2, -2.0, kPi}) {
    Body body{p};
    body.set_caster_angle(caster);
    const SupportLoads n = body.loads();
    const double w = p.mass_kg * Body::kGravity;
    const double xp = caster_contact_x_m(p.caster, caster), yp = caster_contact_y_m(p.caster, caster);
    EXPECT_NEAR(n.left_n + n.right_n + n.caster_n, w, 1e-9);
    EXPECT_NEAR(n.caster_n * xp, w * p.com_x_m, 1e-9);                              // about the axle
    EXPECT_NEAR((n.left_n - n.right_n) * p.track_m / 2 + n.caster_n * yp, 0.0, 1e-9);  // about the centre line
  }
  Body trailing{p};
  trailing.set_caster_angle(0.0);
  EXPECT_NEAR(trailing.loads().left_n, 23.3, 0.05);
  EXPECT_NEAR(trailing.loads().caster_n, 12.2, 0.05);
}

// Same inputs, same trajectory, bit for bit (the solver's sweeps are a fixed sequence).
TEST(Body, DeterministicTrajectory) {
  World world{ArenaParams{}};
  Cart a{CartParams{}}, b{CartParams{}};
  a.place({1.5, 0.5, 0.3});
  b.place({1.5, 0.5, 0.3});
  for (int i = 0; i < 6 * 4000; ++i) {
    const double t = i * kH;
    const double dl = std::sin(1.3 * t), dr = std::sin(0.9 * t + 1.0);  // full duty: slips, backlash, walls
    a.step(kH, dl, dr, world);
    b.step(kH, dl, dr, world);
    ASSERT_EQ(a.pose().x_m, b.pose().x_m) << i;
    ASSERT_EQ(a.pose().theta_rad, b.pose().theta_rad) << i;
    ASSERT_EQ(a.wheel_speed_l_radps(), b.wheel_speed_l_radps()) << i;
    ASSERT_EQ(a.caster_angle_rad(), b.caster_angle_rad()) << i;
  }
}

// With the bridges braking (duty 0) nothing drives the cart: its kinetic energy (body and both
// motors) must never grow, whatever the slips, backlash impacts and caster swings do.
TEST(Body, BrakingNeverAddsEnergy) {
  World world{ArenaParams{0.2, 10, 1000.0}};  // walls far away
  Cart cart{CartParams{}};
  const BodyParams& p = cart.params().body;
  auto energy = [&] {
    const double v = cart.twist().v_mps, w = cart.twist().omega_radps;
    const double ml = cart.motor_speed_l_radps(), mr = cart.motor_speed_r_radps();
    return 0.5 * p.mass_kg * v * v + 0.5 * p.yaw_inertia_kgm2 * w * w +
           0.5 * p.drivetrain_inertia_kgm2 * (ml * ml + mr * mr);
  };
  cart.place({0, 0, 0});
  for (int i = 0; i < 4000; ++i) cart.step(kH, 1.0, 0.2, world);  // fast, turning, caster swung
  ASSERT_LT(cart.twist().omega_radps, -1.0);  // clockwise: the left wheel drives harder
  double last = energy();
  for (int i = 0; i < 2 * 4000; ++i) {
    cart.step(kH, 0.0, 0.0, world);
    ASSERT_LE(energy(), last * (1.0 + 1e-12) + 1e-15) << "energy grew at step " << i;
    last = energy();
  }
  EXPECT_LT(last, 1e-20);
}

// At rest with no drive every dry-friction row holds: the cart does not creep.
TEST(Body, RestStaysPut) {
  World world{ArenaParams{}};
  Cart cart{CartParams{}};
  cart.place({0.9, 0.9, 0.4});
  for (int i = 0; i < 10 * 4000; ++i) cart.step(kH, 0.0, 0.0, world);
  EXPECT_NEAR(cart.pose().x_m, 0.9, 1e-12);
  EXPECT_NEAR(cart.pose().y_m, 0.9, 1e-12);
  EXPECT_NEAR(cart.pose().theta_rad, 0.4, 1e-12);
}

}  // namespace
}  // namespace cart2d
