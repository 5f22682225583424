#include "uart_link.hpp"

#include <algorithm>  // std::max, std::min
#include <cstring>    // strcmp

#include "atmega328p.hpp"

extern "C" {
#include <avr_uart.h>  // avr_uart_t, UART_IRQ_*, AVR_IOCTL_UART_*
#include <sim_io.h>    // avr_io_getirq, avr_ioctl
}

namespace cart2d {

constexpr double kQueueCapBytes = 64 * 1024;  // host bytes the line holds before dropping

UartLink::~UartLink() {
  // The MCU outlives us (the Rig destroys us first): take our module out of its list.
  if (!avr_) return;
  for (avr_io_t** p = &avr_->io_port; *p; p = &(*p)->next) {
    if (*p == &reset_hook_.io) {
      *p = reset_hook_.io.next;
      break;
    }
  }
}

bool UartLink::open_pty(std::string* error) { return pty_.open(error); }

void UartLink::on_avr_reset(avr_io_t* io) { reinterpret_cast<ResetHook*>(io)->self->rearm_after_reset(); }

std::vector<PtyPort::Change> UartLink::poll_host() {
  std::vector<PtyPort::Change> changes = pty_.poll_host();
  for (const PtyPort::Change c : changes) {
    if (c == PtyPort::Change::kOpened) ++stats_.host_opens;
    host_out_.clear();  // nothing for a host that has gone
  }
  return changes;
}

void UartLink::attach(avr_t* avr, uint64_t seed) {
  avr_ = avr;
  rng_rx_.reseed(seed, kStreamUartRx);
  rng_tx_.reseed(seed, kStreamUartTx);
  bursts_.reseed(seed);
  // No usleep() when the firmware polls an empty receiver, no copy of the output on the console.
  uint32_t flags = 0;
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  for (avr_io_t* io = avr_->io_port; io; io = io->next) {
    if (std::strcmp(io->kind, "uart") == 0 && reinterpret_cast<avr_uart_t*>(io)->name == '0')
      uart_ = reinterpret_cast<avr_uart_t*>(io);  // avr_uart_t begins with its avr_io_t
  }
  adapter_.set_cpu_hz(avr_->frequency);
  usart_rx_.attach(avr_, uart_, &adapter_.to_mcu());
  reset_hook_.io.kind = "cart2d_uart_link";
  reset_hook_.io.reset = on_avr_reset;
  reset_hook_.self = this;
  avr_register_io(avr_, &reset_hook_.io);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_output, this);
}

void UartLink::set_faults(const Faults& f) {
  faults_ = f;
  bursts_.configure(f.uart_burst_hz, f.uart_burst_ms, avr_ ? seconds(static_cast<double>(avr_->cycle)) : 0.0);
}

void UartLink::set_adapter(const AdapterSettings& s) {
  adapter_.set_settings(s, avr_ ? static_cast<double>(avr_->cycle) : 0.0);
}

uint64_t UartLink::bit_cycles() const {
  const uint8_t* d = avr_->data;
  const unsigned ubrr = d[m328p::kUBRR0L] | ((d[m328p::kUBRR0H] & 0x0Fu) << 8);
  const bool u2x = (d[m328p::kUCSR0A] >> m328p::kU2X0) & 1;
  return static_cast<uint64_t>(ubrr + 1) * (u2x ? 8 : 16);  // datasheet §19.3.1
}

FrameFormat UartLink::tx_format() const {
  const uint8_t* d = avr_->data;
  const unsigned ucsz = ((d[m328p::kUCSR0C] >> m328p::kUCSZ00) & 0x3u) | (((d[m328p::kUCSR0B] >> m328p::kUCSZ02) & 1u) << 2);
  FrameFormat f;
  f.data_bits = ucsz < 4 ? 5 + static_cast<int>(ucsz) : 8;  // 9-bit characters: not modelled
  const bool parity = (d[m328p::kUCSR0C] >> m328p::kUPM01) & 1;
  const bool odd = (d[m328p::kUCSR0C] >> m328p::kUPM00) & 1;
  f.parity = !parity ? Parity::kNone : odd ? Parity::kOdd : Parity::kEven;
  f.stop_bits = 1 + ((d[m328p::kUCSR0C] >> m328p::kUSBS0) & 1);
  return f;
}

uint64_t UartLink::frame_cycles() const { return bit_cycles() * static_cast<uint64_t>(tx_format().bits()); }

double UartLink::mcu_baud() const { return static_cast<double>(avr_->frequency) / static_cast<double>(bit_cycles()); }

void UartLink::correct_simavr_timing() {
  if (uart_) uart_->cycles_per_byte = frame_cycles();
}

void UartLink::on_output(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<UartLink*>(param);
  // Raised from simavr's UDR write, before it schedules its TX-complete timer.
  self->correct_simavr_timing();
  const FrameFormat format = self->tx_format();
  const uint64_t bit = self->bit_cycles();
  const uint64_t start = std::max(self->avr_->cycle, self->tx_line_free_cycle_);
  self->tx_frame_start_cycle_ = start;
  self->tx_line_free_cycle_ = start + bit * static_cast<uint64_t>(format.bits());
  ++self->stats_.tx_bytes;
  uint8_t byte = static_cast<uint8_t>(value);
  if (self->bursts_.drops(self->seconds(static_cast<double>(start)), self->faults_.uart_burst_drop)) {
    ++self->stats_.tx_burst_dropped;
    return;  // the line stays idle for its frame
  }
  if (self->rng_tx_.chance(self->faults_.uart_tx_drop)) {
    ++self->stats_.tx_dropped;
    return;  // the line stays idle for its frame
  }
  if (self->rng_tx_.chance(self->faults_.uart_tx_corrupt)) {
    byte ^= static_cast<uint8_t>(1u << self->rng_tx_.below(static_cast<uint32_t>(format.data_bits)));
    ++self->stats_.tx_corrupted;
  }
  LineWaveform::Frame f;
  f.start = static_cast<double>(start);
  f.bit = static_cast<double>(bit);
  f.bits = static_cast<uint8_t>(format.bits());
  f.levels = frame_levels(byte, format);
  self->adapter_.mcu_sent(f);
}

void UartLink::send_to_mcu(uint8_t byte) {
  const double now = static_cast<double>(avr_->cycle);
  const double frame = adapter_.bit_cycles() * 10.0;
  if (adapter_.to_mcu_idle_at() - now > kQueueCapBytes * frame) {
    ++stats_.host_overflow;
    return;
  }
  if (bursts_.drops(seconds(now), faults_.uart_burst_drop)) {
    ++stats_.rx_burst_dropped;
    adapter_.send_nothing(now);
    return;
  }
  if (rng_rx_.chance(faults_.uart_rx_drop)) {
    ++stats_.rx_dropped;
    adapter_.send_nothing(now);  // the byte's time on the wire passes all the same
    return;
  }
  if (rng_rx_.chance(faults_.uart_rx_corrupt)) {
    byte ^= static_cast<uint8_t>(1u << rng_rx_.below(8));
    ++stats_.rx_corrupted;
  }
  ++stats_.rx_line_bytes;
  adapter_.send(byte, now);
}

void UartLink::line_changed() {
  usart_rx_.line_changed();
  forget_used_line();
}

void UartLink::forget_used_line() {
  const double now = static_cast<double>(avr_->cycle);
  adapter_.forget_to_mcu_before(std::min(usart_rx_.needed_from(), now));
}

void UartLink::rearm_after_reset() {
  // avr_reset() cleared the registers and our timers; what the host sent goes on arriving (the
  // sender does not know the MCU reset), and the frame being sent stops after its current bit.
  // Called from within avr_reset() (before simavr's own UART reset, its list being in reverse
  // order of registration) and again by the Rig: doing it twice changes nothing.
  usart_rx_.after_reset();
  adapter_.mcu_line_released(static_cast<double>(avr_->cycle));
  tx_line_free_cycle_ = avr_->cycle;
}

size_t UartLink::read_host() {
  std::string in;
  pty_.read(&in);
  if (in.empty()) return 0;
  for (const char c : in) send_to_mcu(static_cast<uint8_t>(c));
  line_changed();
  return in.size();
}

void UartLink::inject(const std::string& bytes) {
  for (const char c : bytes) send_to_mcu(static_cast<uint8_t>(c));
  line_changed();
}

std::string UartLink::take_output(uint64_t now_cycle, std::vector<double>* ready) {
  std::string out;
  adapter_.collect(static_cast<double>(now_cycle), &out, ready);
  return out;
}

void UartLink::write_host(uint64_t now_cycle) {
  std::string out;
  adapter_.collect(static_cast<double>(now_cycle), &out);
  forget_used_line();
  if (!pty_.is_open()) return;
  if (!pty_.host_attached()) {
    stats_.tx_no_host += out.size();  // the adapter drops what no host reads
    return;
  }
  host_out_ += out;
  pty_.write(&host_out_);
  // The host does not read: keep the newest bytes only, as a UART with no listener loses them anyway.
  const size_t cap = static_cast<size_t>(kQueueCapBytes);
  if (host_out_.size() > cap) {
    stats_.host_overflow += host_out_.size() - cap;
    host_out_.erase(0, host_out_.size() - cap);
  }
}

UartLink::Stats UartLink::stats() const {
  Stats s = stats_;
  const UsartReceiver::Stats& r = usart_rx_.stats();
  s.rx_bytes = r.frames;
  s.rx_overruns = r.overruns;
  s.rx_frame_errors = r.frame_errors;
  s.rx_parity_errors = r.parity_errors;
  s.tx_frame_errors = adapter_.stats().frame_errors;
  return s;
}

}  // namespace cart2d
