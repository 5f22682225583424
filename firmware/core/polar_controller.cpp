#include "polar_controller.hpp"

#include "num.hpp"  // normalize_angle, clamp, sign, kPi, trig

namespace core {

// min(v_max, the largest speed from which the cart can still slow to exit_speed within
// distance_m, braking at kBrakingShare of a_max). Cruising, the cap is above v_max: compared
// squared, it needs no square root.
static float speed_from_reach(float reach_sq, const MotionLimits& limits) {
  return reach_sq >= limits.v_max_mps * limits.v_max_mps ? limits.v_max_mps : sqrtf(reach_sq);
}

static float capped_speed(float distance_m, float exit_speed_mps, const MotionLimits& limits) {
  return speed_from_reach(
      exit_speed_mps * exit_speed_mps + (2.0f * kBrakingShare) * limits.a_max_mps2 * distance_m, limits);
}

// The aim point in the cart's frame: `along` ahead (negative: behind), `cross` to the left. The
// seed's angle arithmetic becomes: heading error = atan2(cross, along), folded by pi when the
// aim is behind (then the cart drives backwards). With reverse not allowed the aim behind is
// steered for by its true heading error instead (over 90 deg: the speed factor is 0, the cart
// turns on the spot). Speeds follow the distance to the waypoint itself.
PolarOutput polar_control(const Pose& pose, const Heading& heading, const Approach& target,
                          const PolarGains& gains, const MotionLimits& limits) {
  const float dx = target.x_m - pose.x_m;
  const float dy = target.y_m - pose.y_m;
  const float distance_m = sqrtf(dx * dx + dy * dy);
  // The aim: the waypoint, or the look-ahead point when the waypoint lies beyond it.
  float aim_x = dx, aim_y = dy;
  const float beyond_m = dx * target.dir_x + dy * target.dir_y - kLookahead_m;
  if (beyond_m > 0.0f) {
    aim_x -= beyond_m * target.dir_x;
    aim_y -= beyond_m * target.dir_y;
  }
  const float along_m = aim_x * heading.cos_theta + aim_y * heading.sin_theta;
  const float cross_m = aim_y * heading.cos_theta - aim_x * heading.sin_theta;

  PolarOutput out;
  out.behind = along_m < 0.0f;  // |heading error| > pi/2: the seed's reverse case
  const float side = out.behind ? -1.0f : 1.0f;
  const bool backwards = out.behind && gains.reverse_allowed;
  const float direction = backwards ? -1.0f : 1.0f;  // of travel
  out.rho_m = side * distance_m;
  out.stopping = target.final;

  // Only while the waypoint lies within 45 deg of the heading line (ahead or behind, i.e.
  // |cross-track| <= |along-track|): from further off to the side, closing along the heading
  // would stop the cart abeam of the waypoint, outside the tolerance, for ever. There it steers
  // as usual and turns towards the waypoint first. Even with reverse not allowed the cart
  // closes these last 2 cm backwards when it overshot: it has just driven over them, and
  // turning round for them would take seconds.
  if (target.final && distance_m < kFinalApproachRadius_m && fabsf(cross_m) <= fabsf(along_m)) {
    out.v_mps = side * fminf(gains.rho_kp * fabsf(along_m), capped_speed(fabsf(along_m), 0.0f, limits));
    out.omega_radps = 0.0f;
    return out;
  }

  // [-pi/2, pi/2]; [-pi, pi] when an aim behind must be faced (then beyond pi/2 by the angle
  // between the aim and the tail; exactly behind, the cart turns left).
  float heading_error = atan2_right_half(direction * cross_m, fabsf(along_m));
  if (out.behind && !backwards) heading_error = (cross_m < 0.0f ? -kPi : kPi) - heading_error;
  // The fastest the cart may pass the waypoint: its exit speed, and no faster than it can still
  // stop from where the received points end (a streamed path): exit^2 <= 2 * 0.8 a * beyond.
  // Folded into the exit speed, the two caps cost one multiplication more than one; beyond the
  // stop horizon (the usual case, the window full) not even that.
  const float braking_gain = (2.0f * kBrakingShare) * limits.a_max_mps2;
  float exit_sq = target.exit_speed_mps * target.exit_speed_mps;
  const float along_path_sq = braking_gain * distance_m;
  if (!target.final && target.beyond_m < limits.stop_horizon_m) {
    const float stop_exit_sq = braking_gain * target.beyond_m;
    if (stop_exit_sq < exit_sq) exit_sq = stop_exit_sq;
    out.stopping = stop_exit_sq + along_path_sq < limits.v_max_mps * limits.v_max_mps;
  }
  float speed = speed_from_reach(exit_sq + along_path_sq, limits);
  if (target.final) speed = fminf(speed, gains.rho_kp * distance_m);
  // Do not drive off sideways while the heading is still wrong; turn on the spot when far off.
  speed *= heading_speed_factor(direction * along_m, cross_m);
  out.v_mps = direction * speed;
  out.omega_radps = clamp(gains.phase_kp * heading_error, -limits.w_max_radps, limits.w_max_radps);
  return out;
}

PolarOutput polar_control(const Pose& pose, const Approach& target, const PolarGains& gains,
                          const MotionLimits& limits) {
  return polar_control(pose, Heading{cosf(pose.theta_rad), sinf(pose.theta_rad)}, target, gains, limits);
}

}  // namespace core
