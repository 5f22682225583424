// Drives MCU input pins from outside (encoder outputs, bumper switches).
//
// simavr's ioport re-raises every input pin whose PORT bit is set (the pull-up) each time the
// firmware writes PORTx, which would overwrite a level we drive; declaring our pins "external"
// (AVR_IOCTL_IOPORT_SET_EXTERNAL) makes it use our level instead. So every drive updates both
// the pin IRQ and the port's external mask/value.
#pragma once

#include <cstdint>

#include "pin.hpp"

struct avr_t;
struct avr_irq_t;

namespace cart2d {

class PinDriver {
 public:
  explicit PinDriver(avr_t* avr) : avr_(avr) {}

  void drive(PinRef pin, bool level);
  bool level(PinRef pin) const;
  // avr_reset() zeroes the PINx registers but simavr's pin IRQs keep their last (filtered)
  // value, so raising the same level again would not reach PINx: write the bits back directly.
  void restore_after_reset();

 private:
  struct PortState {
    uint8_t mask = 0;
    uint8_t value = 0;
  };
  PortState& state(char port) { return ports_[port == 'B' ? 0 : port == 'C' ? 1 : 2]; }
  const PortState& state(char port) const { return ports_[port == 'B' ? 0 : port == 'C' ? 1 : 2]; }

  avr_t* avr_;
  PortState ports_[3];  // B, C, D
};

}  // namespace cart2d
