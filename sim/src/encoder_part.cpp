#include "encoder_part.hpp"

#include "pin_driver.hpp"

extern "C" {
#include <sim_avr.h>  // avr_t::cycle, avr_cycle_timer_register
}

namespace cart2d {

EncoderPart::EncoderPart(avr_t* avr, PinDriver* driver, PinRef a, PinRef b, long pulses_per_rev,
                         bool b_high_on_rise_is_forward, uint64_t seed, uint64_t stream)
    : avr_(avr),
      driver_(driver),
      a_(a),
      b_(b),
      encoder_(pulses_per_rev, b_high_on_rise_is_forward, static_cast<double>(avr->frequency)),
      rng_(seed, stream) {
  driver_->drive(a_, encoder_.a());
  driver_->drive(b_, encoder_.b());
}

void EncoderPart::apply(const QuadratureEdge& e) {
  // B first: on a real disc B settles before the next A edge; the ISR reads B after A moved.
  if (driver_->level(b_) != e.b) {
    driver_->drive(b_, e.b);
    ++edges_emitted_;
  }
  if (driver_->level(a_) != e.a) {
    driver_->drive(a_, e.a);
    ++edges_emitted_;
    ++a_edges_emitted_;
  }
}

void EncoderPart::flush() {
  for (; next_ < pending_.size(); ++next_) apply(pending_[next_]);
  pending_.clear();
  next_ = 0;
  avr_cycle_timer_cancel(avr_, on_timer, this);
}

void EncoderPart::advance(double delta_rad, uint64_t c0, uint64_t n, const QuadratureFaults& faults) {
  flush();
  encoder_.advance(delta_rad, c0, n, faults, rng_, &pending_);
  schedule();
}

void EncoderPart::schedule() {
  if (next_ >= pending_.size()) return;
  const uint64_t at = pending_[next_].cycle;
  avr_cycle_timer_register(avr_, at > avr_->cycle ? at - avr_->cycle : 0, on_timer, this);
}

uint64_t EncoderPart::on_timer(avr_t*, uint64_t when, void* param) {
  auto* self = static_cast<EncoderPart*>(param);
  while (self->next_ < self->pending_.size() && self->pending_[self->next_].cycle <= when)
    self->apply(self->pending_[self->next_++]);
  if (self->next_ >= self->pending_.size()) return 0;
  return self->pending_[self->next_].cycle;  // absolute cycle of the next edge
}

void EncoderPart::rearm_after_reset() {
  // The pins keep their levels (the encoder does not care about the MCU's reset).
  schedule();
}

}  // namespace cart2d
