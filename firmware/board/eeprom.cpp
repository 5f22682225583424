#include "eeprom.hpp"

#include <avr/eeprom.h>     // eeprom_read_byte, eeprom_write_byte
#include <avr/interrupt.h>  // ISR
#include <avr/io.h>         // EECR

namespace board {
namespace eeprom {

static bool ready() { return !(EECR & (1 << EEPE)); }

static uint8_t read(uint16_t address) { return eeprom_read_byte(reinterpret_cast<const uint8_t*>(address)); }

// Only called when ready(): avr-libc starts the write and returns without waiting for it.
static void write(uint16_t address, uint8_t value) {
  eeprom_write_byte(reinterpret_cast<uint8_t*>(address), value);
  EECR |= (1 << EERIE);
}

const core::EepromPort kPort = {ready, read, write};

}  // namespace eeprom
}  // namespace board

// The write finished: the interrupt only exists to wake the main loop from sleep.
ISR(EE_READY_vect) { EECR &= ~(1 << EERIE); }
