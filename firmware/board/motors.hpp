// Two LMD18200 H-bridges: PWM on OC1A/OC1B from Timer1, direction on two GPIOs.
#pragma once

#include "cart.hpp"  // core::MotorOutput

namespace board {
namespace motors {

// Outputs off, Timer1 in mode 8 (phase- and frequency-correct, TOP = ICR1) at 50 kHz.
void init();
// Apply a command: disabled means the PWM pins are plain low outputs; enabled with a zero
// command means 0 % duty with the outputs still connected (a zero must not disable control).
void apply(const core::MotorOutput& out);

}  // namespace motors
}  // namespace board
