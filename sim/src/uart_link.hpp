// USART0 ↔ a pseudo-terminal, timed in simulated time (our own part, not simavr's uart_pty,
// which runs a thread and paces to the wall clock).
//
// Host → MCU: bytes read from the pty wait in a queue and enter simavr's receiver one frame apart
// (frame = start + data + parity + stop bits at the baud the firmware set), and only while the
// receiver has room (XOFF not asserted). simavr raises RXC one frame after a byte enters its
// empty FIFO, so handing byte k over at T0 + k·frame makes it readable at T0 + (k+1)·frame,
// exactly when its stop bit would end on the wire.
// MCU → host: each byte written to UDR0 reaches the pty when its frame has left the shift
// register in simulated time.
// simavr 1.6 counts a parity bit even when parity is off (11 bits per 8N1 byte); we correct its
// cycles_per_byte before it uses it, so the firmware's own TX/RX pacing matches the wire.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <utility>

#include "faults.hpp"
#include "rng.hpp"

struct avr_t;
struct avr_irq_t;
struct avr_uart_t;

namespace cart2d {

class UartLink {
 public:
  struct Stats {
    uint64_t rx_bytes = 0;       // delivered to the MCU
    uint64_t rx_dropped = 0;     // lost to the drop fault
    uint64_t rx_corrupted = 0;
    uint64_t tx_bytes = 0;       // sent by the MCU
    uint64_t tx_dropped = 0;
    uint64_t tx_corrupted = 0;
    uint64_t host_overflow = 0;  // dropped because the host side did not keep up
  };

  UartLink() = default;
  ~UartLink();
  UartLink(const UartLink&) = delete;
  UartLink& operator=(const UartLink&) = delete;

  // Creates the pseudo-terminal (raw mode, non-blocking master). Optional: tests use inject().
  bool open_pty(std::string* error);
  const std::string& pty_path() const { return pty_path_; }
  int host_fd() const { return master_fd_; }

  // Connects to the MCU's USART0 and turns off simavr's poll-sleep and console echo.
  void attach(avr_t* avr, uint64_t seed);
  void rearm_after_reset();
  void set_faults(const Faults& f) { faults_ = f; }

  // Host side, called by the simulation loop between slices.
  void read_host();                  // pty → queue
  void write_host(uint64_t now_cycle);  // finished bytes → pty
  bool host_output_pending() const { return !host_out_.empty(); }

  // Without a pty (tests): queue bytes for the MCU / take the bytes it finished sending.
  void inject(const std::string& bytes);
  std::string take_output(uint64_t now_cycle);

  // Cycles per frame at the current USART0 settings.
  uint64_t frame_cycles() const;
  const Stats& stats() const { return stats_; }

 private:
  static void on_output(avr_irq_t* irq, uint32_t value, void* param);
  static void on_xoff(avr_irq_t* irq, uint32_t value, void* param);
  static uint64_t rx_pump(avr_t* avr, uint64_t when, void* param);
  void start_pump();
  void correct_simavr_timing();
  void release_finished(uint64_t now_cycle, std::string* out);

  avr_t* avr_ = nullptr;
  avr_uart_t* uart_ = nullptr;
  avr_irq_t* irq_input_ = nullptr;
  int master_fd_ = -1;
  int slave_fd_ = -1;  // kept open so the master never reads EIO while no client is attached
  std::string pty_path_;

  Faults faults_;
  Rng rng_rx_, rng_tx_;
  Stats stats_;

  std::deque<uint8_t> rx_queue_;
  bool pumping_ = false;
  bool xoff_ = false;
  uint64_t line_free_cycle_ = 0;  // the host's next byte cannot start before this

  std::deque<std::pair<uint64_t, uint8_t>> tx_queue_;  // (cycle its stop bit ends, byte)
  uint64_t tx_line_free_cycle_ = 0;
  std::string host_out_;  // finished bytes the pty had no room for yet
};

}  // namespace cart2d
