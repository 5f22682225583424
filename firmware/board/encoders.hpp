// The two RI-32 encoders: channel A on INT0/INT1 (any edge), channel B read in the ISR.
#pragma once

#include <stdint.h>

namespace board {
namespace encoders {

void init();
// Called by the tick interrupt: moves the counts so far into the tick's sample, so that each
// tick's counts cover exactly one tick period however late the main loop takes them (a loop
// busy with a path-upload frame took them up to 808 us late: +-10 % on a one-tick speed).
void latch_counts();
// The counts latched since the previous call, read and cleared atomically; positive = forwards.
// Ticks the loop missed add up rather than being lost.
void take_counts(int16_t& left, int16_t& right);

}  // namespace encoders
}  // namespace board
