// The ATmega328P's EEPROM as a core::EepromPort: byte writes are started and left to finish
// in the background (~3.3 ms each); the EE_READY interrupt wakes the loop for the next one.
#pragma once

#include "settings_store.hpp"  // core::EepromPort

namespace board {
namespace eeprom {

extern const core::EepromPort kPort;

}  // namespace eeprom
}  // namespace board
