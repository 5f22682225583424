// Settings <-> EEPROM without blocking the control loop. An EEPROM byte write takes 3.4 ms, so
// a whole record would stall the loop for ~290 ms: SAVE only notes what to write, and poll()
// from the main loop writes one changed byte whenever the EEPROM is ready. The bytes come from
// the live settings (no 84-byte copy in RAM); if they change mid-write, the record is started
// over, so what lands on the chip is always one consistent set. Records alternate between two
// slots (settings.hpp, record::): a reset in the middle of a save leaves the previous one.
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
  // Loads the newest valid record into `settings` (or the values being saved, if a save is
  // under way). kBlank / kCorrupt leave `settings` unchanged.
  record::Verdict load(Settings& settings);
  // At most one byte written per call; call from the main loop.
  void poll();
  // True until the last byte of the record has been written.
  bool busy() const { return source_ != nullptr || !port_.ready(); }

 private:
  enum class Phase : uint8_t { kCompare, kWrite };
  // Reads the record in `slot`; kValid gives its sequence number (and values, unless null).
  record::Verdict read_slot(uint8_t slot, Settings* settings, uint8_t* seq) const;
  // True when `slot` already holds exactly the record of `settings` with sequence `seq`.
  bool holds(uint8_t slot, const Settings& settings, uint8_t seq) const;
  void start_writing();
  uint16_t address(uint8_t i) const { return record::slot_address(target_) + i; }

  static constexpr uint8_t kNone = 0xFF;

  const EepromPort& port_;
  const Settings* source_ = nullptr;  // the settings being saved; null when idle
  uint16_t crc_ = 0;
  uint8_t version_ = 0;  // source_->version() when the record was (re)started
  uint8_t next_ = 0;     // next record byte to write
  Phase phase_ = Phase::kCompare;
  uint8_t newest_ = kNone;  // slot of the newest valid record on the chip
  uint8_t seq_ = 0;         // its sequence number
  uint8_t target_ = 0;      // slot being written
};

}  // namespace core
