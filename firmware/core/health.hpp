// What the board's main loop measures about itself, reported by COMMAND_STATUS.
#pragma once

#include <stdint.h>

namespace core {

struct Health {
  uint32_t ticks = 0;          // control ticks since reset (8 ms each)
  uint16_t loop_overruns = 0;  // ticks that started before the previous one had finished
  uint8_t cpu_load_pct = 0;    // busy share of the last second
  uint8_t cpu_max_pct = 0;     // busiest tick of the last second, share of 8 ms
  uint16_t rx_errors = 0;      // packets dropped for a bad LEN or CRC, or truncated
  uint16_t replies_dropped = 0;  // replies the transmit buffer had no room for
  uint8_t reset_cause = 0;     // proto::ResetCause bits of the last reset
  uint16_t boot_count = 1;     // boots since the RAM was last lost (core/retained.hpp)
};

constexpr uint8_t kFirmwareMajor = 0;
constexpr uint8_t kFirmwareMinor = 1;
#ifdef CART2D_FIRMWARE_PATCH  // a test build that must answer with another version (tests/link/test_flash_optiboot.py)
constexpr uint8_t kFirmwarePatch = CART2D_FIRMWARE_PATCH;
#else
constexpr uint8_t kFirmwarePatch = 0;
#endif

}  // namespace core
