// Numeric helpers: the arctangent approximation against std::atan2, angle wrapping, limiter.
#include <gtest/gtest.h>

#include <cmath>

#include "num.hpp"

namespace {

TEST(AtanApproximation, WithinItsStatedErrorOverTheRightHalfPlane) {
  // Sweep the directions of the right half plane (x >= 0) at two magnitudes.
  double worst = 0.0;
  for (int i = -900; i <= 900; ++i) {
    const double angle = i * (M_PI / 2) / 900.0;
    for (double r : {1e-3, 2.5}) {
      const float y = static_cast<float>(r * std::sin(angle));
      const float x = static_cast<float>(std::fmax(0.0, r * std::cos(angle)));
      worst = std::fmax(worst, std::fabs(core::atan2_right_half(y, x) - std::atan2(y, x)));
    }
  }
  EXPECT_LE(worst, 2e-5);
  EXPECT_GT(worst, 1e-7);  // it is an approximation: this test would notice a silent swap
}

TEST(AtanApproximation, ExactWhereItMattersMost) {
  EXPECT_EQ(0.0f, core::atan2_right_half(0.0f, 1.0f));
  EXPECT_EQ(0.0f, core::atan2_right_half(0.0f, 0.0f));
  EXPECT_NEAR(M_PI / 4, core::atan2_right_half(1.0f, 1.0f), 2e-5);  // the series error at z = 1
  EXPECT_NEAR(M_PI / 2, core::atan2_right_half(1.0f, 0.0f), 1e-6);
  EXPECT_NEAR(-M_PI / 2, core::atan2_right_half(-3.0f, 0.0f), 1e-6);
  // Odd symmetry, and the slope at 0 is 1 (a P gain on it keeps its nominal gain).
  EXPECT_EQ(-core::atan2_right_half(0.3f, 1.0f), core::atan2_right_half(-0.3f, 1.0f));
  EXPECT_NEAR(1e-3, core::atan2_right_half(1e-3f, 1.0f), 2e-7);
}

TEST(NormalizeAngle, WrapsIntoMinusPiPi) {
  struct Case {
    float in, out;
  };
  for (const Case c : {Case{0.0f, 0.0f}, Case{3.5f, 3.5f - 6.2831853f}, Case{-3.5f, -3.5f + 6.2831853f},
                       Case{99.0f, 99.0f - 16 * 6.2831853f}, Case{-99.0f, -99.0f + 16 * 6.2831853f}}) {
    EXPECT_NEAR(c.out, core::normalize_angle(c.in), 1e-4) << c.in;
  }
}

TEST(StepToward, MovesAtMostTheStep) {
  EXPECT_FLOAT_EQ(0.008f, core::step_toward(0.0f, 1.0f, 0.008f));
  EXPECT_FLOAT_EQ(-0.008f, core::step_toward(0.0f, -1.0f, 0.008f));
  EXPECT_FLOAT_EQ(0.5f, core::step_toward(0.495f, 0.5f, 0.008f));
}

TEST(IsModerate, AcceptsProtocolSizedNumbersOnly) {
  EXPECT_TRUE(core::is_moderate(0.0f));
  EXPECT_TRUE(core::is_moderate(-1048575.0f));
  EXPECT_FALSE(core::is_moderate(1048576.0f));
  EXPECT_FALSE(core::is_moderate(INFINITY));
  EXPECT_FALSE(core::is_moderate(NAN));
}

}  // namespace
