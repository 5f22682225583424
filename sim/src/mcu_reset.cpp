// Resets as the ATmega328P has them (datasheet DS40002061B §11 "System Control and Reset"), one
// path for every cause, and the hang injection that the next reset undoes.
//
// simavr's watchdog resets the core by itself, from inside avr_run() (it swaps avr->run for a
// callback that calls avr_reset()), and avr_reset() clears every cycle timer. To see that reset
// like any other, an avr_io_t of ours is registered: avr_reset() calls every module's reset()
// after clearing the timers. Ours only notes it; run_until() then takes the common path once
// avr_run() has returned, when every module (the watchdog's own reset() included) is done.
#include <cstdlib>  // free
#include <cstring>  // memset

#include "atmega328p.hpp"
#include "log.hpp"
#include "mcu.hpp"
#include "rng.hpp"
#include "robot_params.hpp"  // params::sim

extern "C" {
#include <avr_watchdog.h>  // AVR_IOCTL_WATCHDOG_RESET
#include <sim_avr.h>       // avr_t, avr_reset, avr_terminate
#include <sim_cycle_timers.h>  // avr_cycle_timer_process
#include <sim_io.h>        // avr_io_t, avr_register_io, avr_register_io_write, avr_ioctl
}

namespace cart2d {

void disable_level_poll(avr_t* avr);  // mcu.cpp
extern Mcu* g_mcu;                      // mcu.cpp: simavr's sleep callback has no user pointer

struct Mcu::ResetWatch {
  avr_io_t io;  // first: simavr hands us the avr_io_t*
  Mcu* mcu;
};

const char* reset_cause_name(ResetCause cause) {
  switch (cause) {
    case ResetCause::kPowerOn: return "power";
    case ResetCause::kExternal: return "external";
    case ResetCause::kBrownOut: return "brownout";
    case ResetCause::kWatchdog: return "watchdog";
  }
  return "unknown";
}

Mcu::Mcu() = default;  // here, where ResetWatch is complete

Mcu::~Mcu() {
  if (avr_) {
    avr_terminate(avr_);  // still walks our ResetWatch: destroyed after this body
    free(avr_);           // allocated by the core maker with malloc
  }
  if (g_mcu == this) g_mcu = nullptr;
}

uint64_t Mcu::timeout_cycles() const {
  return static_cast<uint64_t>(static_cast<double>(params::sim::reset_timeout_s) * f_cpu_hz_ + 0.5) +
         static_cast<uint64_t>(params::sim::reset_timeout_ck);
}

void Mcu::watch_resets() {
  watch_ = std::make_unique<ResetWatch>();
  std::memset(&watch_->io, 0, sizeof watch_->io);
  watch_->io.kind = "cart2d-reset-watch";
  watch_->io.reset = on_avr_reset;
  watch_->mcu = this;
  avr_register_io(avr_, &watch_->io);
  // MCUSR's flags are cleared only by writing zeros to them (§11.9.1), and they must outlive
  // avr_reset(), which zeroes every I/O register: software writes go through us.
  avr_register_io_write(avr_, m328p::kMCUSR, on_mcusr_write, this);
  // Wrapped in place, not registered beside simavr's writer (a shared slot of its four).
  auto& w = avr_->io[AVR_DATA_TO_IO(m328p::kWDTCSR)].w;
  simavr_wdtcsr_write_ = w.c;
  simavr_wdtcsr_param_ = w.param;
  w.c = on_wdtcsr_write;
  w.param = this;
}

// A new watchdog time-out takes effect at once (§11.9.2: the timed sequence, WDCE then the new
// WDP bits). simavr 1.6's avr_watchdog_write() reads the "old" prescaler after storing the new
// one, sees no change and leaves its timer at the old period: Optiboot's verifySpace(), which
// shortens its 1 s to 16 ms to start the application when a byte is not STK500, then ran on for
// up to 1 s. The timer restarts from the change with the new period: the chip's counter goes
// on from the last WDR instead, the same for Optiboot, which changes it just after one (getch()).
void Mcu::on_wdtcsr_write(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  Mcu* self = static_cast<Mcu*>(param);
  const uint8_t wdp_before = avr->data[addr] & m328p::kWDP;
  if (self->simavr_wdtcsr_write_) self->simavr_wdtcsr_write_(avr, addr, v, self->simavr_wdtcsr_param_);
  else avr->data[addr] = v;
  const uint8_t now = avr->data[addr];
  if ((now & m328p::kWDP) != wdp_before && (now & (m328p::kWDE | m328p::kWDIE)))
    avr_ioctl(avr, AVR_IOCTL_WATCHDOG_RESET, nullptr);  // its timer from now, at the new period
}

void Mcu::on_avr_reset(avr_io_t* io) { reinterpret_cast<ResetWatch*>(io)->mcu->avr_reset_seen_ = true; }

void Mcu::on_mcusr_write(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  Mcu* self = static_cast<Mcu*>(param);
  self->mcusr_ = static_cast<uint8_t>(self->mcusr_ & v & 0x0F);  // a one leaves its flag as it is
  avr->data[addr] = self->mcusr_;
}

void Mcu::reset(ResetCause cause, uint64_t off_cycles) {
  avr_reset(avr_);
  after_reset(cause, off_cycles);
}

// What every reset does once avr_reset() has returned (registers at their reset values, cycle
// timers gone, the watchdog's own reset() done).
void Mcu::after_reset(ResetCause cause, uint64_t off_cycles) {
  avr_reset_seen_ = false;
  disable_level_poll(avr_);  // avr_reset() turned it back on
  uint8_t* d = avr_->data;
  // §11.9.1 MCUSR: a power-on reset leaves PORF alone; the other causes add their flag to
  // whatever software has not cleared yet.
  switch (cause) {
    case ResetCause::kPowerOn: mcusr_ = m328p::kPORF; break;
    case ResetCause::kExternal: mcusr_ |= m328p::kEXTRF; break;
    case ResetCause::kBrownOut: mcusr_ |= m328p::kBORF; break;
    case ResetCause::kWatchdog: mcusr_ |= m328p::kWDRF; break;
  }
  d[m328p::kMCUSR] = mcusr_;
  // Without power the SRAM forgets; external and watchdog resets keep it (.noinit survives).
  if (cause == ResetCause::kPowerOn || cause == ResetCause::kBrownOut) scramble_sram();
  restore_hang_word();
  hang_requested_ = hang_waiting_wake_ = false;
  was_sleeping_ = false;

  // The time-out: no instruction runs and the watchdog does not count until it has elapsed
  // (simavr restarts the watchdog after its own reset: WDRF forces WDE, §11.9.2).
  holding_ = true;
  release_cycle_ = avr_->cycle + off_cycles + timeout_cycles();
  held_wdt_bits_ = d[m328p::kWDTCSR] & (m328p::kWDE | m328p::kWDIE);
  d[m328p::kWDTCSR] &= static_cast<uint8_t>(~(m328p::kWDE | m328p::kWDIE));  // its timer then ends silently

  ++resets_[static_cast<int>(cause)];
  LOG_DEBUG("MCU reset (%s) at cycle %llu; runs again at cycle %llu", reset_cause_name(cause),
            static_cast<unsigned long long>(avr_->cycle), static_cast<unsigned long long>(release_cycle_));
  if (reset_hook_) reset_hook_(cause);
}

// Power-on and brown-out: the register file and the SRAM hold whatever the cells settle to; a
// seeded pattern, so runs repeat (and never zeros, which would hide missing initialisation).
void Mcu::scramble_sram() {
  Rng rng(seed_, kStreamSram + resets_[static_cast<int>(ResetCause::kPowerOn)] * 16 +
                     resets_[static_cast<int>(ResetCause::kBrownOut)]);
  uint8_t* d = avr_->data;
  for (uint16_t a = 0; a <= m328p::kRegisterFileEnd; ++a) d[a] = static_cast<uint8_t>(rng.next());
  for (uint32_t a = m328p::kSramStart; a <= m328p::kSramEnd && a <= avr_->ramend; ++a)
    d[a] = static_cast<uint8_t>(rng.next() >> 24);
}

// Held in reset: time passes (the parts' cycle timers fire at their cycles) but the CPU runs no
// instruction and serves no interrupt.
void Mcu::hold(uint64_t limit_cycle) {
  while (avr_->cycle < limit_cycle) {
    const uint64_t until_next = avr_cycle_timer_process(avr_);  // fires those due by now
    const uint64_t next = avr_->cycle + (until_next > 0 ? until_next : 1);
    avr_->cycle = next < limit_cycle ? next : limit_cycle;
  }
}

// The reset is released: registers are still at their reset values, so the interrupt flags that
// pin changes raised in simavr while the chip was held are cleared; the watchdog starts counting.
void Mcu::release() {
  holding_ = false;
  uint8_t* d = avr_->data;
  d[m328p::kEIFR] = 0;
  d[m328p::kPCIFR] = 0;
  d[m328p::kWDTCSR] |= held_wdt_bits_;
  if (held_wdt_bits_) avr_ioctl(avr_, AVR_IOCTL_WATCHDOG_RESET, nullptr);  // (re)starts its timer from now
  held_wdt_bits_ = 0;
  avr_->state = cpu_Running;
}

// ---------------------------------------------------------------------------------------------
// Hang injection.

void Mcu::request_hang() {
  // Asleep now: avr->pc already points past the SLEEP instruction.
  if (!holding_ && avr_->state == cpu_Sleeping) plant_hang(avr_->pc);
  else hang_requested_ = true;
}

void Mcu::plant_hang(uint32_t pc) {
  hang_requested_ = false;
  if (hang_patched_ || pc + 1 > avr_->flashend) return;
  hang_pc_ = pc;
  hang_saved_word_ = static_cast<uint16_t>(avr_->flash[pc] | (avr_->flash[pc + 1] << 8));
  avr_->flash[pc] = static_cast<uint8_t>(m328p::kOpRjmpSelf & 0xFF);
  avr_->flash[pc + 1] = static_cast<uint8_t>(m328p::kOpRjmpSelf >> 8);
  hang_patched_ = true;
  hang_waiting_wake_ = true;
}

void Mcu::note_wake() {
  if (!hang_waiting_wake_) return;
  hang_waiting_wake_ = false;
  hang_began_ = true;
  hang_cycle_ = avr_->cycle;
  LOG_INFO("main loop hung at t = %.6f s (rjmp . at 0x%04X)", time_s(), hang_pc_);
}

bool Mcu::take_hang_began(uint64_t* cycle) {
  if (!hang_began_) return false;
  hang_began_ = false;
  *cycle = hang_cycle_;
  return true;
}

void Mcu::restore_hang_word() {
  if (!hang_patched_) return;
  avr_->flash[hang_pc_] = static_cast<uint8_t>(hang_saved_word_ & 0xFF);
  avr_->flash[hang_pc_ + 1] = static_cast<uint8_t>(hang_saved_word_ >> 8);
  hang_patched_ = false;
}

}  // namespace cart2d
