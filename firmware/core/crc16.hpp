// CRC-16/MCRF4XX: polynomial 0x1021 reflected (0x8408), init 0xFFFF, no final XOR.
// The same as avr-libc's _crc_ccitt_update; check value "123456789" -> 0x6F91.
#pragma once

#include <stdint.h>

namespace core {

// One byte into the CRC. The platform provides it: board/ uses avr-libc's assembler version
// (about twice as fast on the AVR), host/ the portable form below; the spec's test vectors
// pin both to the same results.
uint16_t crc16_update(uint16_t crc, uint8_t byte);

// The byte-at-a-time form without a table (the avr-libc documentation's C equivalent).
inline uint16_t crc16_update_portable(uint16_t crc, uint8_t byte) {
  byte ^= crc & 0xFF;
  byte ^= byte << 4;
  return ((static_cast<uint16_t>(byte) << 8) | (crc >> 8)) ^ static_cast<uint8_t>(byte >> 4) ^
         (static_cast<uint16_t>(byte) << 3);
}

inline uint16_t crc16_mcrf4xx(const uint8_t* data, uint16_t n, uint16_t crc = 0xFFFF) {
  for (uint16_t i = 0; i < n; ++i) crc = crc16_update(crc, data[i]);
  return crc;
}

}  // namespace core
