// The swivel caster: its kinematics, and what its drag does to the cart when it trails, when the
// cart reverses (it swings round) and when the cart turns on the spot (it scrubs round).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "cart.hpp"
#include "caster.hpp"

namespace cart2d {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kH = 0.00025;

// The rows' Jacobians against the contact point's motion computed from the geometry: the body
// moves by (v, ω) for a short time with the swivel held, and the contact's displacement is
// resolved along the caster wheel (rolling) and across it (sideways).
TEST(Caster, JacobiansMatchTheContactMotion) {
  const CasterParams p;
  for (double phi : {0.0, 0.4, 1.7, -2.5, kPi}) {
    for (const Twist u : {Twist{0.3, 0.0}, Twist{0.0, 2.0}, Twist{-0.2, 0.7}}) {
      const double dt = 1e-7;
      const double px = caster_contact_x_m(p, phi), py = caster_contact_y_m(p, phi);
      // Body frame at t = 0 is the world frame; after dt it moved by v·dt and turned by ω·dt.
      const double th = u.omega_radps * dt;
      const double qx = u.v_mps * dt + std::cos(th) * px - std::sin(th) * py;
      const double qy = std::sin(th) * px + std::cos(th) * py;
      const double vx = (qx - px) / dt, vy = (qy - py) / dt;
      const CasterJacobians j = caster_jacobians(p, phi);
      EXPECT_NEAR(j.roll_v * u.v_mps + j.roll_w * u.omega_radps, vx * std::cos(phi) + vy * std::sin(phi), 1e-6);
      EXPECT_NEAR(j.side_v * u.v_mps + j.side_w * u.omega_radps, -vx * std::sin(phi) + vy * std::cos(phi), 1e-6);
    }
  }
}

TEST(Caster, SideForceIsTheSwivelFrictionOrTheFloorsWhicheverIsLess) {
  CasterParams p;
  EXPECT_NEAR(caster_side_limit_n(p, 10.0), 10.0 * p.swivel_friction_arm_m / p.trail_m, 1e-12);
  EXPECT_NEAR(caster_swivel_rate_radps(p, 0.05), 0.05 / p.trail_m, 1e-12);
  p.swivel_friction_arm_m = 0.02;  // a seized swivel: it scrubs instead of turning
  EXPECT_NEAR(caster_side_limit_n(p, 10.0), 10.0 * p.lateral_friction, 1e-12);
  EXPECT_EQ(caster_swivel_rate_radps(p, 0.05), 0.0);
}

struct Arena {
  World world{ArenaParams{0.2, 10, 1000.0}};  // walls far away
  Cart cart;
  explicit Arena(const CartParams& p = CartParams{}) : cart(p) {}
};

CartParams drag_free() {
  CartParams p;
  p.body.caster.rolling_resistance = 0.0;
  p.body.caster.swivel_friction_arm_m = 0.0;
  return p;
}

TEST(Caster, TrailsBehindWhenDrivingForwards) {
  Arena a;
  a.cart.set_caster_angle(0.5);
  a.cart.place({0, 0, 0});
  for (int i = 0; i < 2 * 4000; ++i) a.cart.step(kH, 0.3, 0.3, a.world);
  // It stops aligning once the force needed to bend the motors' path drops below its swivel
  // friction (~0.3 N): open loop, the cart then curves slightly, as a cart with a sticky caster does.
  EXPECT_LT(std::fabs(a.cart.caster_angle_rad()), 0.05);
  EXPECT_LT(std::fabs(a.cart.twist().omega_radps), 0.1);
}

// Backing up, the caster swings through half a turn to trail again; while it is across the
// motion its drag turns the cart (open loop here: nothing corrects the heading).
TEST(Caster, ReversingSwingsTheCasterRound) {
  auto reverse = [](const CartParams& p, double* heading_swing_rad) {
    Arena a(p);
    a.cart.set_caster_angle(0.3);  // never exactly aligned: e.g. after a curve
    a.cart.place({0, 0, 0});
    *heading_swing_rad = 0.0;
    for (int i = 0; i < 4000; ++i) {
      a.cart.step(kH, -0.3, -0.3, a.world);
      *heading_swing_rad = std::max(*heading_swing_rad, std::fabs(a.cart.pose().theta_rad));
      if (a.cart.pose().x_m < -0.25) break;
    }
    return a.cart.caster_angle_rad();
  };
  double swing = 0.0, swing_free = 0.0;
  EXPECT_NEAR(std::fabs(reverse(CartParams{}, &swing)), kPi, 0.05);  // round within 0.25 m (10 trails)
  EXPECT_NEAR(std::fabs(reverse(drag_free(), &swing_free)), kPi, 0.05);
  std::printf("heading swing: %.2f mrad with the caster's drag, %.3f mrad without\n", 1e3 * swing, 1e3 * swing_free);
  EXPECT_GT(swing, 0.003);  // the swing disturbs the heading by several mrad...
  // ...which a caster without drag does not (what is left: the misaligned caster's contact loads
  // one tyre more, and the start's backlash impact slips the lighter one a little more)
  EXPECT_LT(swing_free, 0.05 * swing);
}

// Spinning on the spot, the caster's contact must move sideways: the caster drags at its limit
// while it swings round to the tangent of its circle, then rolls along it; its rolling resistance
// then costs the motors torque.
TEST(Caster, TurningOnTheSpotScrubsItRound) {
  Arena a;
  a.cart.set_caster_angle(0.0);
  a.cart.place({0, 0, 0});
  int at_limit = 0;
  for (int i = 0; i < 400; ++i) {  // the first 0.1 s (the first ~3 ms the motors cross the backlash)
    // The limit of this step: the load moves with the contact as the caster swings.
    const double limit = caster_side_limit_n(a.cart.params().body.caster, a.cart.body().loads().caster_n);
    a.cart.step(kH, -0.3, 0.3, a.world);
    if (std::fabs(a.cart.body().caster_side_force_n()) >= limit * (1 - 1e-9)) ++at_limit;
  }
  EXPECT_GT(at_limit, 360);
  EXPECT_LT(a.cart.caster_angle_rad(), -0.3);  // swinging round meanwhile
  for (int i = 0; i < 2 * 4000; ++i) a.cart.step(kH, -0.3, 0.3, a.world);
  const CasterParams& c = a.cart.params().body.caster;
  // Pure rotation about the axle centre: the contact rolls on a circle, e = 0 ⇔ x_S·cos φ = t.
  EXPECT_NEAR(a.cart.caster_angle_rad(), -std::acos(c.trail_m / c.swivel_x_m), 0.05);

  Arena free(drag_free());
  free.cart.set_caster_angle(0.0);
  free.cart.place({0, 0, 0});
  for (int i = 0; i < 400 + 2 * 4000; ++i) free.cart.step(kH, -0.3, 0.3, free.world);
  // Steady: the rolling resistance c_rr·N at the contact, |P| from the centre, is a yaw moment the
  // motors carry: each wheel r·M/B more torque, i.e. about r·M/(B·k) more current in the yaw
  // share (I_R − I_L)/2 (the common share pushes against the centre of mass's pull, 3 cm behind
  // the axle, which makes the centre circle ~4 mm around).
  const BodyParams& b = a.cart.params().body;
  const double phi = a.cart.caster_angle_rad();
  const double lever = std::hypot(caster_contact_x_m(c, phi), caster_contact_y_m(c, phi));
  const double moment = c.rolling_resistance * a.cart.body().loads().caster_n * lever;
  const double extra_a = b.wheel_radius_m * moment / (b.track_m * a.cart.params().motor.torque_constant_nm_per_a);
  auto yaw_current = [](const Cart& cart) { return (cart.current_r_a() - cart.current_l_a()) / 2; };
  EXPECT_NEAR(yaw_current(a.cart) - yaw_current(free.cart), extra_a, 0.15 * extra_a);  // ~17 mA
  EXPECT_LT(a.cart.twist().omega_radps, free.cart.twist().omega_radps);
}

}  // namespace
}  // namespace cart2d
