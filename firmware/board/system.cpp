#include "system.hpp"

#include <avr/interrupt.h>  // cli, sei
#include <avr/io.h>         // MCUSR
#include <avr/sleep.h>      // sleep_cpu
#include <avr/wdt.h>        // wdt_enable, wdt_disable

namespace board {
namespace system {

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

void reboot() {
  cli();
  wdt_enable(WDTO_15MS);
  for (;;) {
  }
}

}  // namespace system
}  // namespace board

// A watchdog reset leaves the watchdog running with its shortest timeout: stop it before
// anything else, or the firmware would reset forever (avr-libc's wdt.h recommendation).
extern "C" void disable_watchdog_at_boot() __attribute__((naked, used, section(".init3")));
extern "C" void disable_watchdog_at_boot() {
  MCUSR = 0;
  wdt_disable();
}

