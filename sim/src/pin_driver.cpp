#include "pin_driver.hpp"

#include <initializer_list>

#include "atmega328p.hpp"  // pin_register

extern "C" {
#include <avr_ioport.h>  // AVR_IOCTL_IOPORT_GETIRQ, AVR_IOCTL_IOPORT_SET_EXTERNAL
#include <sim_io.h>      // avr_io_getirq, avr_ioctl
}

namespace cart2d {

void PinDriver::drive(PinRef pin, bool level) {
  PortState& s = state(pin.port);
  const uint8_t bit = static_cast<uint8_t>(1u << pin.bit);
  s.mask |= bit;
  s.value = static_cast<uint8_t>(level ? (s.value | bit) : (s.value & ~bit));
  avr_ioport_external_t ext;
  ext.name = static_cast<unsigned>(pin.port);
  ext.mask = s.mask;
  ext.value = s.value;
  avr_ioctl(avr_, AVR_IOCTL_IOPORT_SET_EXTERNAL(pin.port), &ext);
  avr_raise_irq(avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(pin.port), pin.bit), level ? 1 : 0);
}

bool PinDriver::level(PinRef pin) const { return (state(pin.port).value >> pin.bit) & 1; }

void PinDriver::restore_after_reset() {
  for (char port : {'B', 'C', 'D'}) {
    const PortState& s = state(port);
    if (!s.mask) continue;
    uint8_t& pin = avr_->data[m328p::pin_register(port)];
    pin = static_cast<uint8_t>((pin & ~s.mask) | (s.value & s.mask));
  }
}

}  // namespace cart2d
