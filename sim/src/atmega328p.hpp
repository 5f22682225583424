// ATmega328P facts the parts need: data-space register addresses (datasheet DS40002061B,
// "Register Summary": I/O address + 0x20), bit positions and vector numbers. Kept here, once,
// because the simulator is a C++ host program and cannot include avr-libc's <avr/io.h>.
#pragma once

#include <cstdint>

namespace cart2d::m328p {

constexpr uint16_t kPINB = 0x23, kDDRB = 0x24, kPORTB = 0x25;
constexpr uint16_t kPINC = 0x26, kDDRC = 0x27, kPORTC = 0x28;
constexpr uint16_t kPIND = 0x29, kDDRD = 0x2A, kPORTD = 0x2B;

// Timer/Counter1 (datasheet §15.11).
constexpr uint16_t kTCCR1A = 0x80, kTCCR1B = 0x81;
constexpr uint16_t kICR1L = 0x86, kICR1H = 0x87;
constexpr uint16_t kOCR1AL = 0x88, kOCR1AH = 0x89, kOCR1BL = 0x8A, kOCR1BH = 0x8B;
constexpr int kCOM1A0 = 6;  // COM1A1:0 = TCCR1A bits 7:6
constexpr int kCOM1B0 = 4;  // COM1B1:0 = TCCR1A bits 5:4

// USART0 (datasheet §19.10).
constexpr uint16_t kUCSR0A = 0xC0, kUCSR0B = 0xC1, kUCSR0C = 0xC2, kUBRR0L = 0xC4, kUBRR0H = 0xC5;
constexpr uint16_t kUDR0 = 0xC6;
constexpr int kRXC0 = 7, kFE0 = 4, kDOR0 = 3, kUPE0 = 2;  // UCSR0A receiver flags
constexpr int kU2X0 = 1;    // UCSR0A
constexpr int kRXCIE0 = 7, kRXEN0 = 4;  // UCSR0B
constexpr int kUCSZ02 = 2;  // UCSR0B
constexpr int kUCSZ00 = 1;  // UCSR0C bits 2:1
constexpr int kUSBS0 = 3;   // UCSR0C
constexpr int kUPM00 = 4;   // UCSR0C: odd parity when set (with UPM01)
constexpr int kUPM01 = 5;   // UCSR0C: parity enabled when set

// Reset and watchdog (datasheet §11.9): MCUSR flags, WDTCSR enables.
constexpr uint16_t kMCUSR = 0x54, kWDTCSR = 0x60;
constexpr uint8_t kPORF = 1u << 0, kEXTRF = 1u << 1, kBORF = 1u << 2, kWDRF = 1u << 3;
constexpr uint8_t kWDE = 1u << 3, kWDIE = 1u << 6;
constexpr uint8_t kWDP = 0x27;  // WDP3 (bit 5) and WDP2..0: the time-out, 2K << WDP cycles at 128 kHz
// Interrupt flag registers a held reset keeps at their reset value (§12.2.4, §12.2.6).
constexpr uint16_t kPCIFR = 0x3B, kEIFR = 0x3C;

// EEPROM (datasheet §8.6): EECR bits, data and address registers.
constexpr uint16_t kEECR = 0x3F, kEEDR = 0x40, kEEARL = 0x41, kEEARH = 0x42;
constexpr uint8_t kEERE = 1u << 0, kEEPE = 1u << 1, kEEMPE = 1u << 2, kEERIE = 1u << 3;
constexpr uint8_t kEEPM0 = 1u << 4, kEEPM1 = 1u << 5;

// Memory map (§8.3): the register file, then I/O, then 2 KiB of SRAM.
constexpr uint16_t kRegisterFileEnd = 0x1F;
constexpr uint16_t kSramStart = 0x100, kSramEnd = 0x8FF;

// `rjmp .`, a jump to itself (AVR Instruction Set Manual).
constexpr uint16_t kOpRjmpSelf = 0xCFFF;

// Interrupt vector numbers (datasheet §11.1, Table 11-1, counting RESET as 0).
constexpr uint8_t kVectorTimer2CompA = 7;
constexpr uint8_t kVectorEeReady = 22;

constexpr uint32_t kEepromBytes = 1024;

// Boot loader support (datasheet §26, "Boot Loader Support – Read-While-Write Self-Programming"):
// with BOOTSZ = 11 (256 words, a Nano's high fuse 0xDE) the boot section is the last 512 bytes,
// and with BOOTRST programmed every reset starts there (§26.8.4, Table 26-7). Flash is written a
// page of 64 words at a time through SPMCSR (§26.9.1).
constexpr uint32_t kFlashBytes = 32768;
constexpr uint32_t kBootSectionStart = 0x7E00;  // byte address; word address 0x3F00
constexpr uint8_t kNanoFuseLow = 0xFF, kNanoFuseHigh = 0xDE, kNanoFuseExtended = 0xFD;
constexpr uint16_t kSPMCSR = 0x57;
constexpr uint8_t kSELFPRGEN = 1u << 0, kPGERS = 1u << 1, kPGWRT = 1u << 2, kRWWSB = 1u << 6;

// PINx / DDRx / PORTx of a port letter, 0 if the 328P has no such port.
constexpr uint16_t pin_register(char port) { return port == 'B' ? kPINB : port == 'C' ? kPINC : port == 'D' ? kPIND : 0; }
constexpr uint16_t ddr_register(char port) { return port == 'B' ? kDDRB : port == 'C' ? kDDRC : port == 'D' ? kDDRD : 0; }
constexpr uint16_t port_register(char port) { return port == 'B' ? kPORTB : port == 'C' ? kPORTC : port == 'D' ? kPORTD : 0; }

}  // namespace cart2d::m328p
