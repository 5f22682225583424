// Sleep, the watchdog, the reset flags, and the C++ runtime hooks a bare avr-libc build needs.
#pragma once

#include <stdint.h>

#include "retained.hpp"  // core::RetainedState

namespace board {
namespace system {

// Sleep in IDLE mode (timers and UART keep running) unless `work_pending` says otherwise.
// Interrupts are checked and sleep entered atomically, so a wake-up cannot be missed.
void sleep_unless(bool (*work_pending)());

// The chip's reset flags at this boot (MCUSR bits 0..3: PORF, EXTRF, BORF, WDRF), or, when
// MCUSR reads 0 because Optiboot cleared it, core::kMcusrClearedByBootloader (core/retained.hpp
// then tells what it can from the RAM).
uint8_t reset_flags();
// RAM that the C runtime does not clear: it survives external and watchdog resets.
core::RetainedState& retained();

// The watchdog in system-reset mode with a 64 ms timeout (WDTO_60MS: 8K cycles of the 128 kHz
// watchdog oscillator). Fed only after a completed control tick: a main loop that hangs stops
// feeding it, and the reset that follows leaves every pin floating (the H-bridges' pull-downs
// turn the motors off).
void watchdog_start();
void watchdog_feed();
// Lets the watchdog reset the MCU at its shortest timeout (COMMAND_REBOOT).
[[noreturn]] void reboot();

}  // namespace system
}  // namespace board
