// The two LMD18200 H-bridges as the MCU drives them: PWM from Timer1's OC1A/OC1B pins and the
// DIRECTION pins (LOW = forward). Read from the registers at each physics step: simulating every
// 50 kHz edge would cost far more than it tells (the motor filters the PWM, see motor.hpp).
#pragma once

#include <cstdint>

#include "pin.hpp"

struct avr_t;

namespace cart2d {

// What the Timer1 output pin does in PWM mode 8 (phase and frequency correct, TOP = ICR1;
// datasheet §15.9.5 and Table 15-4). Non-inverting (COM1x = 2): cleared on the up-counting
// compare match and set on the down-counting one, so the pin is high for OCR1x/TOP of the period
// (OCR = 0 → always low, OCR ≥ TOP → always high). Inverting (COM1x = 3) is the complement.
// COM1x = 0 or 1 leaves the pin to PORTx (plain GPIO). Without its DDR bit the pin is an input
// and the bridge input reads input_level (see HBridgePart). Returns the high-time fraction in [0, 1].
double oc1_duty(unsigned com_bits, uint16_t ocr, uint16_t top, bool port_bit, bool ddr_bit, bool input_level);

// The Timer1 waveform mode the H-bridge model would misread (it reads duties as in mode 8), or
// 8 when there is none: only while the timer's clock runs and it drives OC1A or OC1B. The timer
// in another mode with both pins left to PORTx is no PWM of the bridges: Optiboot's LED flashes
// after every external reset run Timer1 in mode 0 (clk/1024) before the firmware configures it.
unsigned timer1_misread_mode(uint8_t tccr1a, uint8_t tccr1b);

struct MotorDuties {
  double left = 0.0;   // signed: + forward
  double right = 0.0;
};

// The seed's schematic puts a pull-down resistor on each LMD18200 PWM and DIRECTION input, so
// while the MCU pin is an input (always, during a reset: every pin floats) the bridge reads LOW:
// 0 % duty. Without them (the fault hbridge_pulldowns = 0) the floating TTL inputs read HIGH: PWM
// full on and DIRECTION high (backwards) for as long as the pin stays an input. An input with
// the MCU's pull-up enabled follows the same rule (the board's pull-down is taken to be stronger
// than the 20-50 kΩ internal pull-up, datasheet §29.2 R_PU).
class HBridgePart {
 public:
  HBridgePart(avr_t* avr, PinRef left_dir, PinRef right_dir, PinRef left_pwm, PinRef right_pwm);
  // Current signed duties of both bridges.
  MotorDuties sample();
  void set_pulldowns(bool present) { pulldowns_ = present; }
  bool pulldowns() const { return pulldowns_; }

 private:
  bool output_level(PinRef pin) const;  // level the bridge sees on a GPIO pin

  avr_t* avr_;
  PinRef left_dir_, right_dir_, left_pwm_, right_pwm_;
  bool warned_mode_ = false;
  bool pulldowns_ = true;
};

}  // namespace cart2d
