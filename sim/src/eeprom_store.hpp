// Keeps the MCU's EEPROM in a file across runs (simavr does not): restored after the ELF is
// loaded (loading writes the ELF's .eeprom section), saved on exit and whenever it changed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

struct avr_t;

namespace cart2d {

class EepromStore {
 public:
  explicit EepromStore(std::string path) : path_(std::move(path)) {}

  // $XDG_DATA_HOME/cart2d/sim-eeprom.bin, or ~/.local/share/cart2d/sim-eeprom.bin.
  static std::string default_path();

  const std::string& path() const { return path_; }
  // Copies the file into the MCU's EEPROM. False (and EEPROM untouched) if there is no file yet.
  bool load(avr_t* avr);
  // Writes the EEPROM to the file atomically (temporary file + rename).
  bool save(avr_t* avr, std::string* error);
  // True if the EEPROM differs from what was last loaded or saved.
  bool changed(avr_t* avr) const;

  static std::vector<uint8_t> read_eeprom(avr_t* avr);

 private:
  std::string path_;
  std::vector<uint8_t> last_;
};

}  // namespace cart2d
