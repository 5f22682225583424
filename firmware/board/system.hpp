// Sleep, watchdog reset, and the C++ runtime hooks a bare avr-libc build needs.
#pragma once

namespace board {
namespace system {

// Sleep in IDLE mode (timers and UART keep running) unless `work_pending` says otherwise.
// Interrupts are checked and sleep entered atomically, so a wake-up cannot be missed.
void sleep_unless(bool (*work_pending)());
[[noreturn]] void reboot();

}  // namespace system
}  // namespace board
