// How long the ATmega328P's self-programming takes. simavr 1.6 erases or writes a flash page the
// moment SPM executes and clears SPMCSR.SELFPRGEN at once (avr_flash.c); on the chip a page erase
// or a page write keeps SELFPRGEN set for 3.7-4.5 ms (datasheet DS40002061B §26.9.4, "Programming
// Time for Flash when Using SPM"), and a bootloader busy-waits on that bit before it answers the
// programmer. This module sits in front of simavr's own SPM handler, lets it do the work, and
// then keeps SELFPRGEN (and RWWSB) set for the programming time, so that an upload through
// Optiboot takes the time it takes on a Nano.
#pragma once

#include <cstdint>

extern "C" {
#include <sim_io.h>  // avr_io_t
}

struct avr_t;

namespace cart2d {

// The middle of the datasheet's 3.7-4.5 ms (the chip times it with its RC oscillator).
constexpr double kSpmPageTime_s = 4.1e-3;

struct SpmTiming {
  avr_io_t io;                    // first: simavr hands us the avr_io_t*
  avr_io_t* flash_io = nullptr;   // simavr's self-programming module ("flash")
  uint64_t busy_cycles = 0;
  uint64_t pages_erased = 0, pages_written = 0;

  // Registers in front of simavr's "flash" module; false if the core has none.
  bool attach(avr_t* avr, uint32_t f_cpu_hz);
};

}  // namespace cart2d
