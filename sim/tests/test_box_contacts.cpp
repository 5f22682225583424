// The cart's dynamics against boxes and map walls: contacts stop it without penetration, close its
// switches, spin its wheels when it pushes; a map's corridor lets it through.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "box_at.hpp"
#include "cart.hpp"
#include "measuring_wheels.hpp"

namespace cart2d {
namespace {

constexpr double kH = 0.00025;  // the rig's physics step (s)

double deepest(const Cart& cart) {
  double gap = 1e9;
  for (const ContactProbe& p : cart.probes()) gap = std::min(gap, p.gap_m);
  return gap;
}

// Steps the cart as the rig does: physics, deferred boxes, contact statistics.
void run(Cart* cart, World* world, ContactMonitor* monitor, double seconds, double duty_l, double duty_r,
         double* worst_gap = nullptr) {
  const int steps = static_cast<int>(seconds / kH + 0.5);
  for (int i = 0; i < steps; ++i) {
    cart->step(kH, duty_l, duty_r, *world);
    if (!world->deferred().empty()) world->settle(cart->pose(), cart->params().geometry);
    monitor->update(i * kH, *world, cart->pose(), cart->params().geometry, cart->probes());
    if (worst_gap) *worst_gap = std::min(*worst_gap, deepest(*cart));
  }
}

TEST(BoxContacts, ACartDrivenIntoABoxStopsAtItAndClosesBothSwitches) {
  World world(ArenaParams{0.2, 20, 0.25});
  world.add(box_at(1.2, 0.9, 0.2, 0.6, "crate"));  // west face at x = 1.1
  Cart cart{CartParams{}};
  cart.set_caster_angle(0.0);
  cart.place({0.5, 0.9, 0.0});
  ContactMonitor monitor;
  double worst = 1e9;
  run(&cart, &world, &monitor, 3.0, 0.3, 0.3, &worst);
  EXPECT_GE(worst, -1e-9) << "penetrated";
  EXPECT_NEAR(cart.pose().x_m, 1.1 - cart.params().geometry.bumper_x_m, 1e-6);
  EXPECT_NEAR(cart.twist().v_mps, 0.0, 1e-9);
  EXPECT_TRUE(cart.switch_left());
  EXPECT_TRUE(cart.switch_right());
  EXPECT_EQ(monitor.box_contacts(), 1);
  EXPECT_EQ(monitor.wall_contacts(), 0);
  EXPECT_EQ(monitor.collisions(), 0);
  EXPECT_TRUE(monitor.in_box_contact());
  const auto events = monitor.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, "box_contact");
  EXPECT_EQ(events[0].id, "crate");
  EXPECT_EQ(events[0].x_m, 1.2);
}

// A corner between the switches meets the flat bumper: the cart, heading at 45° for the box's
// south-west corner, stops on it (without the bumper feature the corner would sink 7 mm into the
// bumper, up to the disc), and the switch on that side closes (the plate carries the push to its
// nearer switch; the switch's own point is still 3.5 cm from the box's face).
TEST(BoxContacts, ACornerOnTheBumperStopsTheCartAndClosesTheSwitchOnItsSide) {
  constexpr double kQuarterPi = 0.78539816339744831;
  World world(ArenaParams{0.2, 20, 0.25});
  world.add(box_at(1.35, 1.2, 0.5, 0.5));  // south-west corner at (1.1, 0.95)
  Cart cart{CartParams{}};
  cart.set_caster_angle(0.0);
  // 0.6 m behind the corner along the heading, the corner 5 cm left of the axis.
  const double c = std::cos(kQuarterPi), s = std::sin(kQuarterPi);
  cart.place({1.1 - 0.6 * c + 0.05 * s, 0.95 - 0.6 * s - 0.05 * c, kQuarterPi});
  const RobotGeometry& g = cart.params().geometry;
  ContactMonitor monitor;
  bool seen = false, left_first = false;
  double deepest_into_bumper = 0.0;
  for (int i = 0; i < 3 * 4000; ++i) {
    cart.step(kH, 0.3, 0.3, world);
    monitor.update(i * kH, world, cart.pose(), g, cart.probes());
    // The corner in the body frame: between the switches it must stay ahead of the bumper.
    const Pose& p = cart.pose();
    const double qx = 1.1 - p.x_m, qy = 0.95 - p.y_m;
    const double xb = std::cos(p.theta_rad) * qx + std::sin(p.theta_rad) * qy;
    const double yb = -std::sin(p.theta_rad) * qx + std::cos(p.theta_rad) * qy;
    if (std::fabs(yb) < g.switch_y_m && xb > 0.0) deepest_into_bumper = std::max(deepest_into_bumper, g.bumper_x_m - xb);
    if (!seen && (cart.switch_left() || cart.switch_right())) {
      seen = true;
      left_first = cart.switch_left() && !cart.switch_right();
      EXPECT_NEAR(xb, g.bumper_x_m, 1e-3);  // the corner is on the bumper
      EXPECT_NEAR(yb, 0.05, 1e-3);
    }
  }
  EXPECT_TRUE(seen);
  EXPECT_TRUE(left_first);
  EXPECT_LT(deepest_into_bumper, 1e-6) << "the corner went into the bumper";
  EXPECT_EQ(monitor.box_contacts(), 1);
}

// Full PWM against a box: as against a wall (test_drivetrain.cpp), the tyres spin while the
// measuring wheels, rolling with the body, stand still.
TEST(BoxContacts, PushingABoxAtFullDutySpinsTheWheels) {
  World world;  // an endless floor with one box
  world.add(box_at(1.2, 0.0, 0.2, 0.6));
  Cart cart{CartParams{}};
  cart.set_caster_angle(0.0);
  cart.place({0.5, 0.0, 0.0});
  ContactMonitor monitor;
  run(&cart, &world, &monitor, 2.0, 1.0, 1.0);
  const MeasuringWheelParams wheels;
  double measured_m = 0.0;
  for (int i = 0; i < 4000; ++i) {
    cart.step(kH, 1.0, 1.0, world);
    measured_m += advance_measuring_wheels(wheels, Faults{}, cart.twist(), kH).dist_l_m;
  }
  EXPECT_NEAR(cart.pose().x_m, 1.1 - cart.params().geometry.bumper_x_m, 1e-6);
  EXPECT_GT(cart.slip_l_mps(), 0.5);  // ~0.68 m/s: the motors' torque against μ·N
  EXPECT_GT(cart.slip_r_mps(), 0.5);
  EXPECT_NEAR(measured_m, 0.0, 1e-9);
  EXPECT_EQ(monitor.box_contacts(), 1);
}

// A box that appears under the cart does not fling it away; once the cart has backed out of it,
// it is solid and stops the cart when it comes back.
TEST(BoxContacts, ABoxThatAppearsUnderTheCartBecomesSolidWhenTheCartHasLeftIt) {
  World world;
  Cart cart{CartParams{}};
  cart.set_caster_angle(0.0);
  cart.place({1.0, 0.0, 0.0});
  world.add(box_at(1.2, 0.0, 0.2, 0.2));  // its west face at 1.1: under the front of the cart
  EXPECT_EQ(world.defer_overlapping(cart.pose(), cart.params().geometry), 1u);
  EXPECT_FALSE(world.boxes()[0].solid);
  ContactMonitor monitor;
  run(&cart, &world, &monitor, 0.5, 0.0, 0.0);
  EXPECT_NEAR(cart.pose().x_m, 1.0, 1e-9);  // not pushed out
  EXPECT_EQ(monitor.box_contacts(), 1);      // the overlap counts
  run(&cart, &world, &monitor, 1.5, -0.3, -0.3);
  ASSERT_LT(cart.pose().x_m, 1.1 - 0.17 - 0.01);
  EXPECT_TRUE(world.boxes()[0].solid);
  EXPECT_FALSE(monitor.in_box_contact());
  double worst = 1e9;
  run(&cart, &world, &monitor, 3.0, 0.3, 0.3, &worst);
  EXPECT_GE(worst, -1e-9);
  EXPECT_NEAR(cart.pose().x_m, 1.1 - 0.17, 1e-6);
  EXPECT_EQ(monitor.box_contacts(), 2);
}

// A physical obstacle (a mission's event obstacle) stops the cart before its footprint can overlap
// the obstacle's cell: touching its box counts as the obstacle's collision, once, and as a box
// contact; an ordinary box of the same size there is no collision.
TEST(BoxContacts, TouchingAPhysicalObstacleCountsAsItsCollision) {
  for (bool twin : {true, false}) {
    World world(ArenaParams{0.2, 20, 0.25});
    Obstacle o;
    o.cx_m = 1.4;
    o.cy_m = 0.9;
    o.half_m = 0.1;
    if (twin) world.add_obstacle(o);
    Box b = box_at(1.4, 0.9, 0.2, 0.2, twin ? "obstacle@1.4,0.9" : "crate");
    b.obstacle_twin = twin;
    world.add(b);
    Cart cart{CartParams{}};
    cart.set_caster_angle(0.0);
    cart.place({0.6, 0.9, 0.0});
    ContactMonitor monitor;
    run(&cart, &world, &monitor, 4.0, 0.3, 0.3);
    EXPECT_NEAR(cart.pose().x_m, 1.3 - 0.17, 1e-6);
    EXPECT_EQ(monitor.box_contacts(), 1);
    EXPECT_EQ(monitor.collisions(), twin ? 1 : 0);
    EXPECT_EQ(monitor.in_collision(), twin);
    // Stopped 50 um short, as the firmware's bumper stop may leave it: touching, not overlapping.
    const RobotGeometry& g = cart.params().geometry;
    cart.place({1.3 - g.footprint_radius_m - 5e-5, 0.9, 0.0});
    cart.sense(world);
    ContactMonitor still;
    still.update(0.0, world, cart.pose(), g, cart.probes());
    EXPECT_EQ(still.box_contacts(), 1);
    EXPECT_EQ(still.collisions(), twin ? 1 : 0);
  }
}

// A map: a 0.6 m thick wall across the floor with a 0.5 m corridor through it (the cart is 0.34 m
// wide, its bumper ends 0.394 m apart).
World corridor_world() {
  OccupancyGrid g{80, 40, {}};  // 4 m × 2 m at 5 cm, origin (−0.5, −1.0)
  g.occupied.assign(80 * 40, 0);
  for (int j = 0; j < 40; ++j) {
    if (j >= 15 && j < 25) continue;  // y in [−0.25, 0.25)
    for (int i = 30; i < 42; ++i) g.occupied[j * 80 + i] = 1;  // x in [1.0, 1.6)
  }
  World w;
  w.add_wall_grid(-0.5, -1.0, 0.05, g);
  w.add_boundary(-0.5, -1.0, 3.5, 1.0);
  return w;
}

TEST(BoxContacts, AMapsCorridorLetsTheCartThroughAndItsWallsStopIt) {
  World world = corridor_world();
  EXPECT_EQ(world.count(BoxKind::kWall), 2u + 4u);  // two blocks beside the corridor, the boundary
  Cart cart{CartParams{}};
  cart.set_caster_angle(0.0);
  cart.place({0.2, 0.0, 0.0});
  ContactMonitor monitor;
  run(&cart, &world, &monitor, 5.0, 0.5, 0.5);
  EXPECT_GT(cart.pose().x_m, 1.6 + 0.17);  // through
  EXPECT_NEAR(cart.pose().y_m, 0.0, 1e-9);
  EXPECT_EQ(monitor.wall_contacts(), 0);

  Cart blocked{CartParams{}};
  blocked.set_caster_angle(0.0);
  blocked.place({0.2, 0.6, 0.0});
  ContactMonitor m2;
  double worst = 1e9;
  run(&blocked, &world, &m2, 4.0, 0.3, 0.3, &worst);
  EXPECT_NEAR(blocked.pose().x_m, 1.0 - 0.17, 1e-6);  // at the wall's face
  EXPECT_GE(worst, -1e-9);
  EXPECT_TRUE(blocked.switch_left() && blocked.switch_right());
  EXPECT_EQ(m2.wall_contacts(), 1);
  EXPECT_EQ(m2.box_contacts(), 0);
}

}  // namespace
}  // namespace cart2d
