// The wheel-speed PI (core/pi_controller): proportional and integral action, saturation,
// anti-windup, non-finite input, reset.
//
// Units as in the firmware: error in m/s, output in PWM counts, gains kp [PWM/(m/s)] and
// ki [PWM/m], h = 8 ms, limit = pwm_max = 1000. The integrator term grows by ki * e * h per step.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "pi_controller.hpp"

namespace {

constexpr float kH = 0.008f;
constexpr float kLimit = 1000.0f;
const core::PiGains kSeedGains{1000.0f, 3000.0f};  // the seed's speed PI

TEST(PiController, ProportionalOnlyIsKpTimesError) {
  const core::PiGains p_only{1000.0f, 0.0f};
  // 1000 PWM/(m/s) * e: 0.2 -> 200, -0.35 -> -350, 0 -> 0.
  for (const float e : {0.2f, -0.35f, 0.0f, 0.999f}) {
    core::PiController pi;
    EXPECT_NEAR(pi.update(e, p_only, kH, kLimit), 1000.0f * e, 1e-3f) << e;
    // Without ki the output does not grow with time.
    EXPECT_NEAR(pi.update(e, p_only, kH, kLimit), 1000.0f * e, 1e-3f) << e;
  }
}

TEST(PiController, IntegralAccumulatesKiTimesErrorTimesH) {
  // ki = 3000, e = 0.1, h = 0.008: 3000 * 0.1 * 0.008 = 2.4 PWM per step; step k gives 2.4 k.
  const core::PiGains i_only{0.0f, 3000.0f};
  core::PiController pi;
  for (int k = 1; k <= 10; ++k) EXPECT_NEAR(pi.update(0.1f, i_only, kH, kLimit), 2.4f * k, 1e-3f) << k;
  EXPECT_NEAR(pi.integrator(), 24.0f, 1e-3f);
  // A zero error holds the integral (the output a steady load needs), it does not decay.
  EXPECT_NEAR(pi.update(0.0f, i_only, kH, kLimit), 24.0f, 1e-3f);
  // A negative error integrates back down: 24 - 2.4 * 5 = 12.
  float out = 0.0f;
  for (int k = 0; k < 5; ++k) out = pi.update(-0.1f, i_only, kH, kLimit);
  EXPECT_NEAR(out, 12.0f, 1e-3f);
}

TEST(PiController, ProportionalPlusIntegralOnTheFirstStep) {
  // e = 0.05: P = 1000 * 0.05 = 50, I = 3000 * 0.05 * 0.008 = 1.2 -> 51.2; second step 52.4.
  core::PiController pi;
  EXPECT_NEAR(pi.update(0.05f, kSeedGains, kH, kLimit), 51.2f, 1e-3f);
  EXPECT_NEAR(pi.update(0.05f, kSeedGains, kH, kLimit), 52.4f, 1e-3f);
}

TEST(PiController, OutputSaturatesAtTheLimit) {
  struct Case {
    float error;
    float expected;
  };
  // P alone is 1000 * e: 5 m/s -> 5000, clamped to 1000; exactly at 1 m/s the first step is
  // 1000 + 24 -> clamped too.
  for (const Case c : {Case{5.0f, kLimit}, Case{-5.0f, -kLimit}, Case{1.0f, kLimit}, Case{-1e6f, -kLimit}}) {
    core::PiController pi;
    for (int k = 0; k < 50; ++k) EXPECT_EQ(pi.update(c.error, kSeedGains, kH, kLimit), c.expected) << c.error;
  }
}

TEST(PiController, IntegratorNeverExceedsTheLimit) {
  // Pure integrator on a huge error: without a bound it would reach 3000 * 10 * 0.008 * 1000 =
  // 240000 after 1000 steps.
  const core::PiGains i_only{0.0f, 3000.0f};
  core::PiController pi;
  for (int k = 0; k < 1000; ++k) {
    const float out = pi.update(10.0f, i_only, kH, kLimit);
    ASSERT_LE(out, kLimit);
    ASSERT_LE(pi.integrator(), kLimit);
  }
  for (int k = 0; k < 1000; ++k) {
    pi.update(-10.0f, i_only, kH, kLimit);
    ASSERT_GE(pi.integrator(), -kLimit);
  }
}

TEST(PiController, SaturatedByALargeErrorTheIntegratorDoesNotWindUp) {
  // A stalled wheel: e = +2 m/s held for 10 s (1250 steps). P alone (2000) saturates the output,
  // so integrating would only wind up. Then the target reverses: e = -0.5 m/s.
  // Without anti-windup the integrator would reach 3000 * 2 * 0.008 * 1250 = 60000 (or, merely
  // clamped, sit at +1000): the output would then stay positive (-500 + 1000 = +500) until the
  // integrator fell below 500, i.e. 500 / (3000 * 0.5 * 0.008 = 12 per step) ~ 42 steps (0.33 s)
  // even in the clamped case. With anti-windup the integrator stays near 0 and the output goes
  // negative at once: -500 + (at most one step's 48) < 0.
  core::PiController pi;
  for (int k = 0; k < 1250; ++k) ASSERT_EQ(pi.update(2.0f, kSeedGains, kH, kLimit), kLimit);
  EXPECT_LE(std::fabs(pi.integrator()), 3000.0f * 2.0f * kH);  // at most one step's worth
  int steps_until_negative = 0;
  float out = kLimit;
  while (out >= 0.0f && steps_until_negative < 1000) {
    out = pi.update(-0.5f, kSeedGains, kH, kLimit);
    ++steps_until_negative;
  }
  EXPECT_LE(steps_until_negative, 3);
}

TEST(PiController, SaturatedByTheIntegralItStopsIntegratingAtTheEdge) {
  // e = +0.1 m/s held for 40 s (the load needs more than pwm_max): P = 100, the integrator
  // climbs by 2.4 per step until one more step would take P + I past 1000, and stops there:
  // the output rests in [1000 - 2.4, 1000] and I within one step of 1000 - 100 = 900.
  // Reversing to e = -0.1 m/s then gives about -100 + 900 = 800 < 1000 at the first step: out
  // of saturation immediately, and the integrator unwinds from there (not from far above).
  core::PiController pi;
  for (int k = 0; k < 5000; ++k) pi.update(0.1f, kSeedGains, kH, kLimit);
  EXPECT_GE(pi.update(0.1f, kSeedGains, kH, kLimit), kLimit - 3000.0f * 0.1f * kH - 1e-3f);
  EXPECT_LE(pi.integrator(), kLimit - 1000.0f * 0.1f + 3000.0f * 0.1f * kH + 1e-3f);
  EXPECT_GE(pi.integrator(), kLimit - 1000.0f * 0.1f - 3000.0f * 0.1f * kH - 1e-3f);
  const float first = pi.update(-0.1f, kSeedGains, kH, kLimit);
  EXPECT_LT(first, kLimit);
  EXPECT_LE(first, kLimit - 2.0f * 1000.0f * 0.1f + 1e-3f);
}

TEST(PiController, SaturationLowIsSymmetric) {
  core::PiController pi;
  for (int k = 0; k < 1250; ++k) ASSERT_EQ(pi.update(-2.0f, kSeedGains, kH, kLimit), -kLimit);
  EXPECT_LE(std::fabs(pi.integrator()), 3000.0f * 2.0f * kH);
  EXPECT_GT(pi.update(0.5f, kSeedGains, kH, kLimit), 0.0f);
}

TEST(PiController, IntegrationResumesOnceOutOfSaturation) {
  // After a long saturated stretch (e = +2, integrator frozen near 0), a small error is
  // integrated normally again: e = 0.1 -> I grows by exactly 2.4 per step.
  core::PiController pi;
  for (int k = 0; k < 500; ++k) pi.update(2.0f, kSeedGains, kH, kLimit);
  const float before = pi.integrator();
  for (int k = 1; k <= 10; ++k) {
    pi.update(0.1f, kSeedGains, kH, kLimit);
    EXPECT_NEAR(pi.integrator(), before + 2.4f * k, 1e-3f) << k;
  }
}

TEST(PiController, NonFiniteErrorIsTreatedAsZero) {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity()};
  for (const float e : bad) {
    core::PiController pi;
    // Build some integral: 5 steps of e = 0.1 -> I = 12; output with e = 0 would be 12.
    for (int k = 0; k < 5; ++k) pi.update(0.1f, kSeedGains, kH, kLimit);
    const float integral = pi.integrator();
    const float out = pi.update(e, kSeedGains, kH, kLimit);
    EXPECT_TRUE(std::isfinite(out)) << e;
    EXPECT_NEAR(out, integral, 1e-4f) << e;
    EXPECT_EQ(pi.integrator(), integral) << e;
    // It keeps working afterwards: e = 0.1 -> 100 + 12 + 2.4.
    EXPECT_NEAR(pi.update(0.1f, kSeedGains, kH, kLimit), 114.4f, 1e-3f) << e;
  }
}

TEST(PiController, ResetClearsTheIntegral) {
  core::PiController pi;
  for (int k = 0; k < 100; ++k) pi.update(0.2f, kSeedGains, kH, kLimit);
  ASSERT_GT(pi.integrator(), 0.0f);
  pi.reset();
  EXPECT_EQ(pi.integrator(), 0.0f);
  // First step after reset is the fresh first step: 1000 * 0.05 + 3000 * 0.05 * 0.008 = 51.2.
  EXPECT_NEAR(pi.update(0.05f, kSeedGains, kH, kLimit), 51.2f, 1e-3f);
}

}  // namespace
