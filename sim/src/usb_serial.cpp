#include "usb_serial.hpp"

#include <algorithm>  // std::max, std::min
#include <cmath>      // std::floor

namespace cart2d {

namespace {

constexpr FrameFormat kHost8N1;  // the gateway opens the port 8N1

}  // namespace

// The adapter's receiver oversamples 16 times per bit with a 3-sample majority at the bit
// centre, as the AVR's normal-speed mode does (the FT232R and CH340 datasheets give 16×; their
// exact vote samples are not published). It runs from the adapter's own clock, so its sample
// grid does not follow the MCU's.
void UsbSerialAdapter::set_settings(const AdapterSettings& settings, double now) {
  receive_until(now);
  apply(settings);
}

void UsbSerialAdapter::apply(const AdapterSettings& settings) {
  settings_ = settings;
  SamplerConfig c;
  c.samples_per_bit = 16;
  c.sample_period = bit_cycles() / c.samples_per_bit;
  c.origin = 0.0;
  c.format = kHost8N1;
  const bool was_enabled = receiver_.enabled();
  receiver_.configure(c);
  if (!was_enabled) receiver_.enable(0.0);
}

void UsbSerialAdapter::send(uint8_t byte, double now) {
  LineWaveform::Frame f;
  f.bit = bit_cycles();
  f.bits = static_cast<uint8_t>(kHost8N1.bits());
  f.levels = frame_levels(byte, kHost8N1);
  f.start = std::max(now + settings_.to_mcu_delay_s * cpu_hz_, line_free_);
  line_free_ = f.end();
  to_mcu_.add(f);
}

void UsbSerialAdapter::send_nothing(double now) {
  const double start = std::max(now + settings_.to_mcu_delay_s * cpu_hz_, line_free_);
  line_free_ = start + kHost8N1.bits() * bit_cycles();
}

void UsbSerialAdapter::mcu_line_released(double t) { from_mcu_.release_after(t); }

void UsbSerialAdapter::receive_until(double now) {
  for (double t = receiver_.next_event(from_mcu_); t <= now; t = receiver_.next_event(from_mcu_)) {
    const AsyncReceiver::Event ev = receiver_.step(from_mcu_);
    if (ev.kind == AsyncReceiver::Kind::kFrame) received(ev);
  }
  flush_expired(now);
  from_mcu_.forget_before(std::min(receiver_.needed_from(), now));
}

void UsbSerialAdapter::collect(double now, std::string* out, std::vector<double>* ready) {
  receive_until(now);
  while (!to_host_.empty() && to_host_.front().first <= now) {
    out->push_back(static_cast<char>(to_host_.front().second));
    if (ready) ready->push_back(to_host_.front().first);
    to_host_.pop_front();
  }
}

// With a framing error Linux still delivers the character the UART sampled: pyserial clears
// INPCK for no parity, and n_tty then passes flagged characters through unchanged
// (n_tty_receive_parity_error); the usb-serial drivers report the byte as received.
void UsbSerialAdapter::received(const AsyncReceiver::Event& ev) {
  ++stats_.received;
  if (ev.frame_error) ++stats_.frame_errors;
  if (settings_.latency_timer_s <= 0.0) {
    deliver(ev.t + settings_.to_host_delay_s * cpu_hz_, ev.data);
    return;
  }
  flush_expired(ev.t);
  if (held_.empty()) {
    // The timer runs from the last packet sent; expiries with nothing held send status only.
    const double period = settings_.latency_timer_s * cpu_hz_;
    next_expiry_ = timer_start_ + (std::floor((ev.t - timer_start_) / period) + 1.0) * period;
  }
  held_.push_back(static_cast<char>(ev.data));
  if (held_.size() >= kFtdiPacketData) flush(ev.t);
}

void UsbSerialAdapter::flush_expired(double t) {
  if (!held_.empty() && next_expiry_ <= t) flush(next_expiry_);
}

void UsbSerialAdapter::flush(double t) {
  for (const char c : held_) deliver(t + settings_.to_host_delay_s * cpu_hz_, static_cast<uint8_t>(c));
  held_.clear();
  timer_start_ = t;
}

void UsbSerialAdapter::deliver(double t, uint8_t byte) {
  // A shorter delay set at run time must not let a byte overtake the ones before it.
  if (!to_host_.empty()) t = std::max(t, to_host_.back().first);
  to_host_.emplace_back(t, byte);
}

}  // namespace cart2d
