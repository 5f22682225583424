#include "tick_timer.hpp"

#include <avr/interrupt.h>  // ISR
#include <avr/io.h>         // Timer2 registers

#include "encoders.hpp"       // latch_counts
#include "robot_params.hpp"  // params::control

namespace board {
namespace tick_timer {

static_assert(params::control::f_cpu_hz / 1024 / kCountsPerTick == params::control::tick_hz,
              "Timer2 prescaler and OCR2A must give the control rate");

static volatile bool tick_flag;
static volatile uint16_t overrun_count;

void init() {
  TCCR2A = (1 << WGM21);                              // CTC, TOP = OCR2A
  TCCR2B = (1 << CS22) | (1 << CS21) | (1 << CS20);   // clk / 1024
  OCR2A = kCountsPerTick - 1;
  TIMSK2 = (1 << OCIE2A);
}

bool take_tick() {
  if (!tick_flag) return false;
  tick_flag = false;  // a single byte: no atomic block needed
  return true;
}

bool pending() { return tick_flag; }

uint16_t overruns() {
  uint16_t n;
  const uint8_t sreg = SREG;
  cli();
  n = overrun_count;
  SREG = sreg;
  return n;
}

uint8_t elapsed_counts() { return TCNT2; }

}  // namespace tick_timer
}  // namespace board

// The tick's sampling instant: the encoder counts are latched here, not when the main loop
// gets round to the tick.
ISR(TIMER2_COMPA_vect) {
  board::encoders::latch_counts();
  if (board::tick_timer::tick_flag) ++board::tick_timer::overrun_count;  // the loop fell behind
  board::tick_timer::tick_flag = true;
}
