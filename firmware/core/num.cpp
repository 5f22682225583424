#include "num.hpp"

namespace core {

float normalize_angle(float a_rad) {
  // Whole turns first, so that a huge (but finite) angle does not loop for long. fmodf is exact;
  // a - 2 pi * floor(a / 2 pi) is not, and at 1e38 subtracting 2 pi no longer changes a at all.
  if (a_rad > 3.0f * kPi || a_rad < -3.0f * kPi) a_rad = fmodf(a_rad, kTwoPi);
  while (a_rad > kPi) a_rad -= kTwoPi;
  while (a_rad < -kPi) a_rad += kTwoPi;
  return a_rad;
}

}  // namespace core
