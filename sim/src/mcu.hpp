// The simulated ATmega328P: loads the firmware (ELF or Intel HEX) into simavr, replaces simavr's wall-clock
// sleep with a pure cycle skip (we pace in pacer.cpp), routes simavr's log to stderr and runs
// the core in slices of simulated time. Every reset, whatever its cause, goes through one path
// (mcu_reset.cpp): MCUSR flags, lost SRAM, the reset time-out tTOUT, then the parts' hook.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "robot_params.hpp"  // params::control
#include "spm_timing.hpp"

struct avr_t;
struct avr_io_t;

namespace cart2d {

// Why the chip reset (datasheet DS40002061B §11.2, "Reset Sources"); each sets its MCUSR flag.
enum class ResetCause : uint8_t { kPowerOn = 0, kExternal, kBrownOut, kWatchdog };
constexpr int kResetCauseCount = 4;
// "power", "external", "brownout", "watchdog": the side channel's names.
const char* reset_cause_name(ResetCause cause);

class Mcu {
 public:
  Mcu();
  ~Mcu();
  Mcu(const Mcu&) = delete;
  Mcu& operator=(const Mcu&) = delete;

  // Seeds the SRAM pattern that power-on and brown-out leave (before load()).
  void set_seed(uint64_t seed) { seed_ = seed; }

  // Reads the firmware, builds an atmega328p at f_cpu_hz and loads flash. An ELF (by its magic
  // number) also loads its .eeprom; Intel HEX (the first non-empty line starts with ':') is
  // flash only, validated strictly first. Anything else, or a malformed HEX, is refused with
  // *error = "firmware PATH: reason".
  bool load(const std::string& path, uint32_t f_cpu_hz, std::string* error);

  // mcu_boot.cpp: after load(), puts a bootloader (Intel HEX inside the boot section,
  // 0x7E00-0x7FFF) into flash and programs BOOTRST: every reset, the power-on one load() just
  // did included, then starts at 0x7E00 instead of the application's vector 0. SPM page erases
  // and writes then take the chip's programming time.
  bool load_bootloader(const std::string& path, std::string* error);
  bool has_bootloader() const { return bootloader_; }
  const SpmTiming* spm() const { return spm_.get(); }

  avr_t* avr() const { return avr_; }
  uint64_t cycle() const;
  uint32_t frequency_hz() const { return f_cpu_hz_; }
  double time_s() const { return static_cast<double>(cycle()) / f_cpu_hz_; }

  // Runs the core until its cycle counter reaches target; false if the core has stopped
  // (crashed, or slept with interrupts off) and will not advance any more. While the chip is
  // held in reset no instruction runs but cycle timers (the parts) keep firing.
  bool run_until(uint64_t target_cycle);
  bool alive() const;
  // "reset" (held: power off, brown-out dip or the time-out), "running", "sleeping", "done"
  // (slept with interrupts disabled), "crashed", ...
  const char* state_name() const;

  // Resets the chip: registers and cycle timers cleared, the cause's MCUSR flag set, EEPROM and
  // flash kept. kPowerOn and kBrownOut first hold the chip unpowered for off_cycles (pins
  // floating) and lose the SRAM. Every reset, the watchdog's included, then holds the CPU for the
  // time-out tTOUT and calls the reset hook, where the parts re-arm their timers.
  void reset(ResetCause cause, uint64_t off_cycles = 0);
  void set_reset_hook(std::function<void(ResetCause)> hook) { reset_hook_ = std::move(hook); }
  bool in_reset() const { return holding_; }
  uint64_t release_cycle() const { return release_cycle_; }  // when the CPU (last) left reset
  uint64_t reset_count(ResetCause cause) const { return resets_[static_cast<int>(cause)]; }
  uint64_t timeout_cycles() const;  // tTOUT in CPU cycles

  // Hang injection: at the next wake from sleep the main loop hangs as a real bug would: the
  // flash word after the SLEEP instruction (the one it sleeps in now, else the next it executes)
  // becomes `rjmp .`, so interrupts keep running but the loop never continues. The next reset
  // restores the word. take_hang_began() reports, once, the cycle the hang began.
  void request_hang();
  bool take_hang_began(uint64_t* cycle);

  // Called each time the core goes to sleep (SLEEP instruction), with the current cycle.
  void set_sleep_hook(std::function<void(uint64_t)> hook) { sleep_hook_ = std::move(hook); }

  // Cycle profile: while *gate is true, the cycles of every executed instruction are added to
  // profile()[program word address]. avr_run executes one instruction per call, so this is
  // exact, not sampled. A null gate turns profiling off (and costs nothing).
  void set_profile_gate(const bool* gate);
  const std::vector<uint64_t>& profile() const { return profile_; }
  void clear_profile() { std::fill(profile_.begin(), profile_.end(), 0); }

 private:
  struct ResetWatch;
  static void sleep_callback(avr_t* avr, uint64_t how_long);
  static void on_avr_reset(avr_io_t* io);
  static void on_mcusr_write(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void on_wdtcsr_write(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  // mcu_reset.cpp: the one path every reset takes once simavr's avr_reset() has returned.
  void watch_resets();
  void after_reset(ResetCause cause, uint64_t off_cycles);
  void scramble_sram();
  void hold(uint64_t limit_cycle);
  void release();
  void plant_hang(uint32_t pc);
  void restore_hang_word();
  void note_wake();

  bool load_ihex(const std::string& path, const std::string& text, uint32_t f_cpu_hz, std::string* error);
  // The atmega328p core, before a firmware image goes in; and what follows every load.
  bool create_avr(std::string* error);
  void finish_load(uint32_t f_cpu_hz);

  avr_t* avr_ = nullptr;
  uint32_t f_cpu_hz_ = static_cast<uint32_t>(params::control::f_cpu_hz);  // load() sets the same
  std::function<void(uint64_t)> sleep_hook_;
  const bool* profile_gate_ = nullptr;
  std::vector<uint64_t> profile_;
  bool was_sleeping_ = false;

  uint64_t seed_ = 0;
  std::unique_ptr<ResetWatch> watch_;
  std::function<void(ResetCause)> reset_hook_;
  bool avr_reset_seen_ = false;  // simavr ran avr_reset() (the watchdog does it on its own)
  uint8_t mcusr_ = 0;            // MCUSR as software sees it (flags accumulate)
  bool holding_ = false;
  uint64_t release_cycle_ = 0;
  uint8_t held_wdt_bits_ = 0;    // WDE/WDIE, kept off while the chip is held in reset
  avr_io_write_t simavr_wdtcsr_write_ = nullptr;  // simavr's WDTCSR writer, which ours wraps
  void* simavr_wdtcsr_param_ = nullptr;
  uint64_t resets_[kResetCauseCount] = {};

  bool bootloader_ = false;
  std::unique_ptr<SpmTiming> spm_;

  bool hang_requested_ = false;
  bool hang_waiting_wake_ = false;
  bool hang_began_ = false;
  uint64_t hang_cycle_ = 0;
  uint32_t hang_pc_ = 0;         // byte address of the patched word
  uint16_t hang_saved_word_ = 0;
  bool hang_patched_ = false;
};

}  // namespace cart2d
