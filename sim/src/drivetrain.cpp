#include "drivetrain.hpp"

#include <algorithm>  // std::clamp, std::min, std::max
#include <cmath>      // std::fabs

namespace cart2d {

double motor_speed_after(const MotorStep& m, double radius_m, double impulse_ns) {
  const double p = m.momentum_nms - radius_m * impulse_ns;
  if (p > m.friction_impulse_nms) return (p - m.friction_impulse_nms) / m.inertia_kgm2;
  if (p < -m.friction_impulse_nms) return (p + m.friction_impulse_nms) / m.inertia_kgm2;
  return 0.0;  // the gearbox's dry friction holds the motor
}

// w(λ) = base + a·λ − r·ω₁(λ) increases with λ and is linear between the two impulses at which
// the motor's net momentum reaches ±h·τc. Returns the λ where it equals target.
static double impulse_for_rate(const DriveRow& row, double base_mps, double target_mps) {
  const double r = row.radius_m, a = row.body_compliance;
  const double lo = (row.motor.momentum_nms - row.motor.friction_impulse_nms) / r;  // motor stuck from here...
  const double hi = (row.motor.momentum_nms + row.motor.friction_impulse_nms) / r;  // ...to here
  const double f_lo = base_mps + a * lo - target_mps;  // the motor is still at both ends
  const double f_hi = base_mps + a * hi - target_mps;
  const double slope_turning = a + r * r / row.motor.inertia_kgm2;
  if (f_lo >= 0.0) return lo - f_lo / slope_turning;
  if (f_hi <= 0.0) return hi - f_hi / slope_turning;
  return (target_mps - base_mps) / a;  // motor held still: only the body moves
}

double solve_drive_row(const DriveRow& row, double contact_mps, double current_ns) {
  const double base = contact_mps - row.body_compliance * current_ns;  // contact speed without this row
  const double w_open = base - row.radius_m * motor_speed_after(row.motor, row.radius_m, 0.0);
  if (w_open < -row.gap_fwd_mps)
    return std::min(impulse_for_rate(row, base, -row.gap_fwd_mps), row.max_impulse_ns);
  if (w_open > row.gap_back_mps)
    return std::max(impulse_for_rate(row, base, row.gap_back_mps), -row.max_impulse_ns);
  return 0.0;  // inside the backlash: the motor turns without driving the wheel
}

DriveOutcome drive_outcome(const DriveRow& row, double contact_mps, double impulse_ns, double gap_rad,
                           double backlash_rad, double h_s) {
  DriveOutcome out;
  const double r = row.radius_m;
  out.motor_radps = motor_speed_after(row.motor, r, impulse_ns);
  const bool sliding = std::fabs(impulse_ns) >= row.max_impulse_ns * (1.0 - 1e-12) && row.max_impulse_ns > 0.0;
  if (impulse_ns == 0.0) {
    // Gap open: the unloaded wheel rolls with the floor; the motor moves inside the backlash.
    out.wheel_radps = contact_mps / r;
    out.gap_rad = std::clamp(gap_rad + h_s * (out.motor_radps - out.wheel_radps), -backlash_rad / 2, backlash_rad / 2);
    return out;
  }
  out.gap_rad = impulse_ns > 0.0 ? backlash_rad / 2 : -backlash_rad / 2;
  out.wheel_radps = sliding ? out.motor_radps : contact_mps / r;
  out.slip_mps = sliding ? r * out.motor_radps - contact_mps : 0.0;
  return out;
}

}  // namespace cart2d
