// Dead reckoning from the two measuring-wheel encoders (the seed's RI32::evaluate).
#pragma once

#include <stdint.h>

namespace core {

struct Pose {
  float x_m = 0.0f;
  float y_m = 0.0f;
  float theta_rad = 0.0f;
};

// Measuring-wheel geometry; radii and track may come from a UMBmark calibration.
struct WheelGeometry {
  float radius_left_m;
  float radius_right_m;
  float track_m;
  float counts_per_rev;  // encoder counts per wheel revolution (pulses x edges counted)
};

// The geometry turned into factors, once per change: a float division costs ~500 cycles on
// the AVR, and the 125 Hz loop needs none of them.
struct OdometryScale {
  OdometryScale() = default;
  OdometryScale(const WheelGeometry& geometry, float h_s);
  float m_per_count_left = 0.0f;
  float m_per_count_right = 0.0f;
  float inv_track = 0.0f;  // 1/m
  float inv_h = 0.0f;      // 1/s
  float traction_ratio = 0.0f;  // traction track / measuring track (speed_controller.hpp)
};

class Odometry {
 public:
  // Integrate one sampling period with the counts seen in it.
  void update(int16_t counts_left, int16_t counts_right, const OdometryScale& scale);
  void update(int16_t counts_left, int16_t counts_right, const WheelGeometry& geometry, float h_s) {
    update(counts_left, counts_right, OdometryScale(geometry, h_s));
  }

  const Pose& pose() const { return pose_; }
  void set_pose(const Pose& pose);
  // cos and sin of the current heading, kept up to date without trigonometry in most steps.
  float cos_theta() const { return cos_theta_; }
  float sin_theta() const { return sin_theta_; }

  float v_left_mps() const { return v_left_mps_; }
  float v_right_mps() const { return v_right_mps_; }
  float v_mps() const { return v_mps_; }
  float omega_radps() const { return omega_radps_; }

 private:
  void resync_heading();

  Pose pose_;
  float cos_theta_ = 1.0f;
  float sin_theta_ = 0.0f;
  uint8_t steps_since_resync_ = 0;
  float v_left_mps_ = 0.0f;
  float v_right_mps_ = 0.0f;
  float v_mps_ = 0.0f;
  float omega_radps_ = 0.0f;
};

}  // namespace core
