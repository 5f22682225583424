// Firmware settings, addressed by the stable ids of config/robot.toml, and their EEPROM record.
#pragma once

#include <stdint.h>

#include "robot_params.hpp"  // params::settings

namespace core {

namespace setting = params::settings;

class Settings {
 public:
  Settings() { reset_to_defaults(); }
  void reset_to_defaults();

  float get(uint8_t id) const { return value_[id]; }
  // Range-checked write; returns a proto::Reason, 0 when applied.
  uint8_t set(uint8_t id, float value);
  // True when `value` is finite and within the setting's range.
  static bool acceptable(uint8_t id, float value);
  static float min_value(uint8_t id);
  static float max_value(uint8_t id);
  static float default_value(uint8_t id);

  const float* raw() const { return value_; }
  void assign(const float* values);
  // Changes whenever a value does: lets a background save notice a change mid-write.
  uint8_t version() const { return version_; }

 private:
  float value_[setting::kCount];
  uint8_t version_ = 0;
};

// EEPROM records: magic, layout hash (ids and names of the table), count, sequence number,
// values, CRC-16. A table change invalidates old records instead of loading values into the
// wrong slots. Two slots are written in turn, each save into the one not holding the newest
// valid record, with the next sequence number: a save cut short by a reset (a byte takes 3.4 ms,
// a record ~290 ms) leaves a record that fails its CRC, and the previous one still loads.
namespace record {
constexpr uint16_t kMagic = 0xC2D3;  // format 2 (firmware 0.2): sequence number, two slots
constexpr uint8_t kHeaderSize = 6;   // magic (2), layout hash (2), count (1), sequence (1)
constexpr uint8_t kSize = kHeaderSize + setting::kCount * sizeof(float) + 2;
constexpr uint8_t kSlots = 2;
constexpr uint16_t kSlotStride = 0x80;
static_assert(kSize <= kSlotStride, "a record must fit its slot");
constexpr uint16_t slot_address(uint8_t slot) { return 0x100 + slot * kSlotStride; }

// Format 1 (firmware 0.1): one record at address 0 without a sequence number. Read when no
// format-2 record is valid, so an update keeps a calibration; never written.
constexpr uint16_t kLegacyMagic = 0xC2D2;
constexpr uint16_t kLegacyAddress = 0;
constexpr uint8_t kLegacyHeaderSize = 5;
constexpr uint8_t kLegacySize = kLegacyHeaderSize + setting::kCount * sizeof(float) + 2;

// Byte i of the record of `settings` with sequence `seq` and CRC `crc` (see crc_of).
uint8_t byte_at(const Settings& settings, uint8_t seq, uint16_t crc, uint8_t i);
uint16_t crc_of(const Settings& settings, uint8_t seq);

enum class Verdict : uint8_t { kValid, kBlank, kCorrupt };
// Checks a record; when valid and every value in range, gives its sequence number and (unless
// `settings` is null) copies its values into *settings.
Verdict decode(const uint8_t* in, Settings* settings, uint8_t* seq);
Verdict decode_legacy(const uint8_t* in, Settings* settings);
// Whether sequence number a was written after b (serial-number arithmetic, RFC 1982).
inline bool newer(uint8_t a, uint8_t b) { return static_cast<uint8_t>(a - b - 1) < 127; }
}  // namespace record

}  // namespace core
