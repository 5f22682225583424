#include "settings_store.hpp"

namespace core {

void SettingsStore::save(const Settings& settings) {
  source_ = &settings;
  version_ = settings.version();
  crc_ = record::crc_of(settings);
  next_ = 0;
}

record::Verdict SettingsStore::load(Settings& settings) {
  if (source_ != nullptr) {  // the EEPROM is about to hold exactly these values
    if (source_ != &settings) settings.assign(source_->raw());
    return record::Verdict::kValid;
  }
  uint8_t stored[record::kSize];
  for (uint8_t i = 0; i < record::kSize; ++i) stored[i] = port_.read(record::kAddress + i);
  return record::decode(stored, settings);
}

void SettingsStore::poll() {
  // The EEPROM cannot be read while a write is in progress, so wait for ready() first.
  if (source_ == nullptr || !port_.ready()) return;
  if (source_->version() != version_) save(*source_);
  // Skip bytes that already hold the right value: fewer writes, less wear.
  uint8_t byte = record::byte_at(*source_, crc_, next_);
  while (port_.read(record::kAddress + next_) == byte) {
    if (++next_ == record::kSize) {
      source_ = nullptr;
      return;
    }
    byte = record::byte_at(*source_, crc_, next_);
  }
  port_.write(record::kAddress + next_, byte);
  if (++next_ == record::kSize) source_ = nullptr;
}

}  // namespace core
