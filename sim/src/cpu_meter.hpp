// CPU use of the control tick: cycles from each Timer2 compare-match interrupt request to the
// next moment the CPU goes to sleep, as a share of the tick period (128 000 cycles = 8 ms).
// Everything the CPU does in that interval counts: the tick ISR, encoder ISRs that nest or
// follow, and main-loop work triggered by the tick. A tick that has not slept by the next
// compare match counts as 100 % and as an overrun.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

struct avr_t;
struct avr_irq_t;

namespace cart2d {

class CpuMeter {
 public:
  struct Summary {
    uint64_t ticks = 0;
    uint64_t overruns = 0;
    double mean = 0.0;  // share of the period
    double max = 0.0;
    uint64_t max_cycles = 0;
  };

  CpuMeter(uint64_t period_cycles, size_t window_ticks);

  void attach(avr_t* avr, uint8_t vector);
  void on_sleep(uint64_t cycle);
  void on_tick(uint64_t cycle);
  // After an MCU reset: the tick being measured is abandoned.
  void abandon() { measuring_ = false; }
  // True from a tick's compare match until the CPU sleeps: the window being measured.
  const bool* measuring_flag() const { return &measuring_; }

  Summary window() const;  // the last window_ticks ticks
  Summary total() const;   // since start or the last reset_total()
  void reset_total() { total_ = Accum(); }

 private:
  struct Accum {
    uint64_t ticks = 0, overruns = 0, sum = 0, max = 0;
  };
  static void on_pending(avr_irq_t* irq, uint32_t value, void* param);
  void record(uint64_t cycles, bool overrun);

  avr_t* avr_ = nullptr;
  uint64_t period_;
  bool measuring_ = false;
  uint64_t start_ = 0;
  Accum total_;
  std::vector<uint64_t> ring_;
  std::vector<char> ring_overrun_;
  size_t ring_next_ = 0, ring_count_ = 0;
};

}  // namespace cart2d
