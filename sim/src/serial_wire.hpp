// One direction of an asynchronous serial line, bit by bit: the frames a transmitter puts on
// the wire (each at its own start time and bit time, so two clocks that disagree are two
// waveforms) and a receiver that samples the wire the way the ATmega328P's USART does
// (datasheet DS40002061B §19.8 "Asynchronous Data Reception"). Times are CPU cycles of the
// simulated MCU, fractional where the other clock is not the MCU's. No simavr in here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>

namespace cart2d {

constexpr double kNever = std::numeric_limits<double>::infinity();

enum class Parity : uint8_t { kNone, kEven, kOdd };

// §19.4 "Frame Formats": a start bit (low), 5 to 8 data bits LSB first, an optional parity
// bit, one or two stop bits (high). Nine-bit characters are not modelled.
struct FrameFormat {
  int data_bits = 8;
  Parity parity = Parity::kNone;
  int stop_bits = 1;
  int bits() const { return 1 + data_bits + (parity == Parity::kNone ? 0 : 1) + stop_bits; }
  int stop_index() const { return 1 + data_bits + (parity == Parity::kNone ? 0 : 1); }
};

// The parity bit that goes with data (§19.4.1: even parity makes the number of ones even).
bool parity_bit(uint8_t data, const FrameFormat& format);

// The levels of one frame, bit i = the level during bit i (bit 0 = the start bit).
uint16_t frame_levels(uint8_t data, const FrameFormat& format);

// What one transmitter puts on an idle-high line, frame after frame.
class LineWaveform {
 public:
  struct Frame {
    double start = 0.0;  // cycle the start bit begins
    double bit = 1.0;    // cycles per bit
    uint16_t levels = 0;  // frame_levels()
    uint8_t bits = 10;
    double end() const { return start + bits * bit; }
  };

  // Frames must come in order and not overlap (a transmitter sends one at a time).
  void add(const Frame& frame);
  bool level(double t) const;
  // The first instant after t at which the line falls from high to low, or kNever.
  double next_fall_after(double t) const;
  // The transmitter lets go of the line at t (a reset): frames not begun are gone, and the one
  // on the line goes high after the bit it is in.
  void release_after(double t);
  // Frames that ended before t are of no use any more.
  void forget_before(double t);
  double end() const { return frames_.empty() ? 0.0 : frames_.back().end(); }
  size_t size() const { return frames_.size(); }

 private:
  // Index of the first frame that has not ended at t (frames_.size() if none).
  size_t first_not_ended(double t) const;
  static int bit_index(const Frame& f, double t);  // which bit of f is on the line at t

  std::deque<Frame> frames_;
};

// How a receiver samples: one sample every sample_period cycles at origin + k·sample_period,
// samples_per_bit per bit, majority of the three centre samples (§19.8.1, §19.8.2).
struct SamplerConfig {
  double sample_period = 17.0;  // cycles between samples (the baud rate generator's clock)
  int samples_per_bit = 8;      // 16, or 8 in double-speed mode (U2X)
  double origin = 0.0;          // a cycle at which a sample is taken
  FrameFormat format;
  // Samples 8, 9, 10 of 16 or 4, 5, 6 of 8 decide a bit; sample 1 is the start bit's first low one.
  int first_vote() const { return samples_per_bit / 2; }
};

// The receiver of §19.8: it waits for a high-to-low transition between two samples, checks the
// start bit with the three centre samples (a high majority rejects it as a spike), then decides
// every bit by majority at its centre, the first stop bit included (low: frame error). The next
// start bit may be detected from the sample after the stop bit's last vote on (§19.8.2, Fig. 19-7).
class AsyncReceiver {
 public:
  enum class Kind : uint8_t { kStart, kSpike, kFrame };
  struct Event {
    Kind kind = Kind::kSpike;
    double t = 0.0;  // the sample that decided it
    uint8_t data = 0;
    bool frame_error = false;
    bool parity_error = false;
  };

  // Used from the next start bit on; a frame being received keeps the settings it began with.
  void configure(const SamplerConfig& config) { config_ = config; }
  const SamplerConfig& config() const { return config_; }
  // Starts looking for a start bit at cycle t (the receiver's idle state is high).
  void enable(double t);
  void disable() { state_ = State::kOff; }
  bool enabled() const { return state_ != State::kOff; }

  // When the next event happens, given what is on the line so far, or kNever. Frames added to
  // the line later start after those already there, so a finite answer stays right.
  double next_event(const LineWaveform& line) const;
  // Takes the receiver to that event and reports it (next_event() must be finite).
  Event step(const LineWaveform& line);
  // The earliest instant whose level the receiver may still sample.
  double needed_from() const;

 private:
  enum class State : uint8_t { kOff, kHunting, kFrame };

  double tick_at_or_after(double t) const;
  double find_start(const LineWaveform& line) const;
  // True if two or three of the samples at first_sample, + period, + 2·period read high.
  static bool vote(const LineWaveform& line, double first_sample, double period);
  static double vote_sample(const SamplerConfig& c, double sample1, int bit);
  static double frame_done(const SamplerConfig& c, double sample1);

  State state_ = State::kOff;
  SamplerConfig config_;
  SamplerConfig frame_config_;  // latched at the start bit
  double hunt_from_ = 0.0;      // hunting: the first sample to look at
  bool last_sample_ = true;     // hunting: the level of the sample before it
  double sample1_ = 0.0;        // receiving: the start bit's first low sample
};

}  // namespace cart2d
