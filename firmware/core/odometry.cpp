#include "odometry.hpp"

#include "num.hpp"            // kTwoPi, normalize_angle, sinf, cosf, fabsf
#include "robot_params.hpp"  // params::traction

namespace core {

OdometryScale::OdometryScale(const WheelGeometry& g, float h_s) {
  const float rad_per_count = kTwoPi / g.counts_per_rev;
  m_per_count_left = rad_per_count * g.radius_left_m;
  m_per_count_right = rad_per_count * g.radius_right_m;
  inv_track = 1.0f / g.track_m;
  inv_h = 1.0f / h_s;
  traction_ratio = params::traction::track_m * inv_track;
}

void Odometry::set_pose(const Pose& pose) {
  pose_ = pose;
  resync_heading();
}

void Odometry::resync_heading() {
  cos_theta_ = cosf(pose_.theta_rad);
  sin_theta_ = sinf(pose_.theta_rad);
  steps_since_resync_ = 0;
}

// Beyond this half-step rotation the series below is not used (0.05 rad in 4 ms is 12 rad/s).
constexpr float kSmallAngle_rad = 0.05f;
// cos/sin are re-derived from the (exactly integrated) heading at the first tick standing still,
// and at least every kResyncSteps moving steps: sinf/cosf cost ~10 000 cycles each on the AVR
// (measured in simavr), so not in every tick.
constexpr uint8_t kResyncSteps = 250;

// Rotates (c, s) by a small angle a with cos a ~ 1 - a^2/2, sin a ~ a: the rotation is a + a^3/6
// (3.3e-7 rad per step at pi rad/s, 1.7e-4 at the 0.1 rad limit), and it does not add up for
// long: cos/sin are re-derived from the exactly integrated heading (see kResyncSteps).
__attribute__((noinline)) static void rotate_small(float& c, float& s, float a) {
  const float ca = 1.0f - 0.5f * a * a;
  const float c_new = c * ca - s * a;
  s = s * ca + c * a;
  c = c_new;
}

// The seed's six steps: wheel arcs, body arc and rotation, then midpoint integration, i.e.
// the heading used for the displacement is theta + dtheta/2 (exact for constant-curvature arcs
// to second order).
void Odometry::update(int16_t counts_left, int16_t counts_right, const OdometryScale& k) {
  const float ds_left_m = counts_left * k.m_per_count_left;
  const float ds_right_m = counts_right * k.m_per_count_right;
  const float ds_m = 0.5f * (ds_left_m + ds_right_m);
  const float dtheta_rad = (ds_right_m - ds_left_m) * k.inv_track;

  v_left_mps_ = ds_left_m * k.inv_h;
  v_right_mps_ = ds_right_m * k.inv_h;
  v_mps_ = ds_m * k.inv_h;
  omega_radps_ = dtheta_rad * k.inv_h;

  if (counts_left == 0 && counts_right == 0) {  // standing still: time to spare
    if (steps_since_resync_ != 0) resync_heading();
    return;
  }
  const float half_rad = 0.5f * dtheta_rad;
  pose_.theta_rad = normalize_angle(pose_.theta_rad + dtheta_rad);
  if (fabsf(half_rad) > kSmallAngle_rad || ++steps_since_resync_ >= kResyncSteps) {
    const float mid_rad = pose_.theta_rad - half_rad;
    pose_.x_m += ds_m * cosf(mid_rad);
    pose_.y_m += ds_m * sinf(mid_rad);
    resync_heading();
    return;
  }
  // The midpoint heading's direction is the mean of the old and new unit vectors (shorter by
  // cos(dtheta/2): 1 - 2e-5 at pi rad/s, less than the midpoint rule's own error against the
  // exact arc), which saves a second rotation.
  const float cos_old = cos_theta_;
  const float sin_old = sin_theta_;
  rotate_small(cos_theta_, sin_theta_, dtheta_rad);
  const float half_ds_m = 0.5f * ds_m;
  pose_.x_m += half_ds_m * (cos_old + cos_theta_);
  pose_.y_m += half_ds_m * (sin_old + sin_theta_);
}

}  // namespace core
