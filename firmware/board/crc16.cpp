#include "crc16.hpp"

#include <util/crc16.h>  // _crc_ccitt_update

namespace core {

uint16_t crc16_update(uint16_t crc, uint8_t byte) { return _crc_ccitt_update(crc, byte); }

}  // namespace core
