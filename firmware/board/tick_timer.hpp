// Timer2 in CTC mode: the 125 Hz control tick, and a clock to measure how busy a tick was.
#pragma once

#include <stdint.h>

namespace board {
namespace tick_timer {

constexpr uint8_t kCountsPerTick = 125;  // 16 MHz / 1024 / 125 = 125 Hz; one count = 64 us

void init();
// True once per elapsed tick; counts ticks that arrived while the previous one was pending.
bool take_tick();
bool pending();
uint16_t overruns();
// Timer counts since the current tick began (0..124).
uint8_t elapsed_counts();

}  // namespace tick_timer
}  // namespace board
