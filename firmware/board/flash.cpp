#include "flash.hpp"

#include <avr/pgmspace.h>  // pgm_read_float

namespace core {

float flash_read_float(const float* address) { return pgm_read_float(address); }
unsigned char flash_read_byte(const unsigned char* address) { return pgm_read_byte(address); }

}  // namespace core
