// The host's end of the Nano's serial line: the USB-serial adapter (CH340, FTDI FT232R) with
// its UART at the host's baud rate, and the USB transfers between it and the host, all in the
// MCU's simulated cycles. No flow control: the adapter sends what the host wrote at its line
// rate, whether or not the MCU keeps up. No simavr in here.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "serial_wire.hpp"

namespace cart2d {

struct AdapterSettings {
  double baud = 115200.0;         // the host's line rate, both directions
  double to_mcu_delay_s = 0.0;    // a host write → its first start bit on the wire
  double to_host_delay_s = 0.0;   // a received byte (FTDI: its packet) → readable by the host
  double latency_timer_s = 0.0;   // > 0: FTDI mode, received bytes wait for a full packet or this
};

class UsbSerialAdapter {
 public:
  // FT232R: a USB packet carries 62 data bytes after its 2 modem-status bytes (FTDI AN232B-04).
  static constexpr size_t kFtdiPacketData = 62;

  struct Stats {
    uint64_t received = 0;      // frames its receiver got from the MCU
    uint64_t frame_errors = 0;  // of which the stop bit read low
  };

  UsbSerialAdapter() { apply(settings_); }
  void set_cpu_hz(double hz) {
    cpu_hz_ = hz;
    apply(settings_);
  }
  // Applies to bytes the host writes from cycle now on and to the next start bit received
  // after now; what was received by now is received with the settings before.
  void set_settings(const AdapterSettings& settings, double now);
  const AdapterSettings& settings() const { return settings_; }
  double bit_cycles() const { return cpu_hz_ / settings_.baud; }

  // Host → MCU: the byte the host wrote at cycle now goes out after those before it.
  void send(uint8_t byte, double now);
  // Its slot on the wire passes with the line idle (a byte lost on the way).
  void send_nothing(double now);
  const LineWaveform& to_mcu() const { return to_mcu_; }
  // When the host's transmitter has sent everything it was given.
  double to_mcu_idle_at() const { return line_free_; }
  void forget_to_mcu_before(double t) { to_mcu_.forget_before(t); }

  // MCU → host: a frame the MCU's transmitter puts on the line.
  void mcu_sent(const LineWaveform::Frame& frame) { from_mcu_.add(frame); }
  // The MCU stopped transmitting at cycle t (reset): the line goes high from the next bit on.
  void mcu_line_released(double t);
  // Appends what the host can read by cycle now, in order (and, if asked, the cycle each byte
  // became readable).
  void collect(double now, std::string* out, std::vector<double>* ready = nullptr);
  const Stats& stats() const { return stats_; }

 private:
  void apply(const AdapterSettings& settings);
  void receive_until(double now);
  void received(const AsyncReceiver::Event& ev);
  void flush_expired(double t);
  void flush(double t);
  void deliver(double t, uint8_t byte);

  double cpu_hz_ = 16e6;
  AdapterSettings settings_;
  LineWaveform to_mcu_;
  double line_free_ = 0.0;  // the host's transmitter is busy until then
  LineWaveform from_mcu_;
  AsyncReceiver receiver_;
  Stats stats_;
  std::string held_;            // FTDI: bytes waiting for the next packet
  double timer_start_ = 0.0;    // FTDI: the latency timer restarts with every packet sent
  double next_expiry_ = 0.0;
  std::deque<std::pair<double, uint8_t>> to_host_;  // (cycle readable, byte)
};

}  // namespace cart2d
