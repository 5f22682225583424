#include "motors.hpp"

#include <avr/io.h>  // Timer1 registers

#include "io.hpp"  // make_output_low, write_pin

namespace board {
namespace motors {

namespace pins = params::pins;
namespace ctl = params::control;

// duty = |command| * TOP / pwm_max, as a multiply and a shift: no software division.
constexpr uint16_t kScaleQ8 = (ctl::pwm_top * 256L + ctl::pwm_max - 1) / ctl::pwm_max;
static_assert((ctl::pwm_max * kScaleQ8) >> 8 == ctl::pwm_top, "full command must give full duty");
static_assert(pins::left_pwm.port == 'B' && pins::left_pwm.bit == 2, "left PWM must be OC1B");
static_assert(pins::right_pwm.port == 'B' && pins::right_pwm.bit == 1, "right PWM must be OC1A");

static uint8_t duty_of(int16_t command) {
  uint16_t magnitude = command < 0 ? -command : command;
  if (magnitude > ctl::pwm_max) magnitude = ctl::pwm_max;
  return static_cast<uint8_t>((static_cast<uint32_t>(magnitude) * kScaleQ8) >> 8);
}

void init() {
  make_output_low(pins::left_pwm);
  make_output_low(pins::right_pwm);
  make_output_low(pins::left_dir);
  make_output_low(pins::right_dir);
  TCCR1A = 0;  // COM1A/COM1B off: the pins stay low GPIOs until enabled
  TCCR1B = (1 << WGM13) | (1 << CS10);  // mode 8, no prescaler: 16 MHz / (2 * ICR1)
  ICR1 = ctl::pwm_top;
  OCR1A = 0;
  OCR1B = 0;
}

void apply(const core::MotorOutput& out) {
  if (!out.enabled) {
    TCCR1A = 0;
    OCR1A = OCR1B = 0;
    write_pin(pins::left_dir, false);
    write_pin(pins::right_dir, false);
    return;
  }
  // LMD18200 DIRECTION: LOW = forwards, HIGH = backwards.
  write_pin(pins::left_dir, out.pwm.left < 0);
  write_pin(pins::right_dir, out.pwm.right < 0);
  OCR1B = duty_of(out.pwm.left);  // double-buffered: takes effect at BOTTOM, glitch-free
  OCR1A = duty_of(out.pwm.right);
  TCCR1A = (1 << COM1A1) | (1 << COM1B1);  // non-inverting PWM on both pins
}

}  // namespace motors
}  // namespace board
