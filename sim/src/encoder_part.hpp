// One RI-32 encoder wired to the MCU: its quadrature outputs (quadrature.hpp) drive channel A
// (an INT0/INT1 pin) and channel B at the exact cycle of each edge, through a simavr cycle timer,
// so the firmware's ANY-edge interrupt fires when it would on the robot.
#pragma once

#include <cstdint>
#include <vector>

#include "pin.hpp"
#include "quadrature.hpp"
#include "rng.hpp"

struct avr_t;

namespace cart2d {

class PinDriver;

class EncoderPart {
 public:
  EncoderPart(avr_t* avr, PinDriver* driver, PinRef a, PinRef b, long pulses_per_rev, bool b_high_on_rise_is_forward,
              uint64_t seed, uint64_t stream);

  // Turns the wheel by delta_rad over cycles [c0, c0 + n) and schedules the edges.
  void advance(double delta_rad, uint64_t c0, uint64_t n, const QuadratureFaults& faults);
  // Applies every edge still pending (their time has come or is being overtaken).
  void flush();
  // After avr_reset() cleared all cycle timers.
  void rearm_after_reset();

  uint64_t edges_emitted() const { return edges_emitted_; }  // A and B
  uint64_t a_edges_emitted() const { return a_edges_emitted_; }
  int64_t state_count() const { return encoder_.state_count(); }

 private:
  static uint64_t on_timer(avr_t* avr, uint64_t when, void* param);
  void apply(const QuadratureEdge& e);
  void schedule();

  avr_t* avr_;
  PinDriver* driver_;
  PinRef a_, b_;
  QuadratureEncoder encoder_;
  Rng rng_;
  std::vector<QuadratureEdge> pending_;
  size_t next_ = 0;
  uint64_t edges_emitted_ = 0;
  uint64_t a_edges_emitted_ = 0;
};

}  // namespace cart2d
