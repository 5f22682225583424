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

// The traction wheels' surface speeds that give the same (v, omega) as the measuring-wheel
// speeds `measuring`: the same v, the turning part scaled by traction track / measuring track.
// The motors drive the traction wheels, so the open-loop guess must be theirs: with the
// measuring wheels' speeds it was 0.305 / 0.182 = 1.68 x too high for any turn, and a turn on the
// spot at 3.0 rad/s overshot to 3.62 rad/s.
inline WheelSpeeds traction_speeds(const WheelSpeeds& measuring, float track_ratio) {
  const float v = 0.5f * (measuring.left_mps + measuring.right_mps);
  const float half_turn = 0.5f * (measuring.right_mps - measuring.left_mps) * track_ratio;
  WheelSpeeds w;
  w.left_mps = v - half_turn;
  w.right_mps = v + half_turn;
  return w;
}

class SpeedController {
 public:
  // One step of both PIs on the measuring-wheel speeds, plus gains.kff times the traction-wheel
  // speeds `feedforward` the targets need (traction_speeds()).
  MotorCommand update(const WheelSpeeds& target, const WheelSpeeds& measured, const WheelSpeeds& feedforward,
                      const SpeedGains& gains, float h_s, float pwm_max);
  void reset();

 private:
  PiController left_;
  PiController right_;
};

}  // namespace core
