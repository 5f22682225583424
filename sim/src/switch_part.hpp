// The two front bumper switches: normally open, they short their pin to ground when pressed.
// Released, the pin is held high only by the MCU's internal pull-up (PORT bit set, DDR bit
// clear); without it the input floats, which we model as LOW so that a firmware that forgets the
// pull-up sees "pressed" here as well, not a lucky high.
#pragma once

#include <cstdint>

#include "pin.hpp"

struct avr_t;
struct avr_irq_t;

namespace cart2d {

class PinDriver;

class SwitchPart {
 public:
  SwitchPart(avr_t* avr, PinDriver* driver, PinRef left, PinRef right);

  void set_pressed(bool left, bool right);
  bool pressed_left() const { return pressed_[0]; }
  bool pressed_right() const { return pressed_[1]; }
  // Recomputes both pin levels (after a reset or a PORT/DDR change).
  void refresh();

 private:
  static void on_port_write(avr_irq_t* irq, uint32_t value, void* param);
  static void on_ddr_write(avr_irq_t* irq, uint32_t value, void* param);
  // Drives switch `index`; with use_ddr_override, ddr_override replaces the DDRx register value.
  void update(int index, int use_ddr_override, int ddr_override);

  avr_t* avr_;
  PinDriver* driver_;
  PinRef pins_[2];
  bool pressed_[2] = {false, false};
};

}  // namespace cart2d
