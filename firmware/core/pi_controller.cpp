#include "pi_controller.hpp"

#include "num.hpp"  // clamp, is_finite

namespace core {

float PiController::update(float error, const PiGains& gains, float h_s, float limit, float feedforward) {
  if (!is_finite(error)) error = 0.0f;
  const float proportional = feedforward + gains.kp * error;
  const float candidate = integrator_ + gains.ki * error * h_s;
  const float unclamped = proportional + candidate;
  // Anti-windup by conditional integration: accept the new integrator unless the output is
  // saturated and integrating would push it further into saturation (ki >= 0, so the
  // integrator moves with the sign of the error).
  const bool pushing_high = unclamped > limit && error > 0.0f;
  const bool pushing_low = unclamped < -limit && error < 0.0f;
  if (!pushing_high && !pushing_low) integrator_ = clamp(candidate, -limit, limit);
  return clamp(proportional + integrator_, -limit, limit);
}

}  // namespace core
