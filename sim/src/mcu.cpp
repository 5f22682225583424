#include "mcu.hpp"

#include <cstdarg>   // va_list
#include <cstdio>    // vsnprintf
#include <cstdlib>   // free
#include <cstring>   // strcmp, memset

#include "firmware_file.hpp"  // sniff_firmware, read_intel_hex
#include "log.hpp"

extern "C" {
#include <avr_extint.h>  // avr_extint_set_strict_lvl_trig
#include <sim_avr.h>     // avr_t, avr_run, avr_reset, avr_global_logger_set
#include <sim_cycle_timers.h>  // avr_cycle_timer_register
#include <sim_elf.h>     // elf_read_firmware, avr_load_firmware
#include <sim_regbit.h>  // avr_regbit_set
}

namespace cart2d {

// simavr's sleep callback has no user pointer; one simulated MCU per process.
Mcu* g_mcu = nullptr;  // mcu_reset.cpp clears it

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
void disable_level_poll(avr_t* avr) {
  avr_extint_set_strict_lvl_trig(avr, 0, 0);
  avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

bool Mcu::load(const std::string& path, uint32_t f_cpu_hz, std::string* error) {
  avr_global_logger_set(simavr_logger);
  FirmwareFormat format = FirmwareFormat::kElf;
  std::string text;
  if (!sniff_firmware(path, &format, &text, error)) {
    *error = "firmware " + path + ": " + *error;
    return false;
  }
  if (format == FirmwareFormat::kIntelHex) return load_ihex(path, text, f_cpu_hz, error);

  const std::string& elf_path = path;
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf_path.c_str(), &fw) != 0) {
    *error = "cannot read firmware ELF " + elf_path;
    return false;
  }
  if (fw.mmcu[0] && std::strcmp(fw.mmcu, "atmega328p") != 0)
    LOG_WARN("firmware declares mmcu '%s'; simulating an atmega328p anyway", fw.mmcu);
  if (!create_avr(error)) return false;
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
  finish_load(f_cpu_hz);
  return true;
}

bool Mcu::create_avr(std::string* error) {
  avr_ = avr_make_mcu_by_name("atmega328p");
  if (!avr_) {
    *error = "simavr does not know the atmega328p";
    return false;
  }
  avr_init(avr_);
  disable_level_poll(avr_);
  g_mcu = this;
  watch_resets();
  return true;
}

void Mcu::finish_load(uint32_t f_cpu_hz) {
  avr_->frequency = f_cpu_hz;
  f_cpu_hz_ = f_cpu_hz;
  // Sleeping only skips cycles to the next timer event; pacing to wall time happens in our loop.
  avr_->sleep = sleep_callback;
  after_reset(ResetCause::kPowerOn, 0);  // power is applied: PORF, random SRAM, the time-out
}

bool Mcu::load_ihex(const std::string& path, const std::string& text, uint32_t f_cpu_hz, std::string* error) {
  FlashImage image;
  std::string why;
  if (!read_intel_hex(path, text, &image, &why)) {
    *error = "firmware " + path + ": " + why;
    return false;
  }
  if (!create_avr(error)) return false;
  // A .hex carries flash only: no clock, no mmcu, no .eeprom (avr-objcopy -R .eeprom). The MCU
  // starts at the reset vector, address 0, wherever the image begins.
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  fw.frequency = f_cpu_hz;
  fw.flash = image.flash.data();
  fw.flashsize = static_cast<uint32_t>(image.flash.size());
  fw.flashbase = image.base;
  avr_load_firmware(avr_, &fw);  // copies the flash
  finish_load(f_cpu_hz);
  LOG_INFO("firmware %s: Intel HEX, %u bytes of flash at 0x%04X-0x%04X", path.c_str(), image.data_bytes,
           image.base, image.base + fw.flashsize - 1);
  return true;
}

uint64_t Mcu::cycle() const { return avr_ ? avr_->cycle : 0; }

void Mcu::sleep_callback(avr_t* avr, uint64_t how_long) {
  (void)how_long;
  Mcu* self = g_mcu;
  if (!self || self->avr_ != avr) return;
  // The core calls this on every timer event while asleep; only the first call is the moment
  // the CPU went to sleep (avr->pc already points past the SLEEP instruction).
  if (!self->was_sleeping_) {
    if (self->sleep_hook_) self->sleep_hook_(avr->cycle);
    if (self->hang_requested_) self->plant_hang(avr->pc);
  }
  self->was_sleeping_ = true;
}

void Mcu::set_profile_gate(const bool* gate) {
  profile_gate_ = gate;
  if (gate && profile_.empty()) profile_.assign(32768 / 2, 0);  // one slot per flash word
}

namespace {
avr_cycle_count_t wake_nothing(avr_t*, avr_cycle_count_t, void*) { return 0; }
}  // namespace

// A sleeping core jumps to its next cycle timer, which may lie past the target: a timer at the
// target makes a slice end on its cycle, so a reset or world change scheduled for a simulated
// time happens there, not at the firmware's next interrupt (up to a timer period late).
bool Mcu::run_until(uint64_t target_cycle) {
  if (avr_ && target_cycle > avr_->cycle) avr_cycle_timer_register(avr_, target_cycle - avr_->cycle, wake_nothing, this);
  for (;;) {
    if (holding_ && avr_->cycle >= release_cycle_) release();
    if (avr_->cycle >= target_cycle) return true;
    if (holding_) {
      hold(std::min(target_cycle, release_cycle_));
      continue;
    }
    const uint32_t pc = avr_->pc;
    const uint64_t before = avr_->cycle;
    const int state = avr_run(avr_);
    if (avr_reset_seen_) {  // the watchdog reset the core on its own, inside avr_run()
      after_reset(ResetCause::kWatchdog, 0);
      continue;
    }
    if (profile_gate_ && *profile_gate_ && state == cpu_Running) profile_[(pc / 2) % profile_.size()] += avr_->cycle - before;
    if (state == cpu_Running) {
      if (was_sleeping_) note_wake();
      was_sleeping_ = false;
    } else if (state != cpu_Sleeping) {
      return false;
    }
  }
}

bool Mcu::alive() const {
  return avr_ && (holding_ || avr_->state == cpu_Running || avr_->state == cpu_Sleeping);
}

const char* Mcu::state_name() const {
  if (!avr_) return "none";
  if (holding_) return "reset";
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

}  // namespace cart2d
