#include <gtest/gtest.h>

#include <cmath>

#include "body.hpp"

namespace cart2d {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(WheelStep, StallsWhenDriveIsBelowCoulombFriction) {
  const double mq[4] = {0.01, 0.001, 0.001, 0.01};
  const double c[2] = {0.05, 0.05};
  const double q0[2] = {0.0, 0.0};
  const double drive[2] = {0.04, -0.03};
  double q1[2];
  solve_wheel_step(mq, c, q0, drive, 0.05, 0.00025, q1);
  EXPECT_EQ(q1[0], 0.0);
  EXPECT_EQ(q1[1], 0.0);
}

TEST(WheelStep, SlidesWithFrictionSubtracted) {
  const double mq[4] = {0.01, 0.0, 0.0, 0.01};
  const double c[2] = {0.0, 0.0};
  const double q0[2] = {1.0, -1.0};
  const double drive[2] = {0.15, -0.15};
  double q1[2];
  const double h = 0.001;
  solve_wheel_step(mq, c, q0, drive, 0.05, h, q1);
  EXPECT_NEAR(q1[0], 1.0 + h * (0.15 - 0.05) / 0.01, 1e-12);
  EXPECT_NEAR(q1[1], -1.0 - h * (0.15 - 0.05) / 0.01, 1e-12);
}

TEST(WheelStep, FrictionStopsACoastingWheelWithoutReversing) {
  const double mq[4] = {0.01, 0.0, 0.0, 0.01};
  const double c[2] = {0.0, 0.0};
  double q[2] = {0.01, 0.0};
  const double drive[2] = {0.0, 0.0};
  for (int i = 0; i < 100; ++i) {
    double q1[2];
    solve_wheel_step(mq, c, q, drive, 0.05, 0.001, q1);
    EXPECT_GE(q1[0], 0.0);
    q[0] = q1[0];
    q[1] = q1[1];
  }
  EXPECT_EQ(q[0], 0.0);
}

TEST(ProjectContacts, FreeVelocityKeptWhenFeasible) {
  const Twist free{0.3, 0.1};
  const Twist out = project_contacts(free, 6.0, 0.1, {{-1.0, 0.0, -1.0}});
  EXPECT_DOUBLE_EQ(out.v_mps, 0.3);
  EXPECT_DOUBLE_EQ(out.omega_radps, 0.1);
}

TEST(ProjectContacts, HeadOnWallRemovesOnlyTheApproachingSpeed) {
  // Constraint −v ≥ 0 (a wall ahead): v is cut to 0, ω untouched (M is diagonal).
  const Twist out = project_contacts({0.3, 0.7}, 6.0, 0.1, {{-1.0, 0.0, 0.0}});
  EXPECT_NEAR(out.v_mps, 0.0, 1e-12);
  EXPECT_NEAR(out.omega_radps, 0.7, 1e-12);
}

TEST(ProjectContacts, TwoContactsPinBothComponents) {
  const Twist out = project_contacts({0.3, 0.7}, 6.0, 0.1, {{-1.0, -0.1, 0.0}, {-1.0, 0.1, 0.0}});
  EXPECT_NEAR(out.v_mps, 0.0, 1e-12);
  EXPECT_NEAR(out.omega_radps, 0.0, 1e-12);
}

TEST(ProjectContacts, MovingAwayIsAllowed) {
  const Twist out = project_contacts({-0.3, 0.0}, 6.0, 0.1, {{-1.0, -0.1, 0.0}, {-1.0, 0.1, 0.0}});
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

}  // namespace
}  // namespace cart2d
