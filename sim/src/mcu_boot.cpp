// The bootloader in the boot section: a Nano's Optiboot at 0x7E00 with BOOTRST programmed, so that
// every reset starts there (datasheet DS40002061B §26.8.4, Table 26-7), and the time its SPM
// page erases and writes take (spm_timing.hpp).
#include <cstdio>   // snprintf
#include <cstring>  // memcpy, memset

#include "atmega328p.hpp"
#include "firmware_file.hpp"  // sniff_firmware, read_intel_hex
#include "log.hpp"
#include "mcu.hpp"

extern "C" {
#include <avr_flash.h>         // AVR_IOCTL_FLASH_SPM
#include <sim_avr.h>           // avr_t, AVR_FUSE_*
#include <sim_cycle_timers.h>  // avr_cycle_timer_register
}

namespace cart2d {

static avr_cycle_count_t spm_done(avr_t* avr, avr_cycle_count_t when, void* param) {
  (void)when;
  (void)param;
  // The operation completes: hardware clears SELFPRGEN and the operation's bit (§26.9.1); RWWSB
  // stays set until software re-enables the RWW section (simavr's RWWSRE handling).
  avr->data[m328p::kSPMCSR] &= static_cast<uint8_t>(~(m328p::kSELFPRGEN | m328p::kPGERS | m328p::kPGWRT));
  return 0;
}

static int spm_ioctl(avr_io_t* port, uint32_t ctl, void* io_param) {
  if (ctl != AVR_IOCTL_FLASH_SPM) return -1;
  SpmTiming* self = reinterpret_cast<SpmTiming*>(port);
  avr_t* avr = port->avr;
  const uint8_t spmcsr = avr->data[m328p::kSPMCSR];
  const bool enabled = spmcsr & m328p::kSELFPRGEN;
  const bool erase = enabled && (spmcsr & m328p::kPGERS);
  const bool write = enabled && !erase && (spmcsr & m328p::kPGWRT);
  const int result = self->flash_io->ioctl(self->flash_io, ctl, io_param);  // simavr does the work
  if (erase || write) {
    self->pages_erased += erase;
    self->pages_written += write;
    avr->data[m328p::kSPMCSR] |= static_cast<uint8_t>(spmcsr & (m328p::kPGERS | m328p::kPGWRT)) |
                                 m328p::kSELFPRGEN | m328p::kRWWSB;
    avr_cycle_timer_register(avr, self->busy_cycles, spm_done, self);
  }
  return result;
}

bool SpmTiming::attach(avr_t* avr, uint32_t f_cpu_hz) {
  for (avr_io_t* port = avr->io_port; port; port = port->next)
    if (port->kind && !std::strcmp(port->kind, "flash")) flash_io = port;
  if (!flash_io || !flash_io->ioctl) return false;
  std::memset(&io, 0, sizeof io);
  io.kind = "cart2d-spm-timing";
  io.ioctl = spm_ioctl;
  busy_cycles = static_cast<uint64_t>(kSpmPageTime_s * f_cpu_hz + 0.5);
  avr_register_io(avr, &io);  // in front: avr_ioctl() asks the most recently registered first
  return true;
}

bool Mcu::load_bootloader(const std::string& path, std::string* error) {
  const auto refuse = [&](const std::string& why) {
    *error = "bootloader " + path + ": " + why;
    return false;
  };
  FirmwareFormat format = FirmwareFormat::kElf;
  std::string text, why;
  if (!sniff_firmware(path, &format, &text, &why)) return refuse(why);
  if (format != FirmwareFormat::kIntelHex) return refuse("not Intel HEX");
  FlashImage image;
  if (!read_intel_hex(path, text, &image, &why)) return refuse(why);
  const uint32_t end = image.base + static_cast<uint32_t>(image.flash.size());
  if (image.base < m328p::kBootSectionStart || end > m328p::kFlashBytes) {
    char range[96];
    std::snprintf(range, sizeof range, "0x%04X-0x%04X is not inside the boot section 0x%04X-0x%04X (BOOTSZ = 256 words)",
                  image.base, end - 1, m328p::kBootSectionStart, m328p::kFlashBytes - 1);
    return refuse(range);
  }
  for (uint32_t a = m328p::kBootSectionStart; a < m328p::kFlashBytes; ++a)
    if (avr_->flash[a] != 0xFF) return refuse("the application reaches into the boot section (0x7E00 up)");
  std::memcpy(avr_->flash + image.base, image.flash.data(), image.flash.size());
  // A Nano's fuses: BOOTRST programmed, BOOTSZ = 256 words. simavr 1.6 reads no fuse itself; its
  // avr_reset() starts at reset_pc, so that is what makes every reset go to the boot section.
  avr_->fuse[AVR_FUSE_LOW] = m328p::kNanoFuseLow;
  avr_->fuse[AVR_FUSE_HIGH] = m328p::kNanoFuseHigh;
  avr_->fuse[AVR_FUSE_EXT] = m328p::kNanoFuseExtended;
  avr_->reset_pc = m328p::kBootSectionStart;
  avr_->pc = m328p::kBootSectionStart;  // the power-on reset load() did has not run an instruction yet
  avr_->codeend = avr_->flashend;       // code may now be anywhere in flash
  spm_ = std::make_unique<SpmTiming>();
  if (!spm_->attach(avr_, f_cpu_hz_)) return refuse("simavr's atmega328p has no self-programming module");
  bootloader_ = true;
  LOG_INFO("bootloader %s: %u bytes at 0x%04X-0x%04X, BOOTRST: every reset starts at 0x%04X", path.c_str(),
           image.data_bytes, image.base, end - 1, m328p::kBootSectionStart);
  return true;
}

}  // namespace cart2d
