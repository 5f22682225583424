#include "crc16.hpp"

namespace core {

uint16_t crc16_update(uint16_t crc, uint8_t byte) { return crc16_update_portable(crc, byte); }

}  // namespace core
