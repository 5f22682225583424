#include "motor.hpp"

#include <algorithm>  // std::clamp
#include <cmath>      // std::fabs

namespace cart2d {

double terminal_voltage_v(const MotorParams& p, double signed_duty) {
  return p.battery_v * std::clamp(signed_duty, -1.0, 1.0);
}

double current_a(const MotorParams& p, double voltage_v, double speed_radps) {
  const double i = (voltage_v - p.torque_constant_nm_per_a * speed_radps) / p.resistance_ohm;
  return std::clamp(i, -p.current_limit_a, p.current_limit_a);
}

TorqueLaw torque_law(const MotorParams& p, double voltage_v, double speed_radps) {
  const double k = p.torque_constant_nm_per_a;
  const double i = (voltage_v - k * speed_radps) / p.resistance_ohm;
  TorqueLaw law;
  if (std::fabs(i) > p.current_limit_a) {
    law.drive_nm = k * (i > 0 ? p.current_limit_a : -p.current_limit_a);
    law.damping_nms = p.viscous_friction_nms;
  } else {
    law.drive_nm = k * voltage_v / p.resistance_ohm;
    law.damping_nms = k * k / p.resistance_ohm + p.viscous_friction_nms;
  }
  return law;
}

double steady_speed_radps(const MotorParams& p, double voltage_v, double load_nm) {
  const double k = p.torque_constant_nm_per_a;
  const double drive = k * std::fabs(voltage_v) / p.resistance_ohm;
  if (drive <= p.coulomb_friction_nm + load_nm) return 0.0;
  const double speed = (drive - p.coulomb_friction_nm - load_nm) / (k * k / p.resistance_ohm + p.viscous_friction_nms);
  return voltage_v >= 0 ? speed : -speed;
}

}  // namespace cart2d
