// Errors on demand. All off by default (hbridge_pulldowns: fitted); random ones draw from seeded streams (rng.hpp), so a
// given seed and input reproduce the same run.
#pragma once

#include <cstdint>
#include <deque>
#include <string>

#include "json.hpp"
#include "rng.hpp"

namespace cart2d {

struct Faults {
  // Measuring wheels (odometry errors the firmware cannot see directly).
  double enc_radius_scale_l = 1.0;  // actual / nominal left measuring-wheel radius
  double enc_radius_scale_r = 1.0;  // actual / nominal right measuring-wheel radius
  double enc_track_error_m = 0.0;   // actual − nominal distance between the measuring wheels
  double enc_slip_l = 0.0;          // fraction of the rolled distance the left wheel fails to turn
  double enc_slip_r = 0.0;          // same, right
  double enc_miss_prob = 0.0;       // probability that a channel-A pulse is lost (both its edges)
  double enc_noise_hz = 0.0;        // spurious channel-A spikes per second, per encoder
  // UART, per byte; rx = towards the MCU, tx = from the MCU.
  double uart_rx_drop = 0.0;
  double uart_rx_corrupt = 0.0;  // one random bit flipped
  double uart_tx_drop = 0.0;
  double uart_tx_corrupt = 0.0;
  // Bursts on the line, both ways at once (a Bluetooth or Wi-Fi bridge's bad moments): a burst
  // begins on average 1 / uart_burst_hz s after the last one ended (a Poisson process), lasts
  // uart_burst_ms, and while it lasts each byte, either way, is lost with uart_burst_drop.
  double uart_burst_hz = 0.0;
  double uart_burst_ms = 0.0;
  double uart_burst_drop = 0.0;
  // Board: 1 = the LMD18200 inputs' pull-down resistors are fitted (the seed's schematic), 0 =
  // missing, so floating inputs (every MCU pin during a reset) read high: both bridges full on.
  double hbridge_pulldowns = 1.0;

  bool any_encoder_noise() const { return enc_miss_prob > 0.0 || enc_noise_hz > 0.0; }
};

// When the line's bursts are (Faults::uart_burst_*), drawn from their own seeded stream. Asked
// about simulated times in any order within a second of the latest asked: the two directions
// of the line ask about their own byte times, and a frame from the MCU may start ahead of now.
class BurstSchedule {
 public:
  void reseed(uint64_t seed);
  // Bursts of this rate and length from `now_s` on; unchanged values keep the schedule.
  void configure(double hz, double ms, double now_s);
  bool in_burst(double t_s);
  // Whether a byte on the line at t_s is lost to a burst (drawn only inside one).
  bool drops(double t_s, double drop_prob) { return in_burst(t_s) && bytes_.chance(drop_prob); }

 private:
  struct Burst {
    double start_s, end_s;
  };
  Rng times_, bytes_;
  double hz_ = 0.0, length_s_ = 0.0;
  double next_from_s_ = 0.0;  // the end of the last burst drawn: the next begins after it
  std::deque<Burst> bursts_;
};

// Applies the members of a "faults" control message. All-or-nothing: an unknown key or a value
// outside its range leaves *faults unchanged and says why. {"clear": true} first restores defaults.
bool apply_faults(const json::Value& msg, Faults* faults, std::string* error);

// The current faults as a JSON object.
std::string faults_json(const Faults& faults);

}  // namespace cart2d
