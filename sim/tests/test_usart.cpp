// USART0 as the firmware sees it, against a tiny AVR program (avr/usart_exerciser.c) that logs
// every byte with the FE0/DOR0/UPE0 flags it read before it, and can block its interrupts for a
// number of frame times. The host's adapter streams at its own baud rate with no flow control.
// All assertions are in simulated time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "rig.hpp"

extern "C" {
#include <sim_avr.h>  // avr_reset
}

namespace cart2d {
namespace {

constexpr uint64_t kHz = 16000000;
constexpr uint64_t kMcuBit = 17 * 8;    // UBRR0 = 16 with U2X: 117 647 baud
constexpr uint64_t kSample = 17;        // the receiver's sample clock, 8 samples per bit
constexpr double kHostBit = 16e6 / 115200;  // 138.9 cycles

struct Entry {
  uint8_t data = 0;
  bool fe = false, dor = false, upe = false;
};

// One "\nR 62 34 41 42 44o ...\n" line from text[r] on → its entries.
void parse_report_line(const std::string& text, size_t r, std::vector<Entry>* entries) {
  size_t i = r + 1;
  while (i < text.size() && text[i] == ' ') {
    Entry e;
    unsigned v = 0;
    if (std::sscanf(text.c_str() + i + 1, "%2x", &v) != 1) return;
    e.data = static_cast<uint8_t>(v);
    for (i += 3; i < text.size() && text[i] != ' ' && text[i] != '\n'; ++i) {
      e.fe |= text[i] == 'f';
      e.dor |= text[i] == 'o';
      e.upe |= text[i] == 'p';
    }
    entries->push_back(e);
  }
}

// The entries of every report line in text, in order.
std::vector<Entry> parse_reports(const std::string& text) {
  std::vector<Entry> entries;
  for (size_t r = text.find("R "); r != std::string::npos; r = text.find("R ", r + 1))
    if (r == 0 || text[r - 1] == '\n') parse_report_line(text, r, &entries);
  return entries;
}

class UsartTest : public ::testing::Test {
 protected:
  void SetUp() override {
    RigConfig rc;
    rc.firmware = USART_EXERCISER_ELF;
    rc.open_pty = false;
    rc.start = Pose{0.9, 0.9, 0.0};
    std::string err;
    ASSERT_TRUE(rig_.init(rc, &err)) << err;
    rig_.set_scripted_twist(Twist{});
    // The power-on reset's time-out (65 ms), then 10 ms for the program to print its banner.
    run_s(static_cast<double>(rig_.mcu().timeout_cycles()) / kHz + 0.01);
    banner_ = out();
  }

  void run_s(double s) { ASSERT_TRUE(rig_.run_cycles(static_cast<uint64_t>(s * kHz))); }
  std::string out() { return rig_.uart().take_output(rig_.cycle()); }
  void set_host_baud(double baud) {
    AdapterSettings a = rig_.uart().adapter();
    a.baud = baud;
    rig_.uart().set_adapter(a);
  }

  // Sends bytes, then 'r' at 115200 after the line has been idle a while; returns the entries
  // logged from `bytes` on (the first skip_front left out) up to that 'r' (left out).
  std::vector<Entry> received(const std::string& bytes, size_t skip_front) {
    out();
    rig_.uart().inject(bytes);
    run_s(0.02);
    const double baud = rig_.uart().adapter().baud;
    set_host_baud(115200);
    rig_.uart().inject("r");
    run_s(0.05);
    std::vector<Entry> all = parse_reports(out());
    set_host_baud(baud);
    if (all.size() < skip_front + 1) return {};
    return std::vector<Entry>(all.begin() + static_cast<long>(skip_front), all.end() - 1);
  }

  // Cycles from the host writing 'x' to the echoed 'X' being readable on the host.
  double echo_round_trip() {
    run_s(0.005);
    out();
    const uint64_t t0 = rig_.cycle();
    rig_.uart().inject("x");
    run_s(0.05);
    std::vector<double> ready;
    EXPECT_EQ(rig_.uart().take_output(rig_.cycle(), &ready), "X");
    return ready.empty() ? 0.0 : ready[0] - static_cast<double>(t0);
  }

  static std::string payload(const std::vector<Entry>& entries) {
    std::string s;
    for (const Entry& e : entries) s.push_back(static_cast<char>(e.data));
    return s;
  }

  Rig rig_;
  std::string banner_;
};

TEST_F(UsartTest, BootBannerArrivesIntact) {
  EXPECT_EQ(banner_, "HELLO\n");
  EXPECT_EQ(rig_.uart().stats().tx_frame_errors, 0u);
}

// §19.8.2: the frame is complete at the third centre sample of its stop bit: sample 6 of 8 of
// bit 9, 77 samples after the start bit's first low sample, which comes at most one sample
// after the falling edge. simavr alone made the byte readable a whole frame after it entered.
TEST_F(UsartTest, ByteIsReadableAtItsStopBitCentre) {
  const uint64_t before = rig_.uart().stats().rx_bytes;
  const uint64_t t0 = rig_.cycle();
  rig_.uart().inject("0");
  uint64_t done = 0;
  while (rig_.uart().stats().rx_bytes == before && rig_.cycle() < t0 + 20 * kMcuBit) {
    ASSERT_TRUE(rig_.run_cycles(1));
    done = rig_.cycle();
  }
  ASSERT_EQ(rig_.uart().stats().rx_bytes, before + 1);
  // The timer fires after the instruction under way (at most 4 cycles, or the sleep's wake-up).
  EXPECT_GE(done - t0, 77 * kSample);
  EXPECT_LT(done - t0, 78 * kSample + 5);
}

// 'x' is echoed from the interrupt: in at the stop bit's centre, the echo out at once, and the
// adapter's 16x receiver done at its own stop bit's centre (153 of its samples).
TEST_F(UsartTest, EchoRoundTripEndsAtTheHostsStopBitCentre) {
  const double rt = echo_round_trip();
  const double in = 77 * kSample, back = 153 * kHostBit / 16;
  EXPECT_GE(rt, in + back);
  EXPECT_LE(rt, in + kSample + 40 + back + kHostBit / 16);
}

// The USB delays add to the round trip in simulated time, one each way; the sample phases of
// the two receivers may move by up to one sample each.
TEST_F(UsartTest, EchoRoundTripGrowsByTheUsbDelays) {
  const double direct = echo_round_trip();
  AdapterSettings a = rig_.uart().adapter();
  a.to_mcu_delay_s = 0.001;
  a.to_host_delay_s = 0.002;
  rig_.uart().set_adapter(a);
  const double ch340 = echo_round_trip();
  EXPECT_NEAR(ch340 - direct, 0.003 * kHz, kSample + kHostBit / 16 + 8);
}

// An FT232R holds what it receives until 62 bytes fill a USB packet or its latency timer
// (16 ms, restarted by every packet) expires: a lone echo waits for an expiry, a 100-byte burst
// goes as 62 bytes the moment the 62nd arrives and 38 one timer period later.
TEST_F(UsartTest, FtdiLatencyTimerPacketsTheMcusBytes) {
  AdapterSettings a = rig_.uart().adapter();
  a.latency_timer_s = 0.016;
  rig_.uart().set_adapter(a);
  const double period = 0.016 * kHz;
  out();
  rig_.uart().inject("x");
  run_s(0.04);
  std::vector<double> ready;
  ASSERT_EQ(rig_.uart().take_output(rig_.cycle(), &ready), "X");
  EXPECT_EQ(std::fmod(ready[0], period), 0.0);  // the timer runs from cycle 0: no packet sent yet
  out();
  rig_.uart().inject("t");
  run_s(0.05);
  ready.clear();
  const std::string burst = rig_.uart().take_output(rig_.cycle(), &ready);
  ASSERT_EQ(burst.size(), 100u);
  for (int i = 0; i < 62; ++i) EXPECT_EQ(ready[i], ready[61]) << i;
  for (int i = 62; i < 100; ++i) EXPECT_EQ(ready[i], ready[61] + period) << i;
  EXPECT_LT(ready[61], ready[0] + period);
}

// Interrupts off for N frame times while the host streams: the two-byte buffer and the shift
// register hold three frames; nothing is lost while they suffice.
TEST_F(UsartTest, ShortInterruptBlocksLoseNothing) {
  for (const char n : {'1', '2'}) {
    const uint64_t overruns = rig_.uart().stats().rx_overruns;
    const std::vector<Entry> got = received(std::string("b") + n + "ABCDEFGH", 2);
    EXPECT_EQ(payload(got), "ABCDEFGH") << "blocked " << n << " frames";
    for (const Entry& e : got) EXPECT_FALSE(e.fe || e.dor || e.upe);
    EXPECT_EQ(rig_.uart().stats().rx_overruns, overruns);
  }
}

// Blocked for 4 frame times (5440 cycles) from about when 'A' starts: A and B fill the buffer,
// C completes into the shift register (1389·3 + 1310 cycles after A's start, about 5480), D's
// start bit is detected (about 5640) before the block ends: C is lost (§19.7.4). D reaches the
// buffer after the block and carries DOR0: a frame was lost between B, the last one read, and D.
TEST_F(UsartTest, FourFrameBlockLosesTheFrameInTheShiftRegister) {
  const std::vector<Entry> got = received("b4ABCDEFGH", 2);
  EXPECT_EQ(payload(got), "ABDEFGH");
  ASSERT_EQ(got.size(), 7u);
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].dor, i == 2) << "entry " << i;
    EXPECT_FALSE(got[i].fe);
  }
  EXPECT_EQ(rig_.uart().stats().rx_overruns, 1u);
}

// Blocked for 8 frame times (10 880 cycles): C, D, E, F and G each complete into the shift
// register and are lost when the next start bit comes; H completes after the block (about
// 1389·7 + 1310 = 11 030 cycles after A's start... H's start bit is the last before the end).
TEST_F(UsartTest, LongBlockLosesEveryFrameTheShiftRegisterHeld) {
  const std::vector<Entry> got = received("b8ABCDEFGHIJ", 2);
  EXPECT_EQ(payload(got), "ABHIJ");
  ASSERT_EQ(got.size(), 5u);
  EXPECT_TRUE(got[2].dor);
  EXPECT_FALSE(got[0].dor || got[1].dor || got[3].dor || got[4].dor);
  EXPECT_EQ(rig_.uart().stats().rx_overruns, 5u);
}

// A reset by any path (here simavr's avr_reset() itself, as its watchdog does) flushes the
// receive buffer: frames waiting there before the reset never reach the restarted program.
TEST_F(UsartTest, ResetOfAnyKindFlushesTheReceiveBuffer) {
  rig_.uart().inject("b9ABC");  // interrupts off for 9 frames from about when A starts
  ASSERT_TRUE(rig_.run_cycles(8000));  // A and B done (≈ 4160, 5550), C too (≈ 6940)
  ASSERT_EQ(rig_.uart().receiver().unread(), 2);
  ASSERT_TRUE(rig_.uart().receiver().shift_register_full());
  avr_reset(rig_.mcu().avr());
  run_s(static_cast<double>(rig_.mcu().timeout_cycles()) / kHz + 0.01);  // the time-out, then the banner
  EXPECT_EQ(out(), "HELLO\n");
  EXPECT_EQ(payload(received("", 0)), "");  // the report holds its own 'r' only
}

// The host at 115 200 baud, the Nano at 117 647 (−2.1 %): every byte arrives exactly.
TEST_F(UsartTest, HostAt115200IsReceivedExactly) {
  std::string all;
  for (int v = 0; v < 256; ++v)
    if (v != 'b' && v != 'r' && v != 't') all.push_back(static_cast<char>(v));
  const std::vector<Entry> got = received(all.substr(0, 120), 0);
  EXPECT_EQ(payload(got), all.substr(0, 120));
  for (const Entry& e : got) EXPECT_FALSE(e.fe || e.dor);
  EXPECT_EQ(rig_.uart().stats().rx_frame_errors, 0u);
}

// Outside the receiver's range (test_serial_wire.cpp: 94.7 % to 103.9 % of 117 647 baud with
// U2X) the stop bit is sampled in the wrong bit: FE0, and the firmware sees the same count of
// FE0 flags as the link counted frame errors.
TEST_F(UsartTest, HostBaudOutsideTheRangeGivesFramingErrors) {
  const std::string text = "0123456789:;<=>?@ABCDEFGHIJ";
  for (const double ok : {112000.0, 120000.0}) {
    set_host_baud(ok);
    const std::vector<Entry> got = received(text, 0);
    EXPECT_EQ(payload(got), text) << ok << " baud";
    EXPECT_EQ(rig_.uart().stats().rx_frame_errors, 0u) << ok << " baud";
  }
  for (const double bad : {108000.0, 125000.0}) {
    const uint64_t before = rig_.uart().stats().rx_frame_errors;
    set_host_baud(bad);
    const std::vector<Entry> got = received(text, 0);
    size_t flagged = 0;
    for (const Entry& e : got) flagged += e.fe;
    EXPECT_GT(flagged, text.size() / 2) << bad << " baud";
    EXPECT_NE(payload(got), text) << bad << " baud";
    EXPECT_EQ(rig_.uart().stats().rx_frame_errors - before, flagged) << bad << " baud";
  }
}

// The other way: the adapter's 16x receiver at 126 000 baud reads the Nano's 117 647 baud
// frames 6.6 % too slow, past its 94.1 % limit: every stop bit of ASCII text samples low.
TEST_F(UsartTest, HostReceiverSeesFramingErrorsAtAWrongBaud) {
  set_host_baud(126000);
  rig_.reset_mcu();
  run_s(static_cast<double>(rig_.mcu().timeout_cycles()) / kHz + 0.01);  // the reset's time-out, then the banner
  EXPECT_NE(out(), "HELLO\n");
  EXPECT_EQ(rig_.uart().stats().tx_frame_errors, 6u);
}

}  // namespace
}  // namespace cart2d
