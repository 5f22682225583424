#include "switch_part.hpp"

#include "atmega328p.hpp"
#include "pin_driver.hpp"

extern "C" {
#include <avr_ioport.h>  // IOPORT_IRQ_REG_PORT, IOPORT_IRQ_DIRECTION_ALL
#include <sim_io.h>      // avr_io_getirq
}

namespace cart2d {

SwitchPart::SwitchPart(avr_t* avr, PinDriver* driver, PinRef left, PinRef right)
    : avr_(avr), driver_(driver), pins_{left, right} {
  // Re-evaluate the pull-up whenever the firmware writes PORTx or DDRx of a switch's port.
  for (int i = 0; i < 2; ++i) {
    if (i == 1 && pins_[1].port == pins_[0].port) break;
    const uint32_t ctl = AVR_IOCTL_IOPORT_GETIRQ(pins_[i].port);
    avr_irq_register_notify(avr_io_getirq(avr_, ctl, IOPORT_IRQ_REG_PORT), on_port_write, this);
    avr_irq_register_notify(avr_io_getirq(avr_, ctl, IOPORT_IRQ_DIRECTION_ALL), on_ddr_write, this);
  }
  refresh();
}

void SwitchPart::on_port_write(avr_irq_t*, uint32_t, void* param) {
  // PORTx already holds the new value when simavr raises this IRQ.
  static_cast<SwitchPart*>(param)->refresh();
}

void SwitchPart::on_ddr_write(avr_irq_t* irq, uint32_t value, void* param) {
  // DDRx is raised BEFORE simavr stores the new value: use the value carried by the IRQ.
  auto* self = static_cast<SwitchPart*>(param);
  for (int i = 0; i < 2; ++i) {
    const uint32_t ctl = AVR_IOCTL_IOPORT_GETIRQ(self->pins_[i].port);
    const bool same_port = avr_io_getirq(self->avr_, ctl, IOPORT_IRQ_DIRECTION_ALL) == irq;
    self->update(i, same_port ? 1 : 0, static_cast<int>(value));
  }
}

void SwitchPart::set_pressed(bool left, bool right) {
  if (left == pressed_[0] && right == pressed_[1]) return;
  pressed_[0] = left;
  pressed_[1] = right;
  refresh();
}

void SwitchPart::refresh() {
  update(0, 0, 0);
  update(1, 0, 0);
}

void SwitchPart::update(int index, int use_ddr_override, int ddr_override) {
  const PinRef pin = pins_[index];
  const uint8_t ddr = use_ddr_override ? static_cast<uint8_t>(ddr_override) : avr_->data[m328p::ddr_register(pin.port)];
  const uint8_t port = avr_->data[m328p::port_register(pin.port)];
  const bool pull_up = ((port & ~ddr) >> pin.bit) & 1;
  const bool level = !pressed_[index] && pull_up;
  driver_->drive(pin, level);
}

}  // namespace cart2d
