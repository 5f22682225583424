// USART0 with interrupt-driven ring buffers: the protocol path never waits for the line.
#pragma once

#include <stdint.h>

namespace board {
namespace uart {

void init(uint32_t baud);
bool read(uint8_t& byte);
bool rx_available();
uint8_t tx_free();
// Queues n bytes, or none if they do not fit (false).
bool write(const uint8_t* data, uint8_t n);
// Everything queued has left the shift register.
bool tx_done();
uint16_t rx_overflows();

}  // namespace uart
}  // namespace board
