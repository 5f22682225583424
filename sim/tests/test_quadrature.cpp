#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "quadrature.hpp"

namespace cart2d {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHz = 16e6;
constexpr uint64_t kStep = 4000;  // cycles per physics step

struct Counts {
  int a_edges = 0, b_edges = 0;
  int a_rise_b_high = 0, a_rise_b_low = 0;
};

// Turns an encoder by total_rad in n_steps equal physics steps and tallies the edges.
Counts turn(QuadratureEncoder& enc, double total_rad, int n_steps, const QuadratureFaults& f = {}, uint64_t seed = 1,
            std::vector<QuadratureEdge>* all = nullptr) {
  Rng rng(seed);
  Counts c;
  bool a = enc.a(), b = enc.b();
  for (int s = 0; s < n_steps; ++s) {
    std::vector<QuadratureEdge> out;
    const uint64_t c0 = 1000000 + static_cast<uint64_t>(s) * kStep;
    enc.advance(total_rad / n_steps, c0, kStep, f, rng, &out);
    for (const auto& e : out) {
      EXPECT_GE(e.cycle, c0);
      EXPECT_LT(e.cycle, c0 + kStep);
      if (e.a != a) {
        ++c.a_edges;
        if (e.a) (e.b ? c.a_rise_b_high : c.a_rise_b_low)++;
      }
      if (e.b != b) ++c.b_edges;
      a = e.a;
      b = e.b;
      if (all) all->push_back(e);
    }
  }
  return c;
}

TEST(Quadrature, OneRevolutionIs4000EdgesAnd2000OnChannelA) {
  QuadratureEncoder enc(1000, false, kHz);
  const Counts c = turn(enc, 2 * kPi, 1000);
  EXPECT_EQ(c.a_edges, 2000);
  EXPECT_EQ(c.b_edges, 2000);
  EXPECT_EQ(enc.state_count(), 4000);
}

TEST(Quadrature, ExactCountHoldsForAnyStepSize) {
  for (int steps : {1, 7, 333, 4000, 40000}) {
    QuadratureEncoder enc(1000, true, kHz);
    const Counts c = turn(enc, 2 * kPi, steps);
    EXPECT_EQ(c.a_edges + c.b_edges, 4000) << steps << " steps";
  }
}

// robot.toml: left_b_high_on_rise_is_forward = false, right = true.
TEST(Quadrature, LeftConventionBLowOnForwardRise) {
  QuadratureEncoder enc(1000, false, kHz);
  Counts c = turn(enc, 0.5, 100);
  EXPECT_GT(c.a_rise_b_low, 0);
  EXPECT_EQ(c.a_rise_b_high, 0);
  c = turn(enc, -1.0, 100);  // backwards: B high when A rises
  EXPECT_GT(c.a_rise_b_high, 0);
  EXPECT_EQ(c.a_rise_b_low, 0);
}

TEST(Quadrature, RightConventionBHighOnForwardRise) {
  QuadratureEncoder enc(1000, true, kHz);
  const Counts c = turn(enc, 0.5, 100);
  EXPECT_GT(c.a_rise_b_high, 0);
  EXPECT_EQ(c.a_rise_b_low, 0);
}

TEST(Quadrature, ForwardAndBackReturnsToTheStart) {
  QuadratureEncoder enc(1000, false, kHz);
  turn(enc, 1.234, 50);
  turn(enc, -1.234, 70);
  EXPECT_EQ(enc.state_count(), 0);
  EXPECT_FALSE(enc.a());
  EXPECT_FALSE(enc.b());
}

TEST(Quadrature, EdgesAreEvenlySpacedAtConstantSpeed) {
  QuadratureEncoder enc(1000, false, kHz);
  std::vector<QuadratureEdge> all;
  // 1 rev/s: one edge every 16e6 / 4000 = 4000 cycles.
  turn(enc, 2 * kPi, 4000, {}, 1, &all);
  ASSERT_EQ(all.size(), 4000u);
  for (size_t i = 1; i < all.size(); ++i) EXPECT_NEAR(static_cast<double>(all[i].cycle - all[i - 1].cycle), 4000.0, 1.0);
}

TEST(Quadrature, EveryPulseMissedLeavesAQuiet) {
  QuadratureEncoder enc(1000, false, kHz);
  QuadratureFaults f;
  f.miss_prob = 1.0;
  const Counts c = turn(enc, 2 * kPi, 1000, f);
  EXPECT_EQ(c.a_edges, 0);
  EXPECT_EQ(c.b_edges, 2000);
  EXPECT_EQ(enc.state_count(), 4000);  // the wheel turned all the same
}

TEST(Quadrature, SomePulsesMissed) {
  QuadratureEncoder enc(1000, false, kHz);
  QuadratureFaults f;
  f.miss_prob = 0.1;
  const Counts c = turn(enc, 20 * kPi, 10000, f);  // 10 000 pulses
  EXPECT_NEAR(c.a_edges, 2 * 10000 * 0.9, 2 * 400);
}

TEST(Quadrature, NoiseSpikesComeInPairsAtTheRequestedRate) {
  QuadratureEncoder enc(1000, false, kHz);
  QuadratureFaults f;
  f.noise_hz = 100.0;
  const Counts c = turn(enc, 0.0, 40000, f);  // 10 s standing still
  EXPECT_EQ(c.a_edges % 2, 0);
  EXPECT_NEAR(c.a_edges / 2, 1000, 150);
  EXPECT_EQ(c.b_edges, 0);
  EXPECT_EQ(enc.state_count(), 0);
}

TEST(Quadrature, SameSeedSameEdges) {
  QuadratureFaults f;
  f.miss_prob = 0.05;
  f.noise_hz = 50;
  QuadratureEncoder e1(1000, false, kHz), e2(1000, false, kHz);
  std::vector<QuadratureEdge> a1, a2;
  turn(e1, 7.0, 4000, f, 42, &a1);
  turn(e2, 7.0, 4000, f, 42, &a2);
  ASSERT_EQ(a1.size(), a2.size());
  for (size_t i = 0; i < a1.size(); ++i) EXPECT_EQ(a1[i].cycle, a2[i].cycle);
}

}  // namespace
}  // namespace cart2d
