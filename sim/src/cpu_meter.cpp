#include "cpu_meter.hpp"

extern "C" {
#include <sim_avr.h>         // avr_t
#include <sim_interrupts.h>  // avr_get_interrupt_irq, AVR_INT_IRQ_PENDING
}

namespace cart2d {

CpuMeter::CpuMeter(uint64_t period_cycles, size_t window_ticks)
    : period_(period_cycles), ring_(window_ticks, 0), ring_overrun_(window_ticks, 0) {}

void CpuMeter::attach(avr_t* avr, uint8_t vector) {
  // The vector's "pending" IRQ goes to 1 at the compare match, even while the CPU sleeps.
  avr_ = avr;
  avr_irq_t* irq = avr_get_interrupt_irq(avr, vector);
  if (irq) avr_irq_register_notify(irq + AVR_INT_IRQ_PENDING, on_pending, this);
}

void CpuMeter::on_pending(avr_irq_t* irq, uint32_t value, void* param) {
  // irq->value still holds the previous level here: count rising edges only.
  auto* self = static_cast<CpuMeter*>(param);
  if (value && !irq->value) self->on_tick(self->avr_->cycle);
}

void CpuMeter::on_tick(uint64_t cycle) {
  if (measuring_) record(period_, true);  // the previous tick never reached sleep
  measuring_ = true;
  start_ = cycle;
}

void CpuMeter::on_sleep(uint64_t cycle) {
  if (!measuring_) return;
  measuring_ = false;
  const uint64_t used = cycle - start_;
  record(used > period_ ? period_ : used, used > period_);
}

void CpuMeter::record(uint64_t cycles, bool overrun) {
  ++total_.ticks;
  total_.sum += cycles;
  if (cycles > total_.max) total_.max = cycles;
  if (overrun) ++total_.overruns;
  ring_[ring_next_] = cycles;
  ring_overrun_[ring_next_] = overrun;
  ring_next_ = (ring_next_ + 1) % ring_.size();
  if (ring_count_ < ring_.size()) ++ring_count_;
}

CpuMeter::Summary CpuMeter::window() const {
  Summary s;
  uint64_t sum = 0;
  for (size_t i = 0; i < ring_count_; ++i) {
    sum += ring_[i];
    if (ring_[i] > s.max_cycles) s.max_cycles = ring_[i];
    s.overruns += ring_overrun_[i];
  }
  s.ticks = ring_count_;
  if (ring_count_) {
    s.mean = static_cast<double>(sum) / ring_count_ / period_;
    s.max = static_cast<double>(s.max_cycles) / period_;
  }
  return s;
}

CpuMeter::Summary CpuMeter::total() const {
  Summary s;
  s.ticks = total_.ticks;
  s.overruns = total_.overruns;
  s.max_cycles = total_.max;
  if (total_.ticks) {
    s.mean = static_cast<double>(total_.sum) / total_.ticks / period_;
    s.max = static_cast<double>(total_.max) / period_;
  }
  return s;
}

}  // namespace cart2d
