// Register access for the pins named in config/robot.toml. The port letter is a compile-time
// constant everywhere it is used, so these fold to single sbi/cbi/sbic instructions (forced:
// out of line they became a run-time switch on the port letter).
#pragma once

#include <avr/io.h>  // PORTx, DDRx, PINx

#include "robot_params.hpp"  // params::pins::Pin

namespace board {

using params::pins::Pin;

__attribute__((always_inline)) inline volatile uint8_t& port_of(const Pin& p) { return p.port == 'B' ? PORTB : (p.port == 'C' ? PORTC : PORTD); }
__attribute__((always_inline)) inline volatile uint8_t& ddr_of(const Pin& p) { return p.port == 'B' ? DDRB : (p.port == 'C' ? DDRC : DDRD); }
__attribute__((always_inline)) inline volatile uint8_t& pin_of(const Pin& p) { return p.port == 'B' ? PINB : (p.port == 'C' ? PINC : PIND); }

__attribute__((always_inline)) inline void make_output_low(const Pin& p) {
  port_of(p) &= static_cast<uint8_t>(~(1 << p.bit));
  ddr_of(p) |= static_cast<uint8_t>(1 << p.bit);
}
__attribute__((always_inline)) inline void make_input(const Pin& p, bool pull_up) {
  ddr_of(p) &= static_cast<uint8_t>(~(1 << p.bit));
  if (pull_up)
    port_of(p) |= static_cast<uint8_t>(1 << p.bit);
  else
    port_of(p) &= static_cast<uint8_t>(~(1 << p.bit));
}
__attribute__((always_inline)) inline void write_pin(const Pin& p, bool high) {
  if (high)
    port_of(p) |= static_cast<uint8_t>(1 << p.bit);
  else
    port_of(p) &= static_cast<uint8_t>(~(1 << p.bit));
}
__attribute__((always_inline)) inline bool read_pin(const Pin& p) { return pin_of(p) & (1 << p.bit); }

}  // namespace board
