#include "encoders.hpp"

#include <avr/interrupt.h>  // ISR
#include <util/atomic.h>    // ATOMIC_BLOCK

#include "io.hpp"  // read_pin, make_input

namespace board {
namespace encoders {

namespace pins = params::pins;
namespace enc = params::encoders;

static volatile int16_t left_counts;   // since the last latch, written by the encoder ISRs
static volatile int16_t right_counts;
static volatile int16_t left_latched;  // latched by the tick, taken by the main loop
static volatile int16_t right_latched;

void init() {
  make_input(pins::left_enc_a, false);  // 12 V push-pull outputs through dividers: no pull-ups
  make_input(pins::left_enc_b, false);
  make_input(pins::right_enc_a, false);
  make_input(pins::right_enc_b, false);
  // Any logical change of A: both edges are counted (x2 decoding). Rising-only counting, as in
  // the seed, gains a count every time a wheel dithers across an edge.
  EICRA = (1 << ISC10) | (1 << ISC00);
  EIFR = (1 << INTF1) | (1 << INTF0);
  EIMSK = (1 << INT1) | (1 << INT0);
}

// Interrupts are off in an ISR (no nesting on the AVR): the encoder ISRs cannot interleave.
void latch_counts() {
  left_latched += left_counts;
  right_latched += right_counts;
  left_counts = 0;
  right_counts = 0;
}

void take_counts(int16_t& left, int16_t& right) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    left = left_latched;
    right = right_latched;
    left_latched = 0;
    right_latched = 0;
  }
}

// After an edge of A: forwards when (A == B) matches the mounting's "B high on A's rising edge
// is forwards" (robot.toml); on a falling edge B is the opposite for the same direction.
static inline bool forwards(bool a, bool b, bool b_high_on_rise_is_forward) {
  return (a == b) == b_high_on_rise_is_forward;
}

}  // namespace encoders
}  // namespace board

using namespace board;

// Kept minimal (an increment or a decrement): at 1 m/s each fires ~15 000 times a second.
ISR(INT0_vect) {
  if (encoders::forwards(read_pin(encoders::pins::left_enc_a), read_pin(encoders::pins::left_enc_b),
                         encoders::enc::left_b_high_on_rise_is_forward))
    ++encoders::left_counts;
  else
    --encoders::left_counts;
}

ISR(INT1_vect) {
  if (encoders::forwards(read_pin(encoders::pins::right_enc_a), read_pin(encoders::pins::right_enc_b),
                         encoders::enc::right_b_high_on_rise_is_forward))
    ++encoders::right_counts;
  else
    --encoders::right_counts;
}
