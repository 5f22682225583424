#include "settings.hpp"

#include <string.h>  // memcpy

#include "crc16.hpp"           // crc16_mcrf4xx
#include "flash.hpp"           // CORE_FLASH, flash_read_float
#include "num.hpp"             // is_finite
#include "protocol_table.hpp"  // proto::Reason

namespace core {

#define CART2D_MIN(id, name, min, max, def) min,
#define CART2D_MAX(id, name, min, max, def) max,
#define CART2D_DEFAULT(id, name, min, max, def) def,
static const float kMin[setting::kCount] CORE_FLASH = {CART2D_SETTINGS(CART2D_MIN)};
static const float kMax[setting::kCount] CORE_FLASH = {CART2D_SETTINGS(CART2D_MAX)};
static const float kDefault[setting::kCount] CORE_FLASH = {CART2D_SETTINGS(CART2D_DEFAULT)};
#undef CART2D_MIN
#undef CART2D_MAX
#undef CART2D_DEFAULT

float Settings::min_value(uint8_t id) { return flash_read_float(&kMin[id]); }
float Settings::max_value(uint8_t id) { return flash_read_float(&kMax[id]); }
float Settings::default_value(uint8_t id) { return flash_read_float(&kDefault[id]); }

void Settings::reset_to_defaults() {
  for (uint8_t id = 0; id < setting::kCount; ++id) value_[id] = default_value(id);
  ++version_;
}

void Settings::assign(const float* values) {
  memcpy(value_, values, sizeof value_);
  ++version_;
}

bool Settings::acceptable(uint8_t id, float value) {
  return id < setting::kCount && is_finite(value) && value >= min_value(id) && value <= max_value(id);
}

uint8_t Settings::set(uint8_t id, float value) {
  if (id >= setting::kCount) return proto::REASON_OUT_OF_RANGE;
  if (!is_finite(value)) return proto::REASON_NOT_FINITE;
  if (!acceptable(id, value)) return proto::REASON_OUT_OF_RANGE;
  value_[id] = value;
  ++version_;
  return 0;
}

namespace record {

static uint8_t header_byte(uint8_t seq, uint8_t i) {
  switch (i) {
    case 0: return kMagic & 0xFF;
    case 1: return kMagic >> 8;
    case 2: return setting::kLayoutHash & 0xFF;
    case 3: return setting::kLayoutHash >> 8;
    case 4: return setting::kCount;
    default: return seq;
  }
}

uint8_t byte_at(const Settings& settings, uint8_t seq, uint16_t crc, uint8_t i) {
  if (i < kHeaderSize) return header_byte(seq, i);
  if (i < kSize - 2) return reinterpret_cast<const uint8_t*>(settings.raw())[i - kHeaderSize];
  return i == kSize - 2 ? crc & 0xFF : crc >> 8;
}

uint16_t crc_of(const Settings& settings, uint8_t seq) {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < kSize - 2; ++i) crc = crc16_update(crc, byte_at(settings, seq, 0, i));
  return crc;
}

// The checks both formats share: not erased, magic, table, CRC, every value in range.
static Verdict check(const uint8_t* in, uint8_t size, uint8_t header, uint16_t magic, Settings* settings) {
  bool blank = true;
  for (uint8_t i = 0; i < size; ++i) blank = blank && in[i] == 0xFF;
  if (blank) return Verdict::kBlank;
  const uint16_t crc = in[size - 2] | (in[size - 1] << 8);
  const uint16_t stored_magic = in[0] | (in[1] << 8);
  const uint16_t layout = in[2] | (in[3] << 8);
  if (stored_magic != magic || layout != setting::kLayoutHash || in[4] != setting::kCount ||
      crc != crc16_mcrf4xx(in, size - 2))
    return Verdict::kCorrupt;
  float values[setting::kCount];
  memcpy(values, in + header, sizeof values);
  for (uint8_t id = 0; id < setting::kCount; ++id)
    if (!Settings::acceptable(id, values[id])) return Verdict::kCorrupt;
  if (settings) settings->assign(values);
  return Verdict::kValid;
}

Verdict decode(const uint8_t* in, Settings* settings, uint8_t* seq) {
  const Verdict verdict = check(in, kSize, kHeaderSize, kMagic, settings);
  if (verdict == Verdict::kValid) *seq = in[kHeaderSize - 1];
  return verdict;
}

Verdict decode_legacy(const uint8_t* in, Settings* settings) {
  return check(in, kLegacySize, kLegacyHeaderSize, kLegacyMagic, settings);
}

}  // namespace record
}  // namespace core
