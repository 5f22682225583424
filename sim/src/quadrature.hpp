// Quadrature signal generator for one RI-32 encoder: turns the wheel's angle into channel A/B
// levels and the exact CPU cycle of every edge.
//
// The disc has `pulses_per_rev` slots; A and B are square waves 90° apart, so one revolution has
// 4·pulses_per_rev states (1000 pulses → 2000 A edges + 2000 B edges = 4000). The state index
// is floor(e) with e the position in quarter-pulses; each integer crossing is one edge. Which
// channel leads on forward motion comes from robot.toml: b_high_on_rise_is_forward = false means
// B is low when A rises going forward (A leads: AB = 00→10→11→01), true means B leads
// (AB = 00→01→11→10). Edges inside a physics step are placed by linear interpolation of the
// angle, i.e. constant wheel speed within the step.
#pragma once

#include <cstdint>
#include <vector>

#include "rng.hpp"
#include "robot_params.hpp"  // params::sim, params::control

namespace cart2d {

struct QuadratureEdge {
  uint64_t cycle = 0;  // absolute CPU cycle at which the outputs take these levels
  bool a = false;
  bool b = false;
};

struct QuadratureFaults {
  double miss_prob = 0.0;         // chance that an A pulse is lost (A stays low through it)
  double noise_hz = 0.0;          // rate of spurious A spikes
  // Width of a spike: robot.toml's encoder_glitch_s in CPU cycles, rounded.
  uint64_t glitch_cycles = static_cast<uint64_t>(params::sim::encoder_glitch_s * params::control::f_cpu_hz + 0.5);
};

class QuadratureEncoder {
 public:
  QuadratureEncoder(long pulses_per_rev, bool b_high_on_rise_is_forward, double cycles_per_s);

  // Turns the wheel by delta_rad (positive = rolling forwards) during cycles [c0, c0 + n), and
  // appends the resulting output changes, in order, to *out.
  void advance(double delta_rad, uint64_t c0, uint64_t n, const QuadratureFaults& faults, Rng& rng,
               std::vector<QuadratureEdge>* out);

  bool a() const { return out_a_; }
  bool b() const { return out_b_; }
  // Signed count of true quadrature states passed since construction (4 per pulse).
  int64_t state_count() const { return state_; }
  // Levels of a given state without faults (exposed for tests).
  void levels(int64_t state, bool* a, bool* b) const;

 private:
  void emit(uint64_t cycle, std::vector<QuadratureEdge>* out);

  double quarters_per_rad_;
  bool b_leads_;
  double cycles_per_s_;
  double e_ = 0.5;       // position in quarter pulses; starts mid-state so no edge is pending
  int64_t state_ = 0;    // floor(e_)
  bool suppressed_ = false;  // current A pulse lost (missed-pulse fault)
  bool glitch_ = false;      // inside a noise spike: A inverted
  double next_glitch_s_ = -1.0;
  bool out_a_ = false, out_b_ = false;
};

}  // namespace cart2d
