#include "cart.hpp"

namespace cart2d {

Cart::Cart(const CartParams& p) : p_(p), body_(p.body) {}

void Cart::place(const Pose& pose) {
  body_.place(pose);
  current_l_a_ = current_r_a_ = 0.0;
  probes_world_ = nullptr;
}

// A switch closes when its point is within travel of a wall or box, or when a corner presses the
// bumper on its side: the bumper is a plate on the two switches, and the one nearer the push
// carries the larger share of the force (lever rule); a push in the middle closes both.
void Cart::sense(const World& world) {
  world.probes(body_.pose(), p_.geometry, &probes_);
  probes_world_ = &world;
  probes_version_ = world.version();
  double gap_l = 1e9, gap_r = 1e9;
  for (const auto& probe : probes_) {
    const bool bumper = probe.feature == ContactProbe::kBumper;
    if ((probe.feature == ContactProbe::kSwitchLeft || (bumper && probe.lateral_m >= 0.0)) && probe.gap_m < gap_l)
      gap_l = probe.gap_m;
    if ((probe.feature == ContactProbe::kSwitchRight || (bumper && probe.lateral_m <= 0.0)) && probe.gap_m < gap_r)
      gap_r = probe.gap_m;
  }
  switch_l_ = gap_l <= p_.switch_travel_m;
  switch_r_ = gap_r <= p_.switch_travel_m;
}

void Cart::step(double h, double duty_l, double duty_r, const World& world) {
  const double wl = body_.side(0).motor_radps, wr = body_.side(1).motor_radps;
  const double vl = terminal_voltage_v(p_.motor, duty_l), vr = terminal_voltage_v(p_.motor, duty_r);
  const TorqueLaw left = torque_law(p_.motor, vl, wl);
  const TorqueLaw right = torque_law(p_.motor, vr, wr);

  // Contacts are speculative: a feature within reach this step may close its gap exactly to zero
  // (J·u ≥ −gap/h) but not beyond; one already inside a wall is pushed out over a few steps.
  // The last step's sense() measured them at this pose already.
  if (probes_world_ != &world || probes_version_ != world.version()) world.probes(body_.pose(), p_.geometry, &probes_);
  constraints_.clear();
  constexpr double kReachM = 0.02;
  constexpr double kPushOut = 0.2;  // fraction of a penetration removed per step
  for (const auto& probe : probes_) {
    if (probe.gap_m > kReachM) continue;
    const double min_rate = probe.gap_m >= 0 ? -probe.gap_m / h : -kPushOut * probe.gap_m / h;
    constraints_.push_back({probe.jv, probe.jw, min_rate});
  }
  body_.step(h, left, right, constraints_);
  current_l_a_ = current_a(p_.motor, vl, body_.side(0).motor_radps);
  current_r_a_ = current_a(p_.motor, vr, body_.side(1).motor_radps);
  sense(world);
}

}  // namespace cart2d

namespace cart2d {

void Cart::step_kinematic(double h, const Twist& twist, const World& world) {
  body_.advance_kinematic(h, twist);
  current_l_a_ = current_r_a_ = 0.0;
  sense(world);
}

}  // namespace cart2d
