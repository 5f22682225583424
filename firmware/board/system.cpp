#include "system.hpp"

#include <avr/interrupt.h>  // cli, sei
#include <avr/io.h>         // MCUSR
#include <avr/sleep.h>      // sleep_cpu
#include <avr/wdt.h>        // wdt_enable, wdt_disable, wdt_reset

namespace board {
namespace system {

// In .noinit: neither zeroed nor initialised by the C runtime, so they keep what the boot code
// below wrote, and `retained_state` what the last run left in it.
static uint8_t boot_flags __attribute__((section(".noinit")));
static core::RetainedState retained_state __attribute__((section(".noinit")));

void sleep_unless(bool (*work_pending)()) {
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  if (work_pending()) {
    sei();
    return;
  }
  sleep_enable();
  sei();  // the instruction after sei runs before any interrupt: no lost wake-up
  sleep_cpu();
  sleep_disable();
}

uint8_t reset_flags() { return boot_flags; }

core::RetainedState& retained() { return retained_state; }

void watchdog_start() { wdt_enable(WDTO_60MS); }

void watchdog_feed() { wdt_reset(); }

void reboot() {
  cli();
  wdt_enable(WDTO_15MS);
  for (;;) {
  }
}

}  // namespace system
}  // namespace board

using board::system::boot_flags;

// A watchdog reset leaves the watchdog running with its shortest timeout: stop it before
// anything else, or the firmware would reset forever (avr-libc's wdt.h recommendation). The
// flags are kept first. Without a bootloader MCUSR holds them. The Nano's Optiboot (4.4, the
// optiboot_atmega328.hex of the Arduino IDE and of Debian's arduino-core-avr) reads MCUSR into
// r24, clears it and jumps here through `clr r30; clr r31; ijmp` (optiboot.c, main and
// appStart): nothing passes the flags on (r2 holds whatever it held; only later Optiboot
// versions load it), so MCUSR reads 0 and the RAM has to tell (core/retained.cpp).
extern "C" void disable_watchdog_at_boot() __attribute__((naked, used, section(".init3")));
extern "C" void disable_watchdog_at_boot() {
  const uint8_t mcusr = MCUSR & 0x0F;
  MCUSR = 0;
  wdt_disable();
  boot_flags = mcusr ? mcusr : core::kMcusrClearedByBootloader;
}
