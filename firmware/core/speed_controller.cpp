#include "speed_controller.hpp"

namespace core {

static int16_t round_pwm(float pwm) { return static_cast<int16_t>(pwm < 0.0f ? pwm - 0.5f : pwm + 0.5f); }

MotorCommand SpeedController::update(const WheelSpeeds& target, const WheelSpeeds& measured,
                                     const PiGains& gains, float h_s, float pwm_max) {
  MotorCommand out;
  out.left = round_pwm(left_.update(target.left_mps - measured.left_mps, gains, h_s, pwm_max));
  out.right = round_pwm(right_.update(target.right_mps - measured.right_mps, gains, h_s, pwm_max));
  return out;
}

void SpeedController::reset() {
  left_.reset();
  right_.reset();
}

}  // namespace core
