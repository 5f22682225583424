#include "measuring_wheels.hpp"

namespace cart2d {

WheelAdvance advance_measuring_wheels(const MeasuringWheelParams& p, const Faults& f, const Twist& twist, double h_s) {
  const double half_track = (p.track_m + f.enc_track_error_m) / 2.0;
  WheelAdvance a;
  a.dist_l_m = (twist.v_mps - twist.omega_radps * half_track) * h_s;
  a.dist_r_m = (twist.v_mps + twist.omega_radps * half_track) * h_s;
  a.angle_l_rad = a.dist_l_m * (1.0 - f.enc_slip_l) / (p.radius_m * f.enc_radius_scale_l);
  a.angle_r_rad = a.dist_r_m * (1.0 - f.enc_slip_r) / (p.radius_m * f.enc_radius_scale_r);
  return a;
}

}  // namespace cart2d
