// The seed's polar position controller, extended so that a path is driven at speed: towards an
// intermediate waypoint the speed is only capped so that the cart can brake to the corner's
// exit speed in time (with the acceleration limit); the seed's P law on the distance is kept
// for the final waypoint, where the cart must stop.
#pragma once

#include <math.h>  // fabsf

#include "odometry.hpp"  // Pose

namespace core {

struct PolarGains {
  float rho_kp;    // 1/s: v = rho_kp * distance
  float phase_kp;  // 1/s: omega = phase_kp * heading error
  // false: a waypoint behind is not driven to backwards (the seed's reverse case); the cart
  // turns on the spot to face it, then drives forwards. A forward-looking camera sees only
  // where the cart goes forwards (setting reverse_allowed, config/robot.toml).
  bool reverse_allowed = true;
};

struct MotionLimits {
  float v_max_mps;
  float w_max_radps;
  float a_max_mps2;
  // v_max^2 / (2 * kBrakingShare * a_max): with at least this much of the path received beyond
  // the waypoint, where it ends cannot limit the speed (and the controller skips that cap).
  float stop_horizon_m = 1e30f;
};

// What the path tells the controller about the waypoint being approached.
struct Approach {
  float x_m;
  float y_m;
  float exit_speed_mps;    // speed at which the cart may pass it (0 for the last one)
  bool final;              // the last waypoint: stop on it
  // Unit direction of the segment that leads to the waypoint; zero when there is none (then
  // the cart steers straight for the waypoint, as the seed did).
  float dir_x = 0.0f;
  float dir_y = 0.0f;
  // Length of the path received beyond the waypoint: the cart must be able to stop where the
  // received points end (0 when the waypoint is the last received).
  float beyond_m = 0.0f;
};

// The braking the speed caps plan for, as a share of a_max: the wheels lag a reference that
// brakes at the full limit, and the cart overshot its goal by 14 mm (at 0.8 by less than 1 mm,
// and it stops sooner: a 4 m run took 8.5 s instead of 8.8 s).
constexpr float kBrakingShare = 0.8f;

// The cart steers for the point this far ahead of its projection on the segment (never past
// the waypoint), so it drives the planned line back after any disturbance instead of heading
// for the waypoint on a parallel line; 0.15 m at kp = 4 1/s and 0.5 m/s damps with zeta ~0.55.
constexpr float kLookahead_m = 0.15f;

struct PolarOutput {
  float v_mps;
  float omega_radps;
  float rho_m;             // signed distance to the waypoint (negative: it is behind)
  bool behind;             // the waypoint is behind the cart (it drives backwards, if allowed)
  // The cart has fewer points ahead than it needs to brake from v_max: the target is final (the
  // path's last, or the last received), or the received points end within that distance.
  bool stopping;
};

// The speed factor of a heading error e, given the target's coordinates along and across the
// heading: 1 - |tan e|, so 1 when aligned and 0 from 45 deg on (the cart turns on the spot
// first, so it drives the planner's straight segments instead of arcs that can reach a wall or
// an obstacle). Written without a square root or an angle: the 8-bit MCU pays for each.
inline float heading_speed_factor(float along, float cross) {
  if (!(along > 0.0f)) return 0.0f;
  const float f = 1.0f - fabsf(cross) / along;
  return f > 0.0f ? f : 0.0f;
}

// Within this distance of the FINAL waypoint the bearing is too noisy to steer by: stop
// turning and only close the distance along the current heading (while the waypoint is within
// 45 deg of the heading line; further off to the side the cart must still turn towards it).
constexpr float kFinalApproachRadius_m = 0.02f;

// cos and sin of pose.theta_rad (the odometry keeps them: no trigonometry needed here).
struct Heading {
  float cos_theta;
  float sin_theta;
};

PolarOutput polar_control(const Pose& pose, const Heading& heading, const Approach& target,
                          const PolarGains& gains, const MotionLimits& limits);
// The same, computing the heading's cos and sin itself.
PolarOutput polar_control(const Pose& pose, const Approach& target, const PolarGains& gains,
                          const MotionLimits& limits);

}  // namespace core
