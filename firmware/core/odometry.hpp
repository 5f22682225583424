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

class Odometry {
 public:
  // Integrate one sampling period of h_s seconds with the counts seen in it.
  void update(int16_t counts_left, int16_t counts_right, const WheelGeometry& geometry, float h_s);

  const Pose& pose() const { return pose_; }
  void set_pose(const Pose& pose) { pose_ = pose; }

  float v_left_mps() const { return v_left_mps_; }
  float v_right_mps() const { return v_right_mps_; }
  float v_mps() const { return v_mps_; }
  float omega_radps() const { return omega_radps_; }

 private:
  Pose pose_;
  float v_left_mps_ = 0.0f;
  float v_right_mps_ = 0.0f;
  float v_mps_ = 0.0f;
  float omega_radps_ = 0.0f;
};

}  // namespace core
