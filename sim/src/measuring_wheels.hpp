// The two encoder (measuring) wheels: unpowered wheels on the traction axis, ±track/2 from the
// centre, that roll with the body. Over one step with constant (v, ω) each contact point moves
// s = (v ∓ ω·track/2)·h along the heading (the seed's odometry eqs. 1-5, inverted), and the wheel
// turns s/r. Faults change the real radius, track and slip, which the firmware does not know.
#pragma once

#include "body.hpp"    // Twist
#include "faults.hpp"        // Faults
#include "robot_params.hpp"  // params::encoders

namespace cart2d {

// Defaults: the robot's nominal wheels (config/robot.toml).
struct MeasuringWheelParams {
  double radius_m = params::encoders::radius_m;
  double track_m = params::encoders::track_m;
};

struct WheelAdvance {
  double dist_l_m = 0.0, dist_r_m = 0.0;    // rolled distance of each contact point
  double angle_l_rad = 0.0, angle_r_rad = 0.0;  // how far each wheel turns (what its encoder sees)
};

WheelAdvance advance_measuring_wheels(const MeasuringWheelParams& p, const Faults& f, const Twist& twist, double h_s);

}  // namespace cart2d
