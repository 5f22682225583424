// USART0 ↔ the host, bit by bit in simulated time (our own part, not simavr's uart_pty, which
// runs a thread and paces to the wall clock).
//
// Host → MCU: bytes the host writes to the pty go out from the USB-serial adapter
// (usb_serial.hpp) at the host's baud rate, one frame after another, after the USB delay; there
// is no flow control. The MCU's receiver (usart_rx.hpp) samples that line as the chip does and
// shows the firmware what USART0 would: RXC0 at the stop bit's centre, at most two unread bytes,
// DOR0 and FE0.
// MCU → host: each byte written to UDR0 goes on the line when the one before it has left (its
// frame at the MCU's baud rate); the adapter's receiver samples it at the host's baud rate and
// the USB delay (or the FTDI latency timer) decides when the host can read it.
// simavr 1.6 counts a parity bit even when parity is off (11 bits per 8N1 byte); we correct its
// cycles_per_byte before it uses it, so the firmware's own TX pacing matches the wire.
// The pty also tells when the host opens the port (pty_port.hpp); while nobody has it open,
// what the MCU sends is lost, as an adapter with no host reading it loses it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "faults.hpp"
#include "pty_port.hpp"
#include "rng.hpp"
#include "usart_rx.hpp"
#include "usb_serial.hpp"

extern "C" {
#include <sim_io.h>  // avr_io_t
}

struct avr_irq_t;
struct avr_uart_t;

namespace cart2d {

class UartLink {
 public:
  struct Stats {
    uint64_t rx_line_bytes = 0;    // bytes the host put on the line towards the MCU
    uint64_t rx_bytes = 0;         // frames USART0 moved into its receive buffer
    uint64_t rx_dropped = 0;       // lost to the drop fault
    uint64_t rx_corrupted = 0;
    uint64_t rx_overruns = 0;      // frames lost to a data overrun (DOR0)
    uint64_t rx_frame_errors = 0;  // frames received with FE0
    uint64_t rx_parity_errors = 0;
    uint64_t tx_bytes = 0;         // written to UDR0 by the firmware
    uint64_t tx_dropped = 0;
    uint64_t tx_corrupted = 0;
    uint64_t rx_burst_dropped = 0;  // lost to a burst (Faults::uart_burst_*), towards the MCU
    uint64_t tx_burst_dropped = 0;  // the same, from the MCU
    uint64_t tx_frame_errors = 0;  // bytes the adapter's receiver got with a framing error
    uint64_t tx_no_host = 0;       // bytes that reached the adapter while no host had the port open
    uint64_t host_overflow = 0;    // dropped because the host side did not keep up
    uint64_t host_opens = 0;       // times a host opened the port
  };

  UartLink() = default;
  ~UartLink();
  UartLink(const UartLink&) = delete;
  UartLink& operator=(const UartLink&) = delete;

  // Creates the pseudo-terminal. Optional: tests use inject() and take_output().
  bool open_pty(std::string* error);
  const std::string& pty_path() const { return pty_.path(); }
  int host_fd() const { return pty_.fd(); }
  int host_change_fd() const { return pty_.change_fd(); }
  // Whether a host has the port open (always, without a pty).
  bool host_attached() const { return !pty_.is_open() || pty_.host_attached(); }
  // Looks whether the host opened or closed the port since the last look.
  std::vector<PtyPort::Change> poll_host();

  // Connects to the MCU's USART0 and turns off simavr's poll-sleep and console echo.
  void attach(avr_t* avr, uint64_t seed);
  void rearm_after_reset();
  void set_faults(const Faults& f);
  void set_adapter(const AdapterSettings& s);
  const AdapterSettings& adapter() const { return adapter_.settings(); }

  // Host side, called by the simulation loop between slices.
  size_t read_host();                   // pty → line; the bytes read
  void write_host(uint64_t now_cycle);  // what the host can read by now → pty
  bool host_output_pending() const { return !host_out_.empty(); }
  // When the host's bytes written so far have all reached the MCU; when the MCU's last frame
  // started and its transmitter went idle (a lockstep's hold lets it answer the host: hold.hpp).
  uint64_t to_mcu_idle_cycle() const { return static_cast<uint64_t>(adapter_.to_mcu_idle_at() + 0.5); }
  uint64_t mcu_frame_start_cycle() const { return tx_frame_start_cycle_; }
  uint64_t mcu_line_free_cycle() const { return tx_line_free_cycle_; }

  // Without a pty (tests): the host writes bytes now / reads what reached it by now_cycle
  // (and, if asked, the cycle at which each byte became readable).
  void inject(const std::string& bytes);
  std::string take_output(uint64_t now_cycle, std::vector<double>* ready = nullptr);

  // Cycles per frame and bits per second at the current USART0 settings.
  uint64_t frame_cycles() const;
  double mcu_baud() const;
  Stats stats() const;
  const UsartReceiver& receiver() const { return usart_rx_; }

 private:
  // Registered with simavr as an I/O module, so every avr_reset() reaches us, whoever calls it
  // (a reset button, DTR, simavr's own watchdog reset).
  struct ResetHook {
    avr_io_t io;  // first: simavr hands the reset callback this address
    UartLink* self;
  };
  static void on_avr_reset(avr_io_t* io);
  static void on_output(avr_irq_t* irq, uint32_t value, void* param);
  void send_to_mcu(uint8_t byte);
  void line_changed();
  void forget_used_line();  // frames towards the MCU its receiver is done with
  uint64_t bit_cycles() const;
  double seconds(double cycle) const { return cycle / static_cast<double>(avr_->frequency); }
  FrameFormat tx_format() const;
  void correct_simavr_timing();

  avr_t* avr_ = nullptr;
  avr_uart_t* uart_ = nullptr;
  ResetHook reset_hook_{};
  PtyPort pty_;
  Faults faults_;
  Rng rng_rx_, rng_tx_;
  BurstSchedule bursts_;
  Stats stats_;
  UsbSerialAdapter adapter_;
  UsartReceiver usart_rx_;
  uint64_t tx_line_free_cycle_ = 0;  // the MCU's transmitter is busy until then
  uint64_t tx_frame_start_cycle_ = 0;  // its last frame's start bit
  std::string host_out_;             // bytes for the host the pty had no room for yet
};

}  // namespace cart2d
