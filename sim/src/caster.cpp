#include "caster.hpp"

#include <algorithm>  // std::clamp, std::min, std::max
#include <cmath>      // std::cos, std::sin

namespace cart2d {

CasterJacobians caster_jacobians(const CasterParams& p, double angle_rad) {
  return caster_jacobians(p, std::cos(angle_rad), std::sin(angle_rad));
}

CasterJacobians caster_jacobians(const CasterParams& p, double c, double s) {
  // V_r = V_S·e_c = v·cos φ + ω·x_S·sin φ;  e = V_S·n_c − t·ω = −v·sin φ + ω·(x_S·cos φ − t).
  return CasterJacobians{c, p.swivel_x_m * s, -s, p.swivel_x_m * c - p.trail_m};
}

double caster_contact_x_m(const CasterParams& p, double angle_rad) {
  return caster_contact_x_m(p, std::cos(angle_rad), std::sin(angle_rad));
}

double caster_contact_y_m(const CasterParams& p, double angle_rad) {
  return caster_contact_y_m(p, std::cos(angle_rad), std::sin(angle_rad));
}

double caster_contact_x_m(const CasterParams& p, double c, double) { return p.swivel_x_m - p.trail_m * c; }

double caster_contact_y_m(const CasterParams& p, double, double s) { return -p.trail_m * s; }

double caster_rolling_limit_n(const CasterParams& p, double load_n) { return p.rolling_resistance * load_n; }

double caster_side_limit_n(const CasterParams& p, double load_n) {
  return std::min(p.swivel_friction_arm_m / p.trail_m, p.lateral_friction) * load_n;
}

double caster_swivel_rate_radps(const CasterParams& p, double side_speed_mps) {
  const bool swivel_turns = p.swivel_friction_arm_m / p.trail_m <= p.lateral_friction;
  return swivel_turns ? side_speed_mps / p.trail_m : 0.0;
}

SupportLoads support_loads(double weight_n, double com_x_m, double track_m, double caster_x_m, double caster_y_m) {
  SupportLoads n;
  // Moments about the axle (the line through both tyre contacts): N_c·x_P = W·x_com.
  n.caster_n = std::clamp(weight_n * com_x_m / caster_x_m, 0.0, weight_n);
  // Vertical forces and moments about the centre line: N_L + N_R = W − N_c, (N_L − N_R)·B/2 = −N_c·y_P.
  const double shared = (weight_n - n.caster_n) / 2.0, shift = n.caster_n * caster_y_m / track_m;
  n.left_n = std::max(shared - shift, 0.0);
  n.right_n = std::max(shared + shift, 0.0);
  return n;
}

}  // namespace cart2d
