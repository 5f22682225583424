// Constant tables that should live in program memory. On the AVR, data in RAM costs from the
// 2 KiB; the build defines CORE_FLASH as the progmem attribute and board/ reads such tables
// with pgm_read; on the host CORE_FLASH is empty and host/ reads them directly.
#pragma once

#ifndef CORE_FLASH
#define CORE_FLASH
#endif

namespace core {

float flash_read_float(const float* address);
unsigned char flash_read_byte(const unsigned char* address);

}  // namespace core
