#include "polar_controller.hpp"

#include "num.hpp"  // normalize_angle, clamp, sign, kPi, trig

namespace core {

// Largest speed from which the cart can still slow to exit_speed within distance_m.
static float braking_speed_cap(float distance_m, float exit_speed_mps, float a_max_mps2) {
  return sqrtf(exit_speed_mps * exit_speed_mps + 2.0f * a_max_mps2 * distance_m);
}

PolarOutput polar_control(const Pose& pose, const Approach& target, const PolarGains& gains,
                          const MotionLimits& limits) {
  const float dx = target.x_m - pose.x_m;
  const float dy = target.y_m - pose.y_m;
  const float distance_m = sqrtf(dx * dx + dy * dy);

  PolarOutput out;
  float heading_error = normalize_angle(atan2f(dy, dx) - pose.theta_rad);
  out.behind = heading_error > 0.5f * kPi || heading_error < -0.5f * kPi;
  // The seed's reverse case: a target behind is approached backwards.
  float direction = 1.0f;
  if (out.behind) {
    direction = -1.0f;
    heading_error = normalize_angle(heading_error + kPi);
  }
  out.rho_m = direction * distance_m;

  // Only while the waypoint lies within 45 deg of the heading line (ahead or behind, i.e.
  // |cross-track| <= |along-track|): from further off to the side, closing along the heading
  // would stop the cart abeam of the waypoint, outside the tolerance, for ever. There it steers
  // as usual and turns towards the waypoint first.
  if (target.final && distance_m < kFinalApproachRadius_m && fabsf(heading_error) <= 0.25f * kPi) {
    // Distance along the heading: positive ahead, negative behind.
    const float along_m = dx * cosf(pose.theta_rad) + dy * sinf(pose.theta_rad);
    const float speed = fminf(gains.rho_kp * fabsf(along_m), braking_speed_cap(fabsf(along_m), 0.0f, limits.a_max_mps2));
    out.v_mps = sign(along_m) * fminf(speed, limits.v_max_mps);
    out.omega_radps = 0.0f;
    return out;
  }

  const float to_go_m = distance_m + target.after_m;
  float speed = fminf(gains.rho_kp * to_go_m, limits.v_max_mps);
  speed = fminf(speed, braking_speed_cap(distance_m, target.exit_speed_mps, limits.a_max_mps2));
  // Do not drive off sideways while the heading is still wrong (cos >= 0 here: |error| <= pi/2).
  speed *= cosf(heading_error);
  out.v_mps = direction * speed;
  out.omega_radps = clamp(gains.phase_kp * heading_error, -limits.w_max_radps, limits.w_max_radps);
  return out;
}

}  // namespace core
