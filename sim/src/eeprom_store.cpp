#include "eeprom_store.hpp"

#include <cerrno>    // errno
#include <cstdio>    // fopen, fread, fwrite, rename
#include <cstdlib>   // getenv
#include <cstring>   // strerror
#include <sys/stat.h>  // mkdir

#include "atmega328p.hpp"
#include "log.hpp"

extern "C" {
#include <avr_eeprom.h>  // avr_eeprom_desc_t, AVR_IOCTL_EEPROM_GET/SET
#include <sim_io.h>      // avr_ioctl
}

namespace cart2d {

std::string EepromStore::default_path() {
  std::string base;
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg && *xdg) base = xdg;
  else if (const char* home = std::getenv("HOME"); home && *home) base = std::string(home) + "/.local/share";
  else base = ".";
  return base + "/cart2d/sim-eeprom.bin";
}

// Creates every missing directory above a file path.
static void make_parent_dirs(const std::string& path) {
  for (size_t i = 1; i < path.size(); ++i)
    if (path[i] == '/') mkdir(path.substr(0, i).c_str(), 0755);
}

std::vector<uint8_t> EepromStore::read_eeprom(avr_t* avr) {
  std::vector<uint8_t> bytes(m328p::kEepromBytes, 0xFF);
  avr_eeprom_desc_t d;
  d.ee = bytes.data();
  d.offset = 0;
  d.size = m328p::kEepromBytes;
  avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);  // simavr 1.6 returns −1 even on success
  return bytes;
}

bool EepromStore::load(avr_t* avr) {
  last_ = read_eeprom(avr);
  FILE* f = std::fopen(path_.c_str(), "rb");
  if (!f) return false;
  std::vector<uint8_t> bytes(m328p::kEepromBytes, 0xFF);
  const size_t n = std::fread(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  if (n != bytes.size()) LOG_WARN("%s holds %zu bytes, expected %u: the rest stays erased (0xFF)", path_.c_str(), n, m328p::kEepromBytes);
  avr_eeprom_desc_t d;
  d.ee = bytes.data();
  d.offset = 0;
  d.size = m328p::kEepromBytes;
  avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
  last_ = bytes;
  return true;
}

bool EepromStore::save(avr_t* avr, std::string* error) {
  const std::vector<uint8_t> bytes = read_eeprom(avr);
  make_parent_dirs(path_);
  const std::string tmp = path_ + ".tmp";
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) {
    *error = tmp + ": " + std::strerror(errno);
    return false;
  }
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path_.c_str()) != 0) {
    *error = path_ + ": " + std::strerror(errno);
    return false;
  }
  last_ = bytes;
  return true;
}

bool EepromStore::changed(avr_t* avr) const { return read_eeprom(avr) != last_; }

}  // namespace cart2d
