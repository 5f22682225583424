// The USB-serial adapter on its own: the host's transmitter at its baud with no flow control,
// its 16x receiver, the fixed USB delays and the FTDI latency timer, all in simulated cycles.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "usb_serial.hpp"

namespace cart2d {
namespace {

constexpr double kHz = 16e6;
constexpr double kMcuBit = 136.0;  // the Nano's 117 647 baud

// A frame from the MCU at 117 647 baud starting at `start`.
LineWaveform::Frame mcu_frame(uint8_t byte, double start) {
  LineWaveform::Frame f;
  f.start = start;
  f.bit = kMcuBit;
  f.bits = 10;
  f.levels = frame_levels(byte, FrameFormat{});
  return f;
}

// The adapter's receiver decides a frame 153 samples after the start bit's first low one
// (bit 9, sample 10 of 16: the stop bit's third centre sample).
double host_done(double start) {
  const double ts = kHz / 115200 / 16;
  return std::ceil(start / ts) * ts + 153 * ts;
}

TEST(UsbSerialAdapter, HostSendsBackToBackAfterItsUsbDelay) {
  UsbSerialAdapter a;
  AdapterSettings s;
  s.to_mcu_delay_s = 0.001;
  a.set_settings(s, 0.0);
  a.send('a', 5000.0);
  a.send('b', 5000.0);
  a.send_nothing(5000.0);  // a dropped byte keeps its slot
  a.send('c', 5000.0);
  const double first = 5000.0 + 0.001 * kHz, frame = 10 * kHz / 115200;
  EXPECT_EQ(a.to_mcu().size(), 3u);
  EXPECT_TRUE(a.to_mcu().level(first - 0.01));
  EXPECT_DOUBLE_EQ(a.to_mcu().next_fall_after(0.0), first);
  EXPECT_FALSE(a.to_mcu().level(first + frame + 0.01));  // 'b' starts as 'a' ends
  for (double t = first + 2 * frame; t < first + 3 * frame; t += frame / 40)
    EXPECT_TRUE(a.to_mcu().level(t)) << "the dropped byte's slot, t = " << t;
  EXPECT_FALSE(a.to_mcu().level(first + 3 * frame + 0.01));  // 'c'
  EXPECT_NEAR(a.to_mcu_idle_at(), first + 4 * frame, 1e-6);
}

TEST(UsbSerialAdapter, ByteReachesTheHostAtItsStopBitCentrePlusTheDelay) {
  for (const double delay_s : {0.0, 0.002}) {
    UsbSerialAdapter a;
    AdapterSettings s;
    s.to_host_delay_s = delay_s;
    a.set_settings(s, 0.0);
    a.mcu_sent(mcu_frame('Q', 10000.0));
    const double ready = host_done(10000.0) + delay_s * kHz;
    std::string out;
    a.collect(ready - 0.01, &out);
    EXPECT_EQ(out, "");
    a.collect(ready, &out);
    EXPECT_EQ(out, "Q");
    EXPECT_EQ(a.stats().received, 1u);
    EXPECT_EQ(a.stats().frame_errors, 0u);
  }
}

// FT232R: received bytes go to the host in a USB packet when 62 are held, or when the latency
// timer (restarted by every packet) expires.
TEST(UsbSerialAdapter, FtdiLatencyTimerHoldsBytesUntilAPacketIsFullOrTheTimerExpires) {
  UsbSerialAdapter a;
  AdapterSettings s;
  s.latency_timer_s = 0.016;
  a.set_settings(s, 0.0);
  const double timer = 0.016 * kHz;
  const double frame = 10 * kMcuBit;
  // 70 bytes back to back, starting 1 ms after the first expiry.
  const double t0 = timer + 16000.0;
  for (int i = 0; i < 70; ++i) a.mcu_sent(mcu_frame(static_cast<uint8_t>('0' + i % 40), t0 + i * frame));
  std::string out;
  const double byte62 = host_done(t0 + 61 * frame);
  a.collect(byte62 - 0.01, &out);
  EXPECT_EQ(out.size(), 0u);  // 61 held, the timer (due at 2·16 ms) has not expired
  a.collect(byte62, &out);
  EXPECT_EQ(out.size(), 62u);
  a.collect(byte62 + timer - 0.01, &out);
  EXPECT_EQ(out.size(), 62u);  // the other 8 wait for the restarted timer
  a.collect(byte62 + timer, &out);
  EXPECT_EQ(out.size(), 70u);
}

TEST(UsbSerialAdapter, FtdiLoneByteWaitsForTheNextExpiry) {
  UsbSerialAdapter a;
  AdapterSettings s;
  s.latency_timer_s = 0.016;
  s.to_host_delay_s = 0.001;
  a.set_settings(s, 0.0);
  const double timer = 0.016 * kHz;
  a.mcu_sent(mcu_frame('z', 3 * timer + 5000.0));
  std::string out;
  a.collect(4 * timer + 16000.0 - 0.01, &out);
  EXPECT_EQ(out, "");
  a.collect(4 * timer + 16000.0, &out);
  EXPECT_EQ(out, "z");
}

}  // namespace
}  // namespace cart2d
