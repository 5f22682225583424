// The simulated ATmega328P: loads the firmware (ELF or Intel HEX) into simavr, replaces simavr's wall-clock
// sleep with a pure cycle skip (we pace in pacer.cpp), routes simavr's log to stderr and runs
// the core in slices of simulated time.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "robot_params.hpp"  // params::control

struct avr_t;

namespace cart2d {

class Mcu {
 public:
  Mcu() = default;
  ~Mcu();
  Mcu(const Mcu&) = delete;
  Mcu& operator=(const Mcu&) = delete;

  // Reads the firmware, builds an atmega328p at f_cpu_hz and loads flash. An ELF (by its magic
  // number) also loads its .eeprom; Intel HEX (the first non-empty line starts with ':') is
  // flash only, validated strictly first. Anything else, or a malformed HEX, is refused with
  // *error = "firmware PATH: reason".
  bool load(const std::string& path, uint32_t f_cpu_hz, std::string* error);

  avr_t* avr() const { return avr_; }
  uint64_t cycle() const;
  uint32_t frequency_hz() const { return f_cpu_hz_; }
  double time_s() const { return static_cast<double>(cycle()) / f_cpu_hz_; }

  // Runs the core until its cycle counter reaches target; false if the core has stopped
  // (crashed, or slept with interrupts off) and will not advance any more.
  bool run_until(uint64_t target_cycle);
  bool alive() const;
  // "running", "sleeping", "done" (slept with interrupts disabled), "crashed", ...
  const char* state_name() const;

  // Like pressing the reset button: registers and cycle timers cleared, EXTRF set in MCUSR,
  // EEPROM and flash kept. Parts must re-arm their timers afterwards.
  void reset();

  // Called each time the core goes to sleep (SLEEP instruction), with the current cycle.
  void set_sleep_hook(std::function<void(uint64_t)> hook) { sleep_hook_ = std::move(hook); }

  // Cycle profile: while *gate is true, the cycles of every executed instruction are added to
  // profile()[program word address]. avr_run executes one instruction per call, so this is
  // exact, not sampled. A null gate turns profiling off (and costs nothing).
  void set_profile_gate(const bool* gate);
  const std::vector<uint64_t>& profile() const { return profile_; }
  void clear_profile() { std::fill(profile_.begin(), profile_.end(), 0); }

 private:
  static void sleep_callback(avr_t* avr, uint64_t how_long);
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
};

}  // namespace cart2d
