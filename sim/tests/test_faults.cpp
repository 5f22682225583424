#include <gtest/gtest.h>

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
