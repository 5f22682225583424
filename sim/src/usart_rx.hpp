// The receive half of the ATmega328P's USART0 at register level, in place of simavr 1.6's.
//
// simavr keeps a 64-byte input FIFO, raises RXC0 one frame after a byte enters it (again every
// frame while it is not empty), sets DOR only when those 64 are full, and asks the sender to
// wait (XOFF): a firmware that reads its receiver late never loses a byte there. The chip
// (datasheet DS40002061B §19.7 "Data Reception – The USART Receiver", §19.10.2 UCSR0A) has a
// two-character receive buffer (UDR0) behind the receive shift register:
//  - a frame is complete at the last centre sample of its stop bit (§19.8.2), and moves into the
//    buffer if there is room; otherwise it waits in the shift register;
//  - if a new start bit is detected while the buffer is full and a frame waits in the shift
//    register, that frame is lost: a data overrun. DOR0, like FE0 and UPE0, is stored in the
//    buffer with a frame, the first one to reach the buffer after the loss, so it reads back in
//    UCSR0A while that frame is the next to be read ("one or more frames were lost between the
//    last frame read from UDR0 and the next frame read");
//  - RXC0 is set while the buffer holds unread data, and the RX Complete interrupt is a level:
//    it is taken again after RETI for as long as RXC0 and RXCIE0 are set;
//  - RXEN0 = 0 flushes the buffer; while it is 0 nothing is received.
// Reads of UDR0 and UCSR0A are served here (simavr's handlers are bypassed); writes to UCSR0A,
// UCSR0B, UCSR0C and UBRR0L go to simavr first, then are followed here. The bits come from an
// AsyncReceiver sampling the host's line at the baud rate generator's clock: a sample every
// UBRR0 + 1 cycles counted from the last write to UBRR0L (§19.3.1), 16 per bit or 8 with U2X0.
#pragma once

#include <cstdint>
#include <optional>

#include "serial_wire.hpp"

struct avr_t;
struct avr_irq_t;
struct avr_uart_t;

namespace cart2d {

class UsartReceiver {
 public:
  struct Stats {
    uint64_t frames = 0;         // frames moved into the receive buffer
    uint64_t overruns = 0;       // frames lost in the shift register (DOR0)
    uint64_t frame_errors = 0;   // frames received with FE0
    uint64_t parity_errors = 0;  // frames received with UPE0 (parity enabled only)
  };

  UsartReceiver() = default;
  UsartReceiver(const UsartReceiver&) = delete;
  UsartReceiver& operator=(const UsartReceiver&) = delete;

  // Takes over the receiver of `uart`; the host's frames come from `line`.
  void attach(avr_t* avr, avr_uart_t* uart, const LineWaveform* line);
  // New frames on the line: wake up if the receiver was waiting for a start bit.
  void line_changed() { plan(); }
  // After avr_reset(): registers cleared (RXEN0 = 0), timers gone.
  void after_reset();
  // The earliest cycle of the line the receiver may still sample (kNever when off).
  double needed_from() const { return rx_.needed_from(); }
  const Stats& stats() const { return stats_; }
  int unread() const { return count_; }
  bool shift_register_full() const { return shift_.has_value(); }

 private:
  struct Entry {
    uint8_t data = 0;
    bool fe = false, dor = false, upe = false;
  };
  struct WriteHook {
    UsartReceiver* self = nullptr;
    uint16_t addr = 0;
    void (*c)(avr_t*, uint16_t, uint8_t, void*) = nullptr;  // simavr's handler, if any
    void* param = nullptr;
  };

  static uint8_t read_udr(avr_t* avr, uint16_t addr, void* param);
  static uint8_t read_ucsra(avr_t* avr, uint16_t addr, void* param);
  static void write_hooked(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static uint64_t on_timer(avr_t* avr, uint64_t when, void* param);
  static void on_rxc_pending(avr_irq_t* irq, uint32_t value, void* param);

  void hook_write(WriteHook* hook, uint16_t addr);
  void after_write(uint16_t addr);
  SamplerConfig sampler_config() const;
  void plan();
  void handle(const AsyncReceiver::Event& ev);
  void push(Entry e);
  void flush();
  bool reg_bit(uint16_t addr, int bit) const;
  void raise_rxc();
  void clear_rxc();

  avr_t* avr_ = nullptr;
  avr_uart_t* uart_ = nullptr;
  const LineWaveform* line_ = nullptr;
  WriteHook hooks_[4];
  AsyncReceiver rx_;
  Stats stats_;
  Entry fifo_[2];
  int count_ = 0;
  std::optional<Entry> shift_;  // a complete frame waiting for room in the buffer
  bool dor_pending_ = false;    // a frame was lost: the next one into the buffer carries DOR0
  bool rxen_ = false;
  uint64_t prescaler_origin_ = 0;  // cycle of the last UBRR0L write: the sample clock restarts
};

}  // namespace cart2d
