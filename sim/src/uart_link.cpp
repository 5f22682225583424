#include "uart_link.hpp"

#include <cerrno>    // errno
#include <cstring>   // strcmp, strerror
#include <fcntl.h>   // fcntl, O_NONBLOCK
#include <pty.h>     // openpty
#include <termios.h> // cfmakeraw, tcsetattr
#include <unistd.h>  // read, write, close

#include "atmega328p.hpp"
#include "log.hpp"

extern "C" {
#include <avr_uart.h>  // avr_uart_t, UART_IRQ_*, AVR_IOCTL_UART_*
#include <sim_io.h>    // avr_io_getirq, avr_ioctl
}

namespace cart2d {

constexpr size_t kQueueCap = 64 * 1024;  // bytes the link holds per direction before dropping

UartLink::~UartLink() {
  if (master_fd_ >= 0) close(master_fd_);
  if (slave_fd_ >= 0) close(slave_fd_);
}

bool UartLink::open_pty(std::string* error) {
  char name[256] = {0};
  if (openpty(&master_fd_, &slave_fd_, name, nullptr, nullptr) != 0) {
    *error = std::string("openpty: ") + std::strerror(errno);
    return false;
  }
  termios tio;
  tcgetattr(slave_fd_, &tio);
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  tcsetattr(slave_fd_, TCSANOW, &tio);
  fcntl(master_fd_, F_SETFL, fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  fcntl(master_fd_, F_SETFD, FD_CLOEXEC);
  fcntl(slave_fd_, F_SETFD, FD_CLOEXEC);
  pty_path_ = name;
  return true;
}

void UartLink::attach(avr_t* avr, uint64_t seed) {
  avr_ = avr;
  rng_rx_.reseed(seed, kStreamUartRx);
  rng_tx_.reseed(seed, kStreamUartTx);
  // No usleep() when the firmware polls an empty receiver, no copy of the output on the console.
  uint32_t flags = 0;
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  for (avr_io_t* io = avr_->io_port; io; io = io->next) {
    if (std::strcmp(io->kind, "uart") == 0 && reinterpret_cast<avr_uart_t*>(io)->name == '0')
      uart_ = reinterpret_cast<avr_uart_t*>(io);  // avr_uart_t begins with its avr_io_t
  }
  irq_input_ = avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_output, this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), on_xoff, this);
}

uint64_t UartLink::frame_cycles() const {
  const uint8_t* d = avr_->data;
  const unsigned ubrr = d[m328p::kUBRR0L] | ((d[m328p::kUBRR0H] & 0x0Fu) << 8);
  const bool u2x = (d[m328p::kUCSR0A] >> m328p::kU2X0) & 1;
  const unsigned ucsz = ((d[m328p::kUCSR0C] >> m328p::kUCSZ00) & 0x3u) | (((d[m328p::kUCSR0B] >> m328p::kUCSZ02) & 1u) << 2);
  static const unsigned kDataBits[8] = {5, 6, 7, 8, 8, 8, 8, 9};
  const unsigned parity = (d[m328p::kUCSR0C] >> m328p::kUPM01) & 1u;
  const unsigned stop = 1 + ((d[m328p::kUCSR0C] >> m328p::kUSBS0) & 1u);
  // Datasheet §19.3.1: bit time = (UBRR + 1)·16 cycles, ·8 with U2X.
  return static_cast<uint64_t>(ubrr + 1) * (u2x ? 8 : 16) * (1 + kDataBits[ucsz] + parity + stop);
}

void UartLink::correct_simavr_timing() {
  if (uart_) uart_->cycles_per_byte = frame_cycles();
}

void UartLink::on_output(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<UartLink*>(param);
  // Raised from simavr's UDR write, before it schedules its TX-complete timer.
  self->correct_simavr_timing();
  const uint64_t frame = self->frame_cycles();
  const uint64_t start = self->avr_->cycle > self->tx_line_free_cycle_ ? self->avr_->cycle : self->tx_line_free_cycle_;
  self->tx_line_free_cycle_ = start + frame;
  ++self->stats_.tx_bytes;
  uint8_t byte = static_cast<uint8_t>(value);
  if (self->rng_tx_.chance(self->faults_.uart_tx_drop)) {
    ++self->stats_.tx_dropped;
    return;
  }
  if (self->rng_tx_.chance(self->faults_.uart_tx_corrupt)) {
    byte ^= static_cast<uint8_t>(1u << self->rng_tx_.below(8));
    ++self->stats_.tx_corrupted;
  }
  if (self->tx_queue_.size() >= kQueueCap) {
    ++self->stats_.host_overflow;
    return;
  }
  self->tx_queue_.emplace_back(start + frame, byte);
}

void UartLink::on_xoff(avr_irq_t*, uint32_t value, void* param) { static_cast<UartLink*>(param)->xoff_ = value != 0; }

void UartLink::start_pump() {
  if (pumping_ || rx_queue_.empty() || !avr_) return;
  pumping_ = true;
  const uint64_t at = line_free_cycle_ > avr_->cycle ? line_free_cycle_ : avr_->cycle;
  avr_cycle_timer_register(avr_, at - avr_->cycle, rx_pump, this);
}

uint64_t UartLink::rx_pump(avr_t*, uint64_t when, void* param) {
  auto* self = static_cast<UartLink*>(param);
  const uint64_t frame = self->frame_cycles();
  if (self->rx_queue_.empty()) {
    self->pumping_ = false;
    return 0;
  }
  if (self->xoff_) return when + frame;  // receiver FIFO full: the host waits (flow control)
  uint8_t byte = self->rx_queue_.front();
  self->rx_queue_.pop_front();
  self->line_free_cycle_ = when + frame;
  if (self->rng_rx_.chance(self->faults_.uart_rx_drop)) {
    ++self->stats_.rx_dropped;
    return when + frame;  // the byte's time on the wire passes all the same
  }
  if (self->rng_rx_.chance(self->faults_.uart_rx_corrupt)) {
    byte ^= static_cast<uint8_t>(1u << self->rng_rx_.below(8));
    ++self->stats_.rx_corrupted;
  }
  ++self->stats_.rx_bytes;
  self->correct_simavr_timing();  // before simavr schedules its RXC timer with it
  avr_raise_irq(self->irq_input_, byte);
  return when + frame;
}

void UartLink::rearm_after_reset() {
  // avr_reset() dropped our pump timer and emptied the receiver; bytes still queued on the host
  // side go on arriving (the sender does not know the MCU reset).
  pumping_ = false;
  xoff_ = false;
  line_free_cycle_ = 0;
  start_pump();
}

void UartLink::read_host() {
  if (master_fd_ < 0) return;
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = read(master_fd_, buf, sizeof buf);
    if (n <= 0) break;
    for (ssize_t i = 0; i < n; ++i) {
      if (rx_queue_.size() >= kQueueCap) {
        ++stats_.host_overflow;
        continue;
      }
      rx_queue_.push_back(buf[i]);
    }
  }
  start_pump();
}

void UartLink::inject(const std::string& bytes) {
  for (const char c : bytes) rx_queue_.push_back(static_cast<uint8_t>(c));
  start_pump();
}

void UartLink::release_finished(uint64_t now_cycle, std::string* out) {
  while (!tx_queue_.empty() && tx_queue_.front().first <= now_cycle) {
    out->push_back(static_cast<char>(tx_queue_.front().second));
    tx_queue_.pop_front();
  }
}

std::string UartLink::take_output(uint64_t now_cycle) {
  std::string out;
  release_finished(now_cycle, &out);
  return out;
}

void UartLink::write_host(uint64_t now_cycle) {
  release_finished(now_cycle, &host_out_);
  if (master_fd_ < 0) {
    host_out_.clear();
    return;
  }
  while (!host_out_.empty()) {
    const ssize_t n = write(master_fd_, host_out_.data(), host_out_.size());
    if (n <= 0) break;
    host_out_.erase(0, static_cast<size_t>(n));
  }
  // Nobody reading: keep the newest bytes only, as a UART with no listener loses them anyway.
  if (host_out_.size() > kQueueCap) {
    stats_.host_overflow += host_out_.size() - kQueueCap;
    host_out_.erase(0, host_out_.size() - kQueueCap);
  }
}

}  // namespace cart2d
