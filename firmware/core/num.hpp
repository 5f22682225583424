// Small numeric helpers shared by the control code. No AVR or Arduino includes (core/ rule).
#pragma once

#include <math.h>    // sinf, cosf, atan2f, sqrtf
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

// True when f is finite and |f| < 2^20 (1 048 576): every number the protocol carries. Squares
// of such values stay far inside the float range. Looks at the exponent bits only.
inline bool is_moderate(float f) {
  uint32_t bits;
  memcpy(&bits, &f, sizeof bits);
  return ((bits >> 23) & 0xFF) < 127 + 20;
}

// atan2(y, x) for x >= 0, within 2e-5 rad: Abramowitz & Stegun 4.4.49 (a polynomial in z^2
// on |z| <= 1, error 1e-5) after one division; cheaper on the AVR than avr-libc's atan2.
float atan2_right_half(float y, float x);

// Wrap an angle into [-pi, pi]. (The seed's normalize stepped by pi; the period is 2 pi.)
// The angle must be within kMaxAngle_rad.
constexpr float kMaxAngle_rad = 100.0f;
float normalize_angle(float a_rad);

inline float clamp(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

inline float sign(float v) { return v < 0.0f ? -1.0f : 1.0f; }

// Move `current` towards `target` by at most `max_step`: the acceleration limiter.
inline float step_toward(float current, float target, float max_step) {
  return clamp(target, current - max_step, current + max_step);
}

}  // namespace core
