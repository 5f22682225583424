#include <gtest/gtest.h>

#include <vector>

#include "faults.hpp"
#include "options.hpp"
#include "rng.hpp"

namespace cart2d {
namespace {

json::Value parse(const std::string& s) {
  json::Value v;
  std::string err;
  EXPECT_TRUE(json::parse(s, &v, &err)) << err;
  return v;
}

TEST(Faults, AppliesKnownKeys) {
  Faults f;
  std::string err;
  ASSERT_TRUE(apply_faults(parse(R"({"type":"faults","enc_radius_scale_l":1.01,"uart_rx_drop":0.01})"), &f, &err)) << err;
  EXPECT_DOUBLE_EQ(f.enc_radius_scale_l, 1.01);
  EXPECT_DOUBLE_EQ(f.uart_rx_drop, 0.01);
  EXPECT_DOUBLE_EQ(f.enc_radius_scale_r, 1.0);
}

TEST(Faults, RejectsUnknownOrOutOfRangeAndChangesNothing) {
  Faults f;
  f.enc_slip_l = 0.2;
  std::string err;
  EXPECT_FALSE(apply_faults(parse(R"({"enc_slip_l":0.3,"bogus":1})"), &f, &err));
  EXPECT_NE(err.find("bogus"), std::string::npos);
  EXPECT_FALSE(apply_faults(parse(R"({"enc_slip_l":0.3,"uart_tx_drop":2})"), &f, &err));
  EXPECT_FALSE(apply_faults(parse(R"({"enc_slip_l":"x"})"), &f, &err));
  EXPECT_DOUBLE_EQ(f.enc_slip_l, 0.2);
}

TEST(Faults, ClearRestoresDefaultsFirst) {
  Faults f;
  f.enc_slip_l = 0.2;
  std::string err;
  ASSERT_TRUE(apply_faults(parse(R"({"clear":true,"enc_noise_hz":5})"), &f, &err));
  EXPECT_DOUBLE_EQ(f.enc_slip_l, 0.0);
  EXPECT_DOUBLE_EQ(f.enc_noise_hz, 5.0);
  EXPECT_NE(faults_json(f).find("\"enc_noise_hz\":5"), std::string::npos);
}

TEST(Faults, PullDownsAreFittedUntilRemovedAndTakeOnlyZeroOrOne) {
  Faults f;
  EXPECT_DOUBLE_EQ(f.hbridge_pulldowns, 1.0);
  std::string err;
  EXPECT_FALSE(apply_faults(parse(R"({"hbridge_pulldowns":0.5})"), &f, &err));
  EXPECT_NE(err.find("whole"), std::string::npos);
  ASSERT_TRUE(apply_faults(parse(R"({"hbridge_pulldowns":0})"), &f, &err)) << err;
  EXPECT_DOUBLE_EQ(f.hbridge_pulldowns, 0.0);
  ASSERT_TRUE(apply_faults(parse(R"({"clear":true})"), &f, &err));
  EXPECT_DOUBLE_EQ(f.hbridge_pulldowns, 1.0);
}

// The share of simulated time inside bursts, and the length of each, sampled every 0.1 ms.
struct BurstSample {
  double share = 0.0;
  std::vector<double> lengths_s;
};

BurstSample sample_bursts(BurstSchedule* bursts, double seconds) {
  BurstSample out;
  const double step = 1e-4;
  double run = 0.0;
  int inside = 0;
  const int steps = static_cast<int>(seconds / step);
  for (int i = 0; i < steps; ++i) {
    if (bursts->in_burst(i * step)) {
      ++inside;
      run += step;
    } else if (run > 0.0) {
      out.lengths_s.push_back(run);
      run = 0.0;
    }
  }
  out.share = static_cast<double>(inside) / steps;
  return out;
}

TEST(Bursts, OffUntilConfigured) {
  BurstSchedule bursts;
  bursts.reseed(3);
  for (int i = 0; i < 1000; ++i) EXPECT_FALSE(bursts.drops(i * 0.01, 1.0));
  Faults f;
  std::string err;
  ASSERT_TRUE(apply_faults(parse(R"({"uart_burst_hz":2,"uart_burst_ms":50,"uart_burst_drop":0.5})"), &f, &err)) << err;
  EXPECT_DOUBLE_EQ(f.uart_burst_ms, 50.0);
  EXPECT_FALSE(apply_faults(parse(R"({"uart_burst_hz":101})"), &f, &err));
  EXPECT_FALSE(apply_faults(parse(R"({"uart_burst_drop":1.5})"), &f, &err));
}

TEST(Bursts, ComeAtTheirRateAndLastTheirLength) {
  BurstSchedule bursts;
  bursts.reseed(7);
  bursts.configure(2.0, 50.0, 0.0);
  const BurstSample s = sample_bursts(&bursts, 200.0);
  // A burst every 1 / 2 s after the last one ended: 0.05 s in every 0.55 s on average.
  EXPECT_NEAR(s.share, 0.05 / 0.55, 0.015);
  EXPECT_NEAR(static_cast<double>(s.lengths_s.size()), 200.0 / 0.55, 40.0);
  for (double length : s.lengths_s) EXPECT_NEAR(length, 0.05, 2e-4);
}

TEST(Bursts, AreTheSameForASeedAndInAnyOrderOfQuestions) {
  BurstSchedule a, b, c;
  a.reseed(11);
  b.reseed(11);
  c.reseed(12);
  for (BurstSchedule* s : {&a, &b, &c}) s->configure(5.0, 20.0, 0.0);
  int same_seed_differs = 0, other_seed_differs = 0;
  for (int i = 0; i < 20000; ++i) {
    const double t = i * 1e-3;
    // b is asked 0.5 s ahead first, then about now (a frame from the MCU starts ahead of now).
    const bool ahead = b.in_burst(t + 0.5);
    (void)ahead;
    same_seed_differs += a.in_burst(t) != b.in_burst(t);
    other_seed_differs += a.in_burst(t) != c.in_burst(t);
  }
  EXPECT_EQ(same_seed_differs, 0);
  EXPECT_GT(other_seed_differs, 100);
}

TEST(Bursts, DropBytesOnlyInsideABurstWithTheirProbability) {
  BurstSchedule bursts;
  bursts.reseed(5);
  bursts.configure(10.0, 30.0, 0.0);
  int inside = 0, dropped_inside = 0, dropped_outside = 0;
  for (int i = 0; i < 100000; ++i) {
    const double t = i * 1e-4;
    const bool in = bursts.in_burst(t);
    const bool dropped = bursts.drops(t, 0.5);
    inside += in;
    dropped_inside += in && dropped;
    dropped_outside += !in && dropped;
  }
  EXPECT_EQ(dropped_outside, 0);
  ASSERT_GT(inside, 1000);
  EXPECT_NEAR(static_cast<double>(dropped_inside) / inside, 0.5, 0.05);
}

TEST(Rng, StreamsAreRepeatableAndIndependent) {
  Rng a(7, 1), b(7, 1), c(7, 2);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(a.next(), b.next());
  EXPECT_NE(Rng(7, 1).next(), c.next());
  Rng u(1);
  double sum = 0;
  for (int i = 0; i < 100000; ++i) sum += u.uniform();
  EXPECT_NEAR(sum / 100000, 0.5, 0.01);
}

TEST(Options, ParsesTheCommandLine) {
  const char* argv[] = {"cart2d-sim", "--firmware", "fw.elf", "--speed", "max", "--seed", "12",
                        "--start", "0.4,0.2,-1.5", "--arena-margin", "0.3", "--truth-hz", "10"};
  Options o;
  bool help = false;
  std::string err;
  ASSERT_TRUE(parse_options(13, const_cast<char**>(argv), &o, &help, &err)) << err;
  EXPECT_EQ(o.firmware, "fw.elf");
  EXPECT_EQ(o.speed, 0.0);
  EXPECT_EQ(o.seed, 12u);
  EXPECT_DOUBLE_EQ(o.start.y_m, 0.2);
  EXPECT_DOUBLE_EQ(o.start.theta_rad, -1.5);
  EXPECT_DOUBLE_EQ(o.arena_margin_m, 0.3);
  EXPECT_DOUBLE_EQ(o.truth_hz, 10.0);
}

TEST(Options, RejectsBadValues) {
  bool help = false;
  std::string err;
  const char* no_fw[] = {"cart2d-sim"};
  Options o;
  EXPECT_FALSE(parse_options(1, const_cast<char**>(no_fw), &o, &help, &err));
  const char* bad_speed[] = {"cart2d-sim", "--firmware", "f", "--speed", "-1"};
  EXPECT_FALSE(parse_options(5, const_cast<char**>(bad_speed), &o, &help, &err));
  const char* bad_start[] = {"cart2d-sim", "--firmware", "f", "--start", "1,2"};
  EXPECT_FALSE(parse_options(5, const_cast<char**>(bad_start), &o, &help, &err));
}

}  // namespace
}  // namespace cart2d
