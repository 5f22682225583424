// The physical cart: two motors, the body, its bumper switches and its contacts with the world's
// walls and boxes.
// Everything here is pure physics on a fixed step; the simavr parts feed it duties and read its
// state, and tests drive it directly.
#pragma once

#include <cstdint>
#include <vector>

#include "body.hpp"
#include "motor.hpp"
#include "robot_params.hpp"  // params::sim
#include "world.hpp"

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct CartParams {
  MotorParams motor;
  BodyParams body;
  RobotGeometry geometry;
  double switch_travel_m = params::sim::switch_travel_m;  // a switch closes when its point is this close to a wall or box
};

class Cart {
 public:
  explicit Cart(const CartParams& p);

  // Teleports the cart (at rest).
  void place(const Pose& pose);
  // Advances by h seconds with the given signed duties (+ = forward, from the H-bridges).
  void step(double h, double duty_l, double duty_r, const World& world);
  // Moves with a prescribed twist instead of the dynamics (scripted motion for tests).
  void step_kinematic(double h, const Twist& twist, const World& world);
  // Recomputes the switches and probes at the current pose (after place()).
  void sense(const World& world);

  const Pose& pose() const { return body_.pose(); }
  const Twist& twist() const { return body_.twist(); }
  // The real traction wheel speeds (they differ from the body's motion when a tyre slips).
  double wheel_speed_l_radps() const { return body_.side(0).wheel_radps; }
  double wheel_speed_r_radps() const { return body_.side(1).wheel_radps; }
  double motor_speed_l_radps() const { return body_.side(0).motor_radps; }
  double motor_speed_r_radps() const { return body_.side(1).motor_radps; }
  // Tyre slip, r·ω_wheel − contact speed (m/s, + = spinning forwards over the floor).
  double slip_l_mps() const { return body_.side(0).slip_mps; }
  double slip_r_mps() const { return body_.side(1).slip_mps; }
  double caster_angle_rad() const { return body_.caster_angle_rad(); }
  void set_caster_angle(double angle_rad) { body_.set_caster_angle(angle_rad); }
  const Body& body() const { return body_; }
  double current_l_a() const { return current_l_a_; }
  double current_r_a() const { return current_r_a_; }
  bool switch_left() const { return switch_l_; }
  bool switch_right() const { return switch_r_; }
  // The contact probes at the current pose (for contact statistics).
  const std::vector<ContactProbe>& probes() const { return probes_; }
  const CartParams& params() const { return p_; }

 private:
  CartParams p_;
  Body body_;
  double current_l_a_ = 0.0, current_r_a_ = 0.0;
  bool switch_l_ = false, switch_r_ = false;
  std::vector<ContactProbe> probes_;
  // probes_ hold for the current pose in this world at this version (else probes_world_ is null)
  const World* probes_world_ = nullptr;
  uint64_t probes_version_ = 0;
  std::vector<VelocityConstraint> constraints_;
};

}  // namespace cart2d
