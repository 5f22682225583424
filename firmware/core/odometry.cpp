#include "odometry.hpp"

#include "num.hpp"  // kTwoPi, normalize_angle, sinf, cosf

namespace core {

// The seed's six steps: wheel arcs, body arc and rotation, then midpoint integration, i.e.
// the heading used for the displacement is theta + dtheta/2 (exact for constant-curvature arcs
// to second order).
void Odometry::update(int16_t counts_left, int16_t counts_right, const WheelGeometry& g, float h_s) {
  const float rad_per_count = kTwoPi / g.counts_per_rev;
  const float ds_left_m = counts_left * rad_per_count * g.radius_left_m;
  const float ds_right_m = counts_right * rad_per_count * g.radius_right_m;
  const float ds_m = 0.5f * (ds_left_m + ds_right_m);
  const float dtheta_rad = (ds_right_m - ds_left_m) / g.track_m;

  v_left_mps_ = ds_left_m / h_s;
  v_right_mps_ = ds_right_m / h_s;
  v_mps_ = ds_m / h_s;
  omega_radps_ = dtheta_rad / h_s;

  if (counts_left == 0 && counts_right == 0) return;  // standing still: skip the trigonometry
  const float heading_rad = pose_.theta_rad + 0.5f * dtheta_rad;
  pose_.x_m += ds_m * cosf(heading_rad);
  pose_.y_m += ds_m * sinf(heading_rad);
  pose_.theta_rad = normalize_angle(pose_.theta_rad + dtheta_rad);
}

}  // namespace core
