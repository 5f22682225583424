// Settings <-> EEPROM without blocking the control loop. An EEPROM byte write takes ~3.3 ms,
// so a whole record would stall the loop for ~300 ms: SAVE only notes what to write, and
// poll() from the main loop writes one changed byte whenever the EEPROM is ready. The bytes
// come from the live settings (no 82-byte copy in RAM); if they change mid-write, the save
// starts over, so the record on the chip is always one consistent set.
#pragma once

#include <stdint.h>

#include "settings.hpp"  // Settings, record

namespace core {

// The board's EEPROM, as three plain functions (no virtual calls, no vtable in RAM).
struct EepromPort {
  bool (*ready)();
  uint8_t (*read)(uint16_t address);
  void (*write)(uint16_t address, uint8_t value);  // starts a write; ready() says when done
};

class SettingsStore {
 public:
  constexpr explicit SettingsStore(const EepromPort& port) : port_(port) {}

  void save(const Settings& settings);
  // Loads into `settings` if the stored record (or the one being written) is valid.
  record::Verdict load(Settings& settings);
  // Writes at most one byte; call from the main loop.
  void poll();
  // True until the last byte of the record has been written.
  bool busy() const { return source_ != nullptr || !port_.ready(); }

 private:
  const EepromPort& port_;
  const Settings* source_ = nullptr;  // the settings being saved; null when idle
  uint16_t crc_ = 0;
  uint8_t version_ = 0;  // source_->version() when the save (re)started
  uint8_t next_ = 0;     // next record byte to write
};

}  // namespace core
