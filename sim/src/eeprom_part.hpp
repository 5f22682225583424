// The ATmega328P's EEPROM controller, timed as the datasheet says (DS40002061B §8.4 "EEPROM Data
// Memory", §8.6 register description). simavr 1.6 writes the byte the moment EEPE is set and
// clears EEPE at once (it only delays the EE_READY interrupt), so a firmware that polls EEPE sees
// every write finish instantly. This part takes over simavr's EECR write handler and keeps
// simavr's byte array (what AVR_IOCTL_EEPROM_GET/SET and eeprom_store.cpp use) as the one copy:
//  - EEMPE opens a four-cycle window; EEPE outside it does nothing (§8.6.3);
//  - EEPE stays set for the programming time of the mode EEPM1:0 selects (Table 8-2: 3.4 ms
//    erase + write, 1.8 ms erase only or write only) and the byte changes when it ends;
//  - while EEPE is set, EEPM and EEAR cannot change and a read (EERE) does nothing;
//  - a write halts the CPU for 2 cycles, a read for 4 (§8.6.3);
//  - EE_READY is a level interrupt: pending whenever EERIE is set and EEPE clear;
//  - a reset during programming leaves the byte partly programmed: in the erase phase some
//    bits already erased (1), in the write phase some already programmed (0), drawn from the seed.
#pragma once

#include <cstdint>
#include <string>

#include "rng.hpp"

struct avr_t;
struct avr_irq_t;
struct avr_eeprom_t;

namespace cart2d {

// The byte a cell holds when programming from `old` towards `data` in mode `eepm` (EEPM1:0) is
// cut after `done` of its `total` cycles: each bit the current phase would change has changed
// with probability (time spent in the phase) / (phase length). Atomic writes (EEPM = 00, and the
// reserved 11 treated alike) erase in the first half and write in the second.
uint8_t partly_programmed(uint8_t old, uint8_t data, unsigned eepm, uint64_t done, uint64_t total, Rng* rng);

class EepromPart {
 public:
  struct Stats {
    uint64_t writes_started = 0;
    uint64_t writes_done = 0;
    uint64_t writes_aborted = 0;         // cut short by a reset or a power loss
    uint64_t reads = 0;
    uint64_t reads_while_busy = 0;       // EERE while programming: nothing read (§8.6.3)
    uint64_t strobes_ignored = 0;        // EEPE without EEMPE in the four cycles before
    uint64_t address_writes_ignored = 0; // EEAR written while programming
  };

  EepromPart(avr_t* avr, uint64_t seed);
  // Takes over EECR (and EEAR) from simavr; false with *error if simavr's EEPROM is not found
  // where simavr 1.6 puts it.
  bool attach(std::string* error);
  // After a reset (simavr cleared EECR and every cycle timer): a write in progress is cut short.
  void on_reset();

  bool busy() const { return busy_; }
  const Stats& stats() const { return stats_; }

 private:
  static void on_eecr_write(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void on_eear_write(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static uint64_t on_done(avr_t* avr, uint64_t when, void* param);
  static uint64_t on_eempe_window_end(avr_t* avr, uint64_t when, void* param);
  static void on_ready_running(avr_irq_t* irq, uint32_t value, void* param);
  void write_eecr(uint8_t v);
  void start_write();
  uint16_t address() const;
  uint64_t programming_cycles(unsigned eepm) const;
  void update_ready_interrupt();

  avr_t* avr_;
  avr_eeprom_t* ee_ = nullptr;
  Rng rng_;
  Stats stats_;
  bool busy_ = false;
  uint16_t write_address_ = 0;
  uint8_t write_data_ = 0;
  unsigned write_mode_ = 0;
  uint64_t write_start_ = 0;
};

}  // namespace cart2d
