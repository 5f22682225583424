#include "num.hpp"

namespace core {

// atan z for 0 <= z <= 1 as z (a1 + a3 z^2 + ... + a9 z^8); beyond, pi/2 - atan(1/z).
float atan2_right_half(float y, float x) {
  const float ay = fabsf(y);
  if (ay == 0.0f) return 0.0f;
  const bool steep = ay > x;
  const float z = steep ? x / ay : ay / x;
  const float z2 = z * z;
  float a = z * (0.9998660f + z2 * (-0.3302995f + z2 * (0.1801410f + z2 * (-0.0851330f + z2 * 0.0208351f))));
  if (steep) a = 0.5f * kPi - a;
  return y < 0.0f ? -a : a;
}

float normalize_angle(float a_rad) {
  // Callers pass angles within kMaxAngle_rad (the dispatcher refuses larger ones): at most
  // 16 turns to remove. (Far larger angles would need fmodf: at 1e38, subtracting 2 pi no
  // longer changes the value at all.)
  while (a_rad > kPi) a_rad -= kTwoPi;
  while (a_rad < -kPi) a_rad += kTwoPi;
  return a_rad;
}

}  // namespace core
