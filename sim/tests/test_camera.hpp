// The camera the camera tests look through: the contract's example (robot.toml's today), fixed
// here so that their hand-checked pixels stay right whatever robot.toml says.
#pragma once

#include "camera_model.hpp"

namespace cart2d {

constexpr double kCameraTestPi = 3.14159265358979323846;
constexpr double kCameraTestCpuHz = 16e6;  // the simulated ATmega328P's clock: camera frames in cycles

inline CameraModel test_model() {
  CameraMount m;
  m.x_m = 0.10;
  m.height_m = 0.25;
  m.pitch_rad = 25.0 * kCameraTestPi / 180.0;
  return CameraModel(m, CameraIntrinsics::nominal(320, 240, 55.0 * kCameraTestPi / 180.0, -0.12, 0.03));
}

}  // namespace cart2d
