#include "settings_store.hpp"

namespace core {

void SettingsStore::save(const Settings& settings) {
  if (source_ == nullptr) phase_ = Phase::kCompare;
  source_ = &settings;
  version_ = settings.version();
  next_ = 0;
  if (phase_ == Phase::kWrite) crc_ = record::crc_of(settings, seq_ + 1);  // same slot, from the top
}

record::Verdict SettingsStore::read_slot(uint8_t slot, Settings* settings, uint8_t* seq) const {
  uint8_t stored[record::kSize];
  for (uint8_t i = 0; i < record::kSize; ++i) stored[i] = port_.read(record::slot_address(slot) + i);
  return record::decode(stored, settings, seq);
}

bool SettingsStore::holds(uint8_t slot, const Settings& settings, uint8_t seq) const {
  const uint16_t crc = record::crc_of(settings, seq);
  for (uint8_t i = 0; i < record::kSize; ++i)
    if (port_.read(record::slot_address(slot) + i) != record::byte_at(settings, seq, crc, i)) return false;
  return true;
}

record::Verdict SettingsStore::load(Settings& settings) {
  if (source_ != nullptr) {  // the EEPROM is about to hold exactly these values
    if (source_ != &settings) settings.assign(source_->raw());
    return record::Verdict::kValid;
  }
  record::Verdict worst = record::Verdict::kBlank;
  newest_ = kNone;
  for (uint8_t slot = 0; slot < record::kSlots; ++slot) {
    uint8_t seq = 0;
    const record::Verdict v = read_slot(slot, nullptr, &seq);
    if (v == record::Verdict::kCorrupt) worst = v;
    if (v == record::Verdict::kValid && (newest_ == kNone || record::newer(seq, seq_))) {
      newest_ = slot;
      seq_ = seq;
    }
  }
  if (newest_ != kNone) return read_slot(newest_, &settings, &seq_);
  uint8_t legacy[record::kLegacySize];
  for (uint8_t i = 0; i < record::kLegacySize; ++i) legacy[i] = port_.read(record::kLegacyAddress + i);
  const record::Verdict v = record::decode_legacy(legacy, &settings);
  return v == record::Verdict::kBlank ? worst : v;
}

void SettingsStore::start_writing() {
  target_ = newest_ == 0 ? 1 : 0;
  crc_ = record::crc_of(*source_, seq_ + 1);
  next_ = 0;
  phase_ = Phase::kWrite;
}

void SettingsStore::poll() {
  // The EEPROM cannot be read while a write is in progress, so wait for ready() first.
  if (source_ == nullptr || !port_.ready()) return;
  if (source_->version() != version_) save(*source_);
  if (phase_ == Phase::kCompare) {
    // Saving what the newest record already holds writes nothing (and wears nothing).
    if (newest_ != kNone && holds(newest_, *source_, seq_)) {
      source_ = nullptr;
      return;
    }
    start_writing();
  }
  // Skip bytes that already hold the right value: fewer writes, less wear.
  const uint8_t seq = seq_ + 1;
  uint8_t byte = record::byte_at(*source_, seq, crc_, next_);
  while (port_.read(address(next_)) == byte) {
    if (++next_ == record::kSize) break;
    byte = record::byte_at(*source_, seq, crc_, next_);
  }
  if (next_ < record::kSize) port_.write(address(next_++), byte);
  if (next_ == record::kSize) {
    newest_ = target_;
    seq_ = seq;
    source_ = nullptr;
    phase_ = Phase::kCompare;
  }
}

}  // namespace core
