// The host has one address space: tables marked CORE_FLASH are ordinary constants.
#include "flash.hpp"

namespace core {

float flash_read_float(const float* address) { return *address; }
unsigned char flash_read_byte(const unsigned char* address) { return *address; }

}  // namespace core
