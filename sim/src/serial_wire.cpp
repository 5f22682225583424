#include "serial_wire.hpp"

#include <algorithm>  // std::partition_point
#include <cmath>      // std::ceil, std::floor

namespace cart2d {

bool parity_bit(uint8_t data, const FrameFormat& format) {
  bool odd_ones = false;
  for (int i = 0; i < format.data_bits; ++i) odd_ones ^= (data >> i) & 1;
  return format.parity == Parity::kOdd ? !odd_ones : odd_ones;
}

uint16_t frame_levels(uint8_t data, const FrameFormat& format) {
  const uint16_t data_mask = static_cast<uint16_t>((1u << format.data_bits) - 1);
  uint16_t levels = static_cast<uint16_t>((data & data_mask) << 1);  // bit 0: the start bit, low
  if (format.parity != Parity::kNone && parity_bit(data, format))
    levels |= static_cast<uint16_t>(1u << (1 + format.data_bits));
  for (int i = format.stop_index(); i < format.bits(); ++i) levels |= static_cast<uint16_t>(1u << i);
  return levels;
}

// ---- LineWaveform ---------------------------------------------------------------------------

void LineWaveform::add(const Frame& frame) { frames_.push_back(frame); }

size_t LineWaveform::first_not_ended(double t) const {
  const auto it = std::partition_point(frames_.begin(), frames_.end(), [t](const Frame& f) { return f.end() <= t; });
  return static_cast<size_t>(it - frames_.begin());
}

// Bit b covers [start + b·bit, start + (b+1)·bit); the same products decide edges and levels,
// so an instant on an edge always reads the new bit.
int LineWaveform::bit_index(const Frame& f, double t) {
  int b = static_cast<int>(std::floor((t - f.start) / f.bit));
  if (b < 0) b = 0;
  if (b > f.bits - 1) b = f.bits - 1;
  while (b + 1 < f.bits && f.start + (b + 1) * f.bit <= t) ++b;
  while (b > 0 && f.start + b * f.bit > t) --b;
  return b;
}

bool LineWaveform::level(double t) const {
  const size_t i = first_not_ended(t);
  if (i == frames_.size() || t < frames_[i].start) return true;  // idle: high
  const Frame& f = frames_[i];
  return (f.levels >> bit_index(f, t)) & 1;
}

// A frame's start is always a fall: before it the line is idle or in a stop bit, both high.
double LineWaveform::next_fall_after(double t) const {
  for (size_t i = first_not_ended(t); i < frames_.size(); ++i) {
    const Frame& f = frames_[i];
    if (f.start > t) return f.start;
    for (int b = 1; b < f.bits; ++b) {
      const bool falls = ((f.levels >> (b - 1)) & 1) && !((f.levels >> b) & 1);
      const double edge = f.start + b * f.bit;
      if (falls && edge > t) return edge;
    }
  }
  return kNever;
}

void LineWaveform::release_after(double t) {
  while (!frames_.empty() && frames_.back().start >= t) frames_.pop_back();
  if (frames_.empty() || frames_.back().end() <= t) return;
  Frame& f = frames_.back();
  for (int b = bit_index(f, t) + 1; b < f.bits; ++b) f.levels |= static_cast<uint16_t>(1u << b);
}

void LineWaveform::forget_before(double t) {
  while (!frames_.empty() && frames_.front().end() < t) frames_.pop_front();
}

// ---- AsyncReceiver --------------------------------------------------------------------------

void AsyncReceiver::enable(double t) {
  state_ = State::kHunting;
  hunt_from_ = t;
  last_sample_ = true;
}

double AsyncReceiver::tick_at_or_after(double t) const {
  const double ts = config_.sample_period;
  double tick = config_.origin + std::ceil((t - config_.origin) / ts) * ts;
  if (tick < t) tick += ts;  // rounding
  else if (tick - ts >= t) tick -= ts;
  return tick;
}

// Sample 1 of the next start bit: the first sample that reads low after one that read high.
// The sampled level can only change at the first sample after an edge of the line.
double AsyncReceiver::find_start(const LineWaveform& line) const {
  const double first = tick_at_or_after(hunt_from_);
  if (last_sample_ && !line.level(first)) return first;
  for (double edge = line.next_fall_after(first); edge != kNever; edge = line.next_fall_after(edge)) {
    const double t = tick_at_or_after(edge);  // > first, so t − period is a sample of this hunt
    if (!line.level(t) && line.level(t - config_.sample_period)) return t;
  }
  return kNever;
}

// The first of the three centre samples of bit `bit` (0 = the start bit) of a frame whose
// sample 1 is sample1: sample n of bit b is taken at sample1 + (b·S + n − 1)·period.
double AsyncReceiver::vote_sample(const SamplerConfig& c, double sample1, int bit) {
  return sample1 + (bit * c.samples_per_bit + c.first_vote() - 1) * c.sample_period;
}

double AsyncReceiver::frame_done(const SamplerConfig& c, double sample1) {
  return vote_sample(c, sample1, c.format.stop_index()) + 2 * c.sample_period;
}

bool AsyncReceiver::vote(const LineWaveform& line, double first_sample, double ts) {
  const int highs = line.level(first_sample) + line.level(first_sample + ts) + line.level(first_sample + 2 * ts);
  return highs >= 2;
}

double AsyncReceiver::next_event(const LineWaveform& line) const {
  switch (state_) {
    case State::kOff:
      return kNever;
    case State::kHunting: {
      const double s1 = find_start(line);
      return s1 == kNever ? kNever : vote_sample(config_, s1, 0) + 2 * config_.sample_period;
    }
    case State::kFrame:
      return frame_done(frame_config_, sample1_);
  }
  return kNever;
}

AsyncReceiver::Event AsyncReceiver::step(const LineWaveform& line) {
  Event ev;
  if (state_ == State::kHunting) {
    const double s1 = find_start(line);
    const double first = vote_sample(config_, s1, 0);
    ev.t = first + 2 * config_.sample_period;
    if (!vote(line, first, config_.sample_period)) {  // §19.8.1: a low majority makes it a valid start bit
      ev.kind = Kind::kStart;
      state_ = State::kFrame;
      frame_config_ = config_;
      sample1_ = s1;
    } else {  // a spike: look for the next high-to-low transition
      ev.kind = Kind::kSpike;
      hunt_from_ = ev.t + config_.sample_period;
      last_sample_ = true;  // the majority was high
    }
    return ev;
  }
  const SamplerConfig& c = frame_config_;
  const FrameFormat& f = c.format;
  auto bit = [&](int b) { return vote(line, vote_sample(c, sample1_, b), c.sample_period); };
  ev.kind = Kind::kFrame;
  for (int i = 0; i < f.data_bits; ++i) ev.data |= static_cast<uint8_t>(bit(1 + i) << i);
  if (f.parity != Parity::kNone) ev.parity_error = bit(1 + f.data_bits) != parity_bit(ev.data, f);
  ev.frame_error = !bit(f.stop_index());  // only the first stop bit is checked (§19.8.2)
  ev.t = frame_done(c, sample1_);
  state_ = State::kHunting;
  hunt_from_ = ev.t + c.sample_period;
  // The level the next start bit must fall from is the stop bit's voted one, not its last
  // sample: a fast sender's next start bit may already have begun at that sample, and §19.8.3's
  // Rfast, which only needs the middle vote sample inside the stop bit, counts that as received.
  last_sample_ = !ev.frame_error;
  return ev;
}

double AsyncReceiver::needed_from() const {
  switch (state_) {
    case State::kOff:
      return kNever;
    case State::kHunting:
      return hunt_from_;
    case State::kFrame:
      return sample1_;
  }
  return kNever;
}

}  // namespace cart2d
