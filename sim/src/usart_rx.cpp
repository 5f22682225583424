#include "usart_rx.hpp"

#include <cmath>  // std::ceil

#include "atmega328p.hpp"

extern "C" {
#include <avr_uart.h>          // avr_uart_t
#include <sim_avr.h>           // avr_t, AVR_DATA_TO_IO
#include <sim_cycle_timers.h>  // avr_cycle_timer_register, avr_cycle_timer_cancel
#include <sim_interrupts.h>    // avr_raise_interrupt, avr_clear_interrupt
#include <sim_irq.h>           // avr_irq_register_notify
#include <sim_regbit.h>        // avr_regbit_clear
}

namespace cart2d {

using namespace m328p;

void UsartReceiver::attach(avr_t* avr, avr_uart_t* uart, const LineWaveform* line) {
  avr_ = avr;
  uart_ = uart;
  line_ = line;
  // Reads are ours alone: simavr's UDR0 read pops its own FIFO and its UCSR0A read reports FE
  // from it. simavr refuses a second read handler, so the table entry is replaced directly.
  avr->io[AVR_DATA_TO_IO(kUDR0)].r.c = read_udr;
  avr->io[AVR_DATA_TO_IO(kUDR0)].r.param = this;
  avr->io[AVR_DATA_TO_IO(kUCSR0A)].r.c = read_ucsra;
  avr->io[AVR_DATA_TO_IO(kUCSR0A)].r.param = this;
  const uint16_t followed[4] = {kUCSR0A, kUCSR0B, kUCSR0C, kUBRR0L};
  for (int i = 0; i < 4; ++i) hook_write(&hooks_[i], followed[i]);
  avr_irq_register_notify(uart->rxc.irq + AVR_INT_IRQ_PENDING, on_rxc_pending, this);
  after_reset();
}

// Wraps whatever simavr has on the register (it runs first) instead of registering a second
// writer, which would take one of simavr's four shared-register slots.
void UsartReceiver::hook_write(WriteHook* hook, uint16_t addr) {
  auto& w = avr_->io[AVR_DATA_TO_IO(addr)].w;
  *hook = WriteHook{this, addr, w.c, w.param};
  w.c = write_hooked;
  w.param = hook;
}

void UsartReceiver::write_hooked(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* hook = static_cast<WriteHook*>(param);
  if (hook->c) hook->c(avr, addr, v, hook->param);
  else avr->data[addr] = v;
  hook->self->after_write(addr);
}

void UsartReceiver::after_reset() {
  // avr_reset() dropped our timer and pending interrupts; the line keeps what the host sent.
  count_ = 0;
  shift_.reset();
  dor_pending_ = false;
  rx_.disable();
  rxen_ = reg_bit(kUCSR0B, kRXEN0);
  prescaler_origin_ = avr_->cycle;
  if (rxen_) rx_.enable(static_cast<double>(avr_->cycle));
  plan();
}

bool UsartReceiver::reg_bit(uint16_t addr, int bit) const { return (avr_->data[addr] >> bit) & 1; }

void UsartReceiver::after_write(uint16_t addr) {
  if (addr == kUBRR0L) prescaler_origin_ = avr_->cycle;  // §19.3.1: the prescaler reloads
  if (addr == kUCSR0B) {
    const bool rxen = reg_bit(kUCSR0B, kRXEN0);
    if (rxen && !rxen_) rx_.enable(static_cast<double>(avr_->cycle));
    if (!rxen && rxen_) flush();
    rxen_ = rxen;
    if (count_ > 0 && reg_bit(kUCSR0B, kRXCIE0)) raise_rxc();  // the interrupt is a level
  }
  plan();
}

SamplerConfig UsartReceiver::sampler_config() const {
  const uint8_t* d = avr_->data;
  const unsigned ubrr = d[kUBRR0L] | ((d[kUBRR0H] & 0x0Fu) << 8);
  SamplerConfig c;
  c.sample_period = ubrr + 1.0;
  c.samples_per_bit = reg_bit(kUCSR0A, kU2X0) ? 8 : 16;
  c.origin = static_cast<double>(prescaler_origin_);
  const unsigned ucsz = ((d[kUCSR0C] >> kUCSZ00) & 0x3u) | (reg_bit(kUCSR0B, kUCSZ02) << 2);
  c.format.data_bits = ucsz < 4 ? 5 + static_cast<int>(ucsz) : 8;  // 9-bit characters: not modelled
  const bool parity = reg_bit(kUCSR0C, kUPM01);
  c.format.parity = !parity ? Parity::kNone : reg_bit(kUCSR0C, kUPM00) ? Parity::kOdd : Parity::kEven;
  c.format.stop_bits = 1;  // the receiver only looks at the first stop bit
  return c;
}

// (Re)arms the cycle timer at the receiver's next event: the start bit's centre votes or the
// stop bit's. Every sample falls on a whole cycle (origin and period are whole cycles).
void UsartReceiver::plan() {
  avr_cycle_timer_cancel(avr_, on_timer, this);
  rx_.configure(sampler_config());
  const double t = rx_.next_event(*line_);
  if (t == kNever) return;
  const uint64_t at = static_cast<uint64_t>(std::ceil(t));
  avr_cycle_timer_register(avr_, at > avr_->cycle ? at - avr_->cycle : 0, on_timer, this);
}

uint64_t UsartReceiver::on_timer(avr_t*, uint64_t when, void* param) {
  auto* self = static_cast<UsartReceiver*>(param);
  self->handle(self->rx_.step(*self->line_));
  self->rx_.configure(self->sampler_config());
  const double t = self->rx_.next_event(*self->line_);
  if (t == kNever) return 0;
  const uint64_t at = static_cast<uint64_t>(std::ceil(t));
  return at > when ? at : when + 1;
}

void UsartReceiver::handle(const AsyncReceiver::Event& ev) {
  switch (ev.kind) {
    case AsyncReceiver::Kind::kStart:
      if (count_ == 2 && shift_) {  // §19.7.4: buffer full, a frame waiting, a new start bit
        shift_.reset();
        dor_pending_ = true;
        ++stats_.overruns;
      }
      return;
    case AsyncReceiver::Kind::kSpike:
      return;
    case AsyncReceiver::Kind::kFrame: {
      Entry e;
      e.data = ev.data;
      e.fe = ev.frame_error;
      e.upe = ev.parity_error;
      stats_.frame_errors += e.fe;
      stats_.parity_errors += e.upe;
      if (count_ < 2) push(e);
      else shift_ = e;
      return;
    }
  }
}

void UsartReceiver::push(Entry e) {
  e.dor = dor_pending_;
  dor_pending_ = false;
  fifo_[count_++] = e;
  ++stats_.frames;
  raise_rxc();
}

void UsartReceiver::flush() {
  count_ = 0;
  shift_.reset();
  dor_pending_ = false;
  rx_.disable();
  clear_rxc();
}

// Sets RXC0 and, with RXCIE0, makes the interrupt pending (simavr does nothing if it already is).
void UsartReceiver::raise_rxc() { avr_raise_interrupt(avr_, &uart_->rxc); }

void UsartReceiver::clear_rxc() {
  avr_clear_interrupt(avr_, &uart_->rxc);
  avr_regbit_clear(avr_, uart_->rxc.raised);  // a "sticky" vector: simavr leaves the flag set
}

// simavr clears a pending interrupt when it enters the vector; RXC0 is a level, so while the
// buffer holds data (the routine has not read it yet) the request stands and is taken again
// one instruction after RETI.
void UsartReceiver::on_rxc_pending(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<UsartReceiver*>(param);
  if (value == 0 && self->count_ > 0 && self->reg_bit(kUCSR0B, kRXEN0) && self->reg_bit(kUCSR0B, kRXCIE0))
    self->raise_rxc();
}

uint8_t UsartReceiver::read_udr(avr_t*, uint16_t, void* param) {
  auto* self = static_cast<UsartReceiver*>(param);
  if (self->count_ == 0) return 0;  // empty buffer: the datasheet leaves the value undefined
  const Entry head = self->fifo_[0];
  self->fifo_[0] = self->fifo_[1];
  --self->count_;
  if (self->shift_) {  // room again: the waiting frame moves in
    const Entry waiting = *self->shift_;
    self->shift_.reset();
    self->push(waiting);
  }
  if (self->count_ == 0) self->clear_rxc();
  else self->raise_rxc();
  return head.data;
}

// RXC0, FE0, DOR0 and UPE0 describe the next frame to be read; the other bits are simavr's.
uint8_t UsartReceiver::read_ucsra(avr_t* avr, uint16_t addr, void* param) {
  auto* self = static_cast<UsartReceiver*>(param);
  constexpr uint8_t kOurs = (1u << kRXC0) | (1u << kFE0) | (1u << kDOR0) | (1u << kUPE0);
  uint8_t v = avr->data[addr] & static_cast<uint8_t>(~kOurs);
  if (self->count_ > 0) {
    const Entry& e = self->fifo_[0];
    v |= static_cast<uint8_t>((1u << kRXC0) | (e.fe << kFE0) | (e.dor << kDOR0) | (e.upe << kUPE0));
  }
  return v;
}

}  // namespace cart2d
