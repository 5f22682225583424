// The two RI-32 encoders: channel A on INT0/INT1 (any edge), channel B read in the ISR.
#pragma once

#include <stdint.h>

namespace board {
namespace encoders {

void init();
// Counts since the previous call, read and cleared atomically; positive = forwards.
void take_counts(int16_t& left, int16_t& right);

}  // namespace encoders
}  // namespace board
