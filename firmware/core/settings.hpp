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

// EEPROM record: magic, layout hash (ids and names of the table), count, values, CRC-16.
// A table change invalidates old records instead of loading values into the wrong slots.
namespace record {
constexpr uint16_t kMagic = 0xC2D2;
constexpr uint16_t kAddress = 0;
constexpr uint8_t kHeaderSize = 5;  // magic (2), layout hash (2), count (1)
constexpr uint8_t kSize = kHeaderSize + setting::kCount * sizeof(float) + 2;

// Byte i of the record of `settings` whose CRC is `crc` (see crc_of).
uint8_t byte_at(const Settings& settings, uint16_t crc, uint8_t i);
uint16_t crc_of(const Settings& settings);

enum class Verdict : uint8_t { kValid, kBlank, kCorrupt };
// Check a record and, when valid and every value in range, copy it into `settings`.
Verdict decode(const uint8_t* in, Settings& settings);
}  // namespace record

}  // namespace core
