#include "eeprom_part.hpp"

#include <cstring>  // strcmp
#include <string>

#include "atmega328p.hpp"
#include "log.hpp"
#include "robot_params.hpp"  // params::sim

extern "C" {
#include <avr_eeprom.h>   // avr_eeprom_t
#include <sim_avr.h>      // avr_t
#include <sim_cycle_timers.h>  // avr_cycle_timer_register
#include <sim_interrupts.h>    // avr_raise_interrupt, avr_clear_interrupt
#include <sim_io.h>       // avr_register_io_write
#include <sim_irq.h>      // avr_irq_register_notify
}

namespace cart2d {

namespace {

constexpr uint8_t kEepm = m328p::kEEPM0 | m328p::kEEPM1;
constexpr int kEepmShift = 4;
constexpr unsigned kEraseOnly = 1, kWriteOnly = 2;  // EEPM1:0, Table 8-2
constexpr uint64_t kEempeWindowCycles = 4;            // §8.6.3 EEMPE
constexpr uint64_t kWriteHaltCycles = 2, kReadHaltCycles = 4;  // §8.6.3 EEPE, EERE

// Each bit of `mask` flips in `value` with probability p.
uint8_t flip_some(uint8_t value, uint8_t mask, double p, Rng* rng) {
  for (int bit = 0; bit < 8; ++bit)
    if ((mask >> bit) & 1 && rng->chance(p)) value = static_cast<uint8_t>(value ^ (1u << bit));
  return value;
}

}  // namespace

uint8_t partly_programmed(uint8_t old, uint8_t data, unsigned eepm, uint64_t done, uint64_t total, Rng* rng) {
  const bool erase = eepm != kWriteOnly, write = eepm != kEraseOnly;
  const uint64_t erase_cycles = erase ? (write ? total / 2 : total) : 0;
  const uint64_t write_cycles = total - erase_cycles;
  uint8_t cell = old;
  if (erase) {  // programmed bits (0) go back to 1
    const double p = done >= erase_cycles ? 1.0 : static_cast<double>(done) / erase_cycles;
    cell = flip_some(cell, static_cast<uint8_t>(~cell), p, rng);
  }
  if (write && done > erase_cycles) {  // bits the data holds at 0 are programmed
    const uint64_t in_write = done - erase_cycles;
    const double p = in_write >= write_cycles ? 1.0 : static_cast<double>(in_write) / write_cycles;
    cell = flip_some(cell, static_cast<uint8_t>(cell & ~data), p, rng);
  }
  return cell;
}

EepromPart::EepromPart(avr_t* avr, uint64_t seed) : avr_(avr), rng_(seed, kStreamEeprom) {}

bool EepromPart::attach(std::string* error) {
  for (avr_io_t* io = avr_->io_port; io; io = io->next)
    if (io->kind && std::strcmp(io->kind, "eeprom") == 0) ee_ = reinterpret_cast<avr_eeprom_t*>(io);
  auto& eecr = avr_->io[AVR_DATA_TO_IO(m328p::kEECR)].w;
  if (!ee_ || eecr.param != ee_) {
    *error = "simavr's EEPROM module or its EECR handler is not where simavr 1.6 puts them";
    return false;
  }
  // Replaces simavr's handler (not added beside it: avr_register_io_write would chain both).
  eecr.c = on_eecr_write;
  eecr.param = this;
  avr_register_io_write(avr_, m328p::kEEARL, on_eear_write, this);
  avr_register_io_write(avr_, m328p::kEEARH, on_eear_write, this);
  // RETI from the EE_READY handler: a level interrupt asks again if its condition still holds.
  avr_irq_register_notify(ee_->ready.irq + AVR_INT_IRQ_RUNNING, on_ready_running, this);
  return true;
}

uint16_t EepromPart::address() const {
  const uint8_t* d = avr_->data;
  return static_cast<uint16_t>((d[m328p::kEEARL] | (d[m328p::kEEARH] << 8)) & (m328p::kEepromBytes - 1));
}

uint64_t EepromPart::programming_cycles(unsigned eepm) const {
  const double s = eepm == kEraseOnly || eepm == kWriteOnly ? static_cast<double>(params::sim::eeprom_split_write_s)
                                                            : static_cast<double>(params::sim::eeprom_atomic_write_s);
  return static_cast<uint64_t>(s * avr_->frequency + 0.5);
}

void EepromPart::on_eecr_write(avr_t*, uint16_t, uint8_t v, void* param) { static_cast<EepromPart*>(param)->write_eecr(v); }

void EepromPart::write_eecr(uint8_t v) {
  uint8_t* d = avr_->data;
  const uint8_t old = d[m328p::kEECR];
  // EEPE and EEMPE are the hardware's to clear; EEPM is frozen while programming.
  uint8_t next = static_cast<uint8_t>((old & (m328p::kEEPE | m328p::kEEMPE)) | (v & m328p::kEERIE));
  next |= busy_ ? (old & kEepm) : (v & kEepm);
  if ((v & m328p::kEEMPE) && !(old & m328p::kEEMPE)) {
    next |= m328p::kEEMPE;
    avr_cycle_timer_register(avr_, kEempeWindowCycles, on_eempe_window_end, this);
  }
  d[m328p::kEECR] = next;
  if (v & m328p::kEEPE) {
    if (busy_) {
      // already programming: EEPE reads one anyway
    } else if (old & m328p::kEEMPE) {
      start_write();
    } else {
      ++stats_.strobes_ignored;
    }
  }
  if (v & m328p::kEERE) {
    if (busy_) {
      ++stats_.reads_while_busy;
    } else {
      d[m328p::kEEDR] = ee_->eeprom[address()];
      ++stats_.reads;
      avr_->cycle += kReadHaltCycles;
    }
  }
  update_ready_interrupt();
}

void EepromPart::start_write() {
  uint8_t* d = avr_->data;
  busy_ = true;
  write_address_ = address();
  write_data_ = d[m328p::kEEDR];
  write_mode_ = (d[m328p::kEECR] & kEepm) >> kEepmShift;
  write_start_ = avr_->cycle;
  d[m328p::kEECR] |= m328p::kEEPE;
  avr_cycle_timer_register(avr_, programming_cycles(write_mode_), on_done, this);
  ++stats_.writes_started;
  avr_->cycle += kWriteHaltCycles;
}

uint64_t EepromPart::on_done(avr_t*, uint64_t, void* param) {
  auto* self = static_cast<EepromPart*>(param);
  uint8_t& cell = self->ee_->eeprom[self->write_address_];
  const uint8_t data = self->write_data_;
  switch (self->write_mode_) {
    case kEraseOnly: cell = 0xFF; break;
    case kWriteOnly: cell = static_cast<uint8_t>(cell & data); break;  // can only program zeros
    default: cell = data; break;
  }
  self->busy_ = false;
  self->avr_->data[m328p::kEECR] &= static_cast<uint8_t>(~m328p::kEEPE);
  ++self->stats_.writes_done;
  self->update_ready_interrupt();
  return 0;
}

uint64_t EepromPart::on_eempe_window_end(avr_t*, uint64_t, void* param) {
  auto* self = static_cast<EepromPart*>(param);
  self->avr_->data[m328p::kEECR] &= static_cast<uint8_t>(~m328p::kEEMPE);
  return 0;
}

void EepromPart::on_eear_write(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* self = static_cast<EepromPart*>(param);
  if (self->busy_) {
    ++self->stats_.address_writes_ignored;
    return;
  }
  // EEARH has EEAR9:8 only (1 KiB); its other bits read zero.
  avr->data[addr] = addr == m328p::kEEARH ? static_cast<uint8_t>(v & 0x03) : v;
}

void EepromPart::on_ready_running(avr_irq_t*, uint32_t value, void* param) {
  if (value == 0) static_cast<EepromPart*>(param)->update_ready_interrupt();
}

void EepromPart::update_ready_interrupt() {
  const uint8_t eecr = avr_->data[m328p::kEECR];
  const bool level = (eecr & m328p::kEERIE) && !(eecr & m328p::kEEPE);
  if (level && !ee_->ready.pending) avr_raise_interrupt(avr_, &ee_->ready);
  else if (!level && ee_->ready.pending) avr_clear_interrupt(avr_, &ee_->ready);
}

void EepromPart::on_reset() {
  if (!busy_) return;
  busy_ = false;
  const uint64_t total = programming_cycles(write_mode_);
  const uint64_t done = avr_->cycle - write_start_;
  uint8_t& cell = ee_->eeprom[write_address_];
  const uint8_t before = cell;
  cell = partly_programmed(cell, write_data_, write_mode_, done, total, &rng_);
  ++stats_.writes_aborted;
  LOG_INFO("EEPROM write of 0x%02X to %u cut short after %.3f ms of %.3f ms: 0x%02X -> 0x%02X", write_data_,
           write_address_, 1e3 * static_cast<double>(done) / avr_->frequency,
           1e3 * static_cast<double>(total) / avr_->frequency, before, cell);
}

}  // namespace cart2d
