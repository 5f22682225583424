// Firmware files: telling an ELF from Intel HEX, reading Intel HEX strictly (and checking that
// simavr's own reader gets the very same bytes), and the checks that make a HEX an application a
// Nano can run below its bootloader. The simulator loads through these functions and the
// gateway's firmware update checks uploads through them (`cart2d-sim --check-firmware FILE`), so
// a file is refused by both or by neither.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cart2d {

enum class FirmwareFormat { kElf, kIntelHex };

// Reads the file and tells ELF (by its magic number) from Intel HEX (the first non-empty line
// starts with ':'); anything else is refused with a reason. An ELF is read no further than its
// magic number; the text of a HEX is returned in *text.
bool sniff_firmware(const std::string& path, FirmwareFormat* format, std::string* text, std::string* error);

// The flash an Intel HEX file gives: bytes from `base` on, gaps erased (0xFF).
struct FlashImage {
  std::vector<uint8_t> flash;
  uint32_t base = 0;
  uint32_t data_bytes = 0;  // bytes the data records give (gaps not counted)
};

// Strict Intel HEX (`text` is the content of `path`; see firmware_file.cpp), then simavr's
// reader on `path`, which must read exactly what the file says. False with *error = the reason.
bool read_intel_hex(const std::string& path, const std::string& text, FlashImage* image, std::string* error);

// An ATmega328P application for a Nano with Optiboot: it ends below the bootloader's 512 bytes
// and starts with the interrupt vector table's 26 jumps. False with *error = the reason.
bool check_nano_application(const FlashImage& image, std::string* error);

// `cart2d-sim --check-firmware FILE`: the firmware update's check of an uploaded file. Prints one
// JSON line, {"ok":true,"bytes":N,"end":E} or {"ok":false,"error":"..."}, and returns the exit
// status (0 when the file passes).
int check_firmware_command(const std::string& path);

}  // namespace cart2d
