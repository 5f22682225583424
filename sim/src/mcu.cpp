#include "mcu.hpp"

#include <cstdarg>   // va_list
#include <cstdio>    // vsnprintf
#include <cstdlib>   // free
#include <cstring>   // strcmp

#include "log.hpp"

extern "C" {
#include <avr_extint.h>  // avr_extint_set_strict_lvl_trig
#include <sim_avr.h>     // avr_t, avr_run, avr_reset, avr_global_logger_set
#include <sim_elf.h>     // elf_read_firmware, avr_load_firmware
#include <sim_regbit.h>  // avr_regbit_set
}

namespace cart2d {

// simavr's sleep callback has no user pointer; one simulated MCU per process.
static Mcu* g_mcu = nullptr;

// simavr logs through one global function; the default writes traces to stdout, which must
// stay reserved for the ready line.
static void simavr_logger(avr_t*, const int level, const char* format, va_list ap) {
  if (level >= LOG_TRACE && log_level() < LogLevel::kDebug) return;
  char buf[512];
  std::vsnprintf(buf, sizeof buf, format, ap);
  size_t n = std::strlen(buf);
  while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) buf[--n] = 0;
  if (n == 0) return;
  // simavr's warnings are mostly about register writes in an order it does not expect (OCR1A
  // before TCCR1B at start-up); the parts report what matters to us themselves.
  if (level <= LOG_ERROR) LOG_WARN("simavr: %s", buf);
  else LOG_DEBUG("simavr: %s", buf);
}

// simavr 1.6 emulates INT0/INT1's low-level mode by polling the pin every cycle from the moment
// it reads low in that mode (the power-on default, ISC = 00), and the poll only ends when the pin
// goes high: after the firmware has switched to ANY-edge mode it still raises the interrupt on
// every cycle while an encoder rests with A low. Turning the strict level emulation off makes
// the low-level mode act like a falling edge, which our firmware never uses anyway.
static void disable_level_poll(avr_t* avr) {
  avr_extint_set_strict_lvl_trig(avr, 0, 0);
  avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

Mcu::~Mcu() {
  if (avr_) {
    avr_terminate(avr_);
    free(avr_);  // allocated by the core maker with malloc
  }
  if (g_mcu == this) g_mcu = nullptr;
}

bool Mcu::load(const std::string& elf_path, uint32_t f_cpu_hz, std::string* error) {
  avr_global_logger_set(simavr_logger);
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf_path.c_str(), &fw) != 0) {
    *error = "cannot read firmware ELF " + elf_path;
    return false;
  }
  if (fw.mmcu[0] && std::strcmp(fw.mmcu, "atmega328p") != 0)
    LOG_WARN("firmware declares mmcu '%s'; simulating an atmega328p anyway", fw.mmcu);
  avr_ = avr_make_mcu_by_name("atmega328p");
  if (!avr_) {
    *error = "simavr does not know the atmega328p";
    return false;
  }
  avr_init(avr_);
  disable_level_poll(avr_);
  g_mcu = this;
  // Without an .mmcu section the ELF says nothing about the clock: use robot.toml's.
  if (fw.frequency && fw.frequency != f_cpu_hz)
    LOG_WARN("firmware declares %u Hz, robot.toml says %u Hz: using robot.toml", fw.frequency, f_cpu_hz);
  fw.frequency = f_cpu_hz;
  avr_load_firmware(avr_, &fw);
  // simavr copied what it needs; the reader's buffers are ours to free (it has no free call).
  free(fw.flash);
  free(fw.eeprom);
  free(fw.fuse);
  free(fw.lockbits);
  for (uint32_t i = 0; i < fw.symbolcount; ++i) free(fw.symbol[i]);
  free(fw.symbol);
  avr_->frequency = f_cpu_hz;
  f_cpu_hz_ = f_cpu_hz;
  // Sleeping only skips cycles to the next timer event; pacing to wall time happens in our loop.
  avr_->sleep = sleep_callback;
  return true;
}

uint64_t Mcu::cycle() const { return avr_ ? avr_->cycle : 0; }

void Mcu::sleep_callback(avr_t* avr, uint64_t how_long) {
  (void)how_long;
  Mcu* self = g_mcu;
  if (!self || self->avr_ != avr) return;
  // The core calls this on every timer event while asleep; only the first call is the moment
  // the CPU went to sleep.
  if (!self->was_sleeping_ && self->sleep_hook_) self->sleep_hook_(avr->cycle);
  self->was_sleeping_ = true;
}

void Mcu::set_profile_gate(const bool* gate) {
  profile_gate_ = gate;
  if (gate && profile_.empty()) profile_.assign(32768 / 2, 0);  // one slot per flash word
}

bool Mcu::run_until(uint64_t target_cycle) {
  while (avr_->cycle < target_cycle) {
    const uint32_t pc = avr_->pc;
    const uint64_t before = avr_->cycle;
    const int state = avr_run(avr_);
    if (profile_gate_ && *profile_gate_ && state == cpu_Running) profile_[(pc / 2) % profile_.size()] += avr_->cycle - before;
    if (state == cpu_Running) was_sleeping_ = false;
    else if (state != cpu_Sleeping) return false;
  }
  return true;
}

bool Mcu::alive() const { return avr_ && (avr_->state == cpu_Running || avr_->state == cpu_Sleeping); }

const char* Mcu::state_name() const {
  if (!avr_) return "none";
  switch (avr_->state) {
    case cpu_Limbo: return "limbo";
    case cpu_Stopped: return "stopped";
    case cpu_Running: return "running";
    case cpu_Sleeping: return "sleeping";
    case cpu_Step: return "step";
    case cpu_StepDone: return "step_done";
    case cpu_Done: return "done";
    case cpu_Crashed: return "crashed";
    default: return "unknown";
  }
}

void Mcu::reset() {
  avr_reset(avr_);
  disable_level_poll(avr_);  // avr_reset() turned it back on
  avr_regbit_set(avr_, avr_->reset_flags.extrf);  // MCUSR: external reset, as the button does
  was_sleeping_ = false;
}

}  // namespace cart2d
