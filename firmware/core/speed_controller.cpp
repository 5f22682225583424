#include "speed_controller.hpp"

namespace core {

static int16_t round_pwm(float pwm) { return static_cast<int16_t>(pwm < 0.0f ? pwm - 0.5f : pwm + 0.5f); }

// Feedforward gives most of the PWM at once, so the measured speed follows the (acceleration
// limited) reference closely and braking for a corner happens where it was planned; the PI
// only corrects what the open-loop guess gets wrong.
MotorCommand SpeedController::update(const WheelSpeeds& target, const WheelSpeeds& measured,
                                     const WheelSpeeds& feedforward, const SpeedGains& gains, float h_s,
                                     float pwm_max) {
  MotorCommand out;
  out.left = round_pwm(left_.update(target.left_mps - measured.left_mps, gains.pi, h_s, pwm_max,
                                    gains.kff * feedforward.left_mps));
  out.right = round_pwm(right_.update(target.right_mps - measured.right_mps, gains.pi, h_s, pwm_max,
                                      gains.kff * feedforward.right_mps));
  return out;
}

void SpeedController::reset() {
  left_.reset();
  right_.reset();
}

}  // namespace core
