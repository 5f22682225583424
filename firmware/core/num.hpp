// Small numeric helpers shared by the control code. No AVR or Arduino includes (core/ rule).
#pragma once

#include <math.h>    // sinf, cosf, atan2f, sqrtf, fmodf
#include <stdint.h>  // uint32_t
#include <string.h>  // memcpy

namespace core {

constexpr float kPi = 3.14159265f;
constexpr float kTwoPi = 6.28318531f;

// True unless f is NaN or ±Inf. Looks at the exponent bits so that it works the same with
// avr-libc and glibc and cannot be optimised away.
inline bool is_finite(float f) {
  uint32_t bits;
  memcpy(&bits, &f, sizeof bits);
  return (bits & 0x7F800000u) != 0x7F800000u;
}

// Wrap an angle into [-pi, pi]. (The seed's normalize stepped by pi; the period is 2 pi.)
float normalize_angle(float a_rad);

inline float clamp(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

inline float sign(float v) { return v < 0.0f ? -1.0f : 1.0f; }

// Move `current` towards `target` by at most `max_step`: the acceleration limiter.
inline float step_toward(float current, float target, float max_step) {
  return clamp(target, current - max_step, current + max_step);
}

}  // namespace core
