#include "hbridge_part.hpp"

#include "atmega328p.hpp"
#include "log.hpp"

extern "C" {
#include <sim_avr.h>  // avr_t::data
}

namespace cart2d {

double oc1_duty(unsigned com_bits, uint16_t ocr, uint16_t top, bool port_bit, bool ddr_bit, bool input_level) {
  if (!ddr_bit) return input_level ? 1.0 : 0.0;
  if (com_bits < 2) return port_bit ? 1.0 : 0.0;
  double duty = top == 0 ? (ocr > 0 ? 1.0 : 0.0) : static_cast<double>(ocr) / top;
  if (duty > 1.0) duty = 1.0;
  return com_bits == 3 ? 1.0 - duty : duty;
}

HBridgePart::HBridgePart(avr_t* avr, PinRef left_dir, PinRef right_dir, PinRef left_pwm, PinRef right_pwm)
    : avr_(avr), left_dir_(left_dir), right_dir_(right_dir), left_pwm_(left_pwm), right_pwm_(right_pwm) {}

bool HBridgePart::output_level(PinRef pin) const {
  const uint8_t ddr = avr_->data[m328p::ddr_register(pin.port)];
  const uint8_t port = avr_->data[m328p::port_register(pin.port)];
  if (!((ddr >> pin.bit) & 1)) return !pulldowns_;
  return (port >> pin.bit) & 1;
}

unsigned timer1_misread_mode(uint8_t tccr1a, uint8_t tccr1b) {
  const unsigned wgm = (tccr1a & 0x3u) | ((tccr1b >> 1) & 0xCu);
  const bool clock_running = (tccr1b & 0x7u) != 0;
  const bool drives_a_pin = (tccr1a & ((0x3u << m328p::kCOM1A0) | (0x3u << m328p::kCOM1B0))) != 0;
  return clock_running && drives_a_pin && wgm != 8 ? wgm : 8;
}

MotorDuties HBridgePart::sample() {
  const uint8_t* d = avr_->data;
  const uint8_t tccr1a = d[m328p::kTCCR1A], tccr1b = d[m328p::kTCCR1B];
  const bool clock_running = (tccr1b & 0x7u) != 0;
  const unsigned misread = timer1_misread_mode(tccr1a, tccr1b);
  if (misread != 8 && !warned_mode_) {
    LOG_WARN("Timer1 drives PWM in WGM mode %u; the H-bridge model reads duties as in mode 8 (TOP = ICR1)", misread);
    warned_mode_ = true;
  }
  const uint16_t top = static_cast<uint16_t>(d[m328p::kICR1L] | (d[m328p::kICR1H] << 8));
  const uint16_t ocr_a = static_cast<uint16_t>(d[m328p::kOCR1AL] | (d[m328p::kOCR1AH] << 8));
  const uint16_t ocr_b = static_cast<uint16_t>(d[m328p::kOCR1BL] | (d[m328p::kOCR1BH] << 8));
  unsigned com_a = (tccr1a >> m328p::kCOM1A0) & 0x3u;
  unsigned com_b = (tccr1a >> m328p::kCOM1B0) & 0x3u;
  // A stopped timer no longer toggles its pins; treat it as its GPIO level (the usual case:
  // firmware stops the clock with the outputs cleared).
  if (!clock_running) com_a = com_b = 0;

  auto pwm = [&](PinRef pin, unsigned com, uint16_t ocr) {
    const uint8_t ddr = d[m328p::ddr_register(pin.port)];
    const uint8_t port = d[m328p::port_register(pin.port)];
    return oc1_duty(com, ocr, top, (port >> pin.bit) & 1, (ddr >> pin.bit) & 1, !pulldowns_);
  };
  // OC1A = D9 = right motor, OC1B = D10 = left motor (gen_params.py checks the pin numbers).
  const double left = pwm(left_pwm_, com_b, ocr_b);
  const double right = pwm(right_pwm_, com_a, ocr_a);
  MotorDuties out;
  out.left = output_level(left_dir_) ? -left : left;
  out.right = output_level(right_dir_) ? -right : right;
  return out;
}

}  // namespace cart2d
