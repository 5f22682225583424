// A PI controller with output saturation and anti-windup (the shape of ArduPilot's AC_PID:
// finite-input guard, an integrator that may only shrink while the output is saturated).
#pragma once

namespace core {

struct PiGains {
  float kp;
  float ki;
};

class PiController {
 public:
  // One step of h_s seconds on `error`; the result (feedforward included) is clamped to
  // [-limit, limit], and the integrator does not wind up against that clamp.
  float update(float error, const PiGains& gains, float h_s, float limit, float feedforward = 0.0f);
  void reset() { integrator_ = 0.0f; }
  float integrator() const { return integrator_; }

 private:
  float integrator_ = 0.0f;  // already multiplied by ki: output units
};

}  // namespace core
