// Wheel-speed control: (v, omega) -> (v_left, v_right) and one PI per wheel.
#pragma once

#include <stdint.h>

#include "pi_controller.hpp"

namespace core {

struct WheelSpeeds {
  float left_mps = 0.0f;
  float right_mps = 0.0f;
};

struct SpeedGains {
  PiGains pi;
  float kff;  // PWM per m/s of target: the open-loop part
};

struct MotorCommand {
  int16_t left = 0;   // signed PWM in [-pwm_max, pwm_max]; positive drives forwards
  int16_t right = 0;
};

// v_l = v - omega B/2, v_r = v + omega B/2, with B the track of the wheels that MEASURE the
// speeds the PIs regulate (the encoder wheels).
inline WheelSpeeds wheel_speeds(float v_mps, float omega_radps, float track_m) {
  WheelSpeeds w;
  w.left_mps = v_mps - 0.5f * omega_radps * track_m;
  w.right_mps = v_mps + 0.5f * omega_radps * track_m;
  return w;
}

class SpeedController {
 public:
  MotorCommand update(const WheelSpeeds& target, const WheelSpeeds& measured, const SpeedGains& gains,
                      float h_s, float pwm_max);
  void reset();

 private:
  PiController left_;
  PiController right_;
};

}  // namespace core
