// Firmware files: ELF or Intel HEX, and the strict reading of Intel HEX (see firmware_file.hpp).
//
// Intel HEX is what avr-objcopy -O ihex makes and avrdude flashes. simavr 1.6 has a reader,
// read_ihex_chunks(), but it trusts its input: it stops quietly at a bad checksum (keeping what it
// read so far), skips lines with bad characters, never checks a record's length byte against the
// line (and copies that many bytes from a 64-byte buffer), and avr_loadcode() abort()s on data
// beyond the flash. So the file is validated completely here first, and what simavr then reads
// must be exactly what the file says, byte for byte, before anything is loaded.
#include "firmware_file.hpp"

#include <algorithm>  // std::min, std::max
#include <cerrno>     // errno
#include <cstdarg>    // va_list
#include <cstdio>     // vsnprintf, fopen, printf
#include <cstdlib>    // free
#include <cstring>    // strerror, memcpy
#include <memory>     // unique_ptr

#include "json.hpp"  // json::Object

extern "C" {
#include <sim_hex.h>  // read_ihex_chunks, free_ihex_chunks
}

namespace cart2d {

namespace {

constexpr uint32_t kFlashBytes = 32768;        // ATmega328P
constexpr size_t kMaxHexFileBytes = 4u << 20;  // ~10x the largest hex of a 32 KiB flash
// read_ihex_chunks() reads each line with fgets() into 127 bytes: 126 characters including the
// line end. A longer line would be split and its tail taken for a malformed record.
constexpr size_t kSimavrMaxLine = 126;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

std::string printf_string(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string printf_string(const char* format, ...) {
  char buf[256];
  va_list ap;
  va_start(ap, format);
  std::vsnprintf(buf, sizeof buf, format, ap);
  va_end(ap);
  return buf;
}

std::string show_char(unsigned char c) {
  return c >= 0x20 && c < 0x7f ? printf_string("'%c'", c) : printf_string("byte 0x%02X", c);
}

// The first characters of a line, printable, for messages.
std::string show_start(const std::string& text, size_t from) {
  std::string out = "\"";
  size_t i = from;
  for (; i < text.size() && i < from + 16 && text[i] != '\n' && text[i] != '\r'; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out += c >= 0x20 && c < 0x7f ? std::string(1, static_cast<char>(c)) : printf_string("\\x%02X", c);
  }
  if (i < text.size() && text[i] != '\n' && text[i] != '\r') out += "...";
  return out + "\"";
}

// Reads the file and tells ELF (by its magic number) from Intel HEX (the first non-empty line
// starts with ':'); anything else is refused. An ELF is read no further than its magic number.
bool sniff_text(const std::string& path, FirmwareFormat* format, std::string* text, std::string* error) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) {
    *error = std::string("cannot open: ") + std::strerror(errno);
    return false;
  }
  text->clear();
  char buf[65536];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f.get())) > 0) {
    text->append(buf, n);
    if (text->size() >= 4 && text->compare(0, 4, "\x7f" "ELF") == 0) {
      *format = FirmwareFormat::kElf;
      return true;
    }
    if (text->size() > kMaxHexFileBytes) {
      *error = "not an ELF file, and too large for Intel HEX of a 32 KiB flash (more than 4 MiB)";
      return false;
    }
  }
  if (std::ferror(f.get())) {
    *error = std::string("cannot read: ") + std::strerror(errno);
    return false;
  }
  size_t first = 0;
  while (first < text->size() && is_space((*text)[first])) ++first;
  if (first == text->size()) {
    *error = text->empty() ? "empty file" : "empty file (only whitespace)";
    return false;
  }
  if ((*text)[first] != ':') {
    *error = "neither an ELF file nor Intel HEX (the first non-empty line should start with ':', it is " +
             show_start(*text, first) + ")";
    return false;
  }
  *format = FirmwareFormat::kIntelHex;
  return true;
}

// What the file says: the flash bytes it gives, and which.
struct HexImage {
  std::vector<uint8_t> bytes = std::vector<uint8_t>(kFlashBytes, 0xFF);
  std::vector<bool> given = std::vector<bool>(kFlashBytes, false);
  uint32_t count = 0;
  bool segment_records = false;  // any extended segment address (02) record
};

std::string beyond_flash_hint(uint32_t addr) {
  if (addr >= 0x810000 && addr < 0x820000)
    return "; 0x810000 is where avr-objcopy puts .eeprom: make the .hex with -R .eeprom";
  if (addr >= 0x820000 && addr < 0x840000)
    return "; 0x820000/0x830000 are where avr-objcopy puts .fuse/.lock: make the .hex with -R .fuse -R .lock";
  return "";
}

// Strict Intel HEX: every line a record ':' + hex digits (trailing whitespace allowed), length
// and checksum right, data records inside the flash and not overlapping, an end-of-file record
// and nothing after it. Record types 00, 01, 02, 04; 03/05 (start address) are ignored: the MCU
// starts at its reset vector.
bool parse_ihex(const std::string& text, HexImage* img, std::string* error) {
  uint32_t base = 0;  // from extended segment (02) / linear (04) address records
  bool eof = false;
  size_t pos = 0;
  for (int line = 1; pos < text.size(); ++line) {
    const size_t nl = text.find('\n', pos);
    const size_t end = nl == std::string::npos ? text.size() : nl + 1;
    const size_t raw_len = end - pos;  // with the line end, as fgets() sees it
    size_t len = raw_len;
    while (len > 0 && is_space(text[pos + len - 1])) --len;
    const char* rec = text.data() + pos;
    pos = end;
    const std::string where = "line " + std::to_string(line) + ": ";
    if (eof) {
      if (len > 0) {
        *error = where + "more text after the end-of-file record";
        return false;
      }
      continue;
    }
    if (len == 0) {
      *error = where + "empty line before the end-of-file record";
      return false;
    }
    if (rec[0] != ':') {
      *error = where + "not a record (starts with " + show_char(static_cast<unsigned char>(rec[0])) + ", not ':')";
      return false;
    }
    for (size_t i = 1; i < len; ++i) {
      if (hex_value(rec[i]) < 0) {
        *error = where + "bad character " + show_char(static_cast<unsigned char>(rec[i])) + " in column " +
                 std::to_string(i + 1) + " (records are hex digits)";
        return false;
      }
    }
    if ((len - 1) % 2 != 0) {
      *error = where + "odd number of hex digits";
      return false;
    }
    std::vector<uint8_t> b((len - 1) / 2);
    for (size_t i = 0; i < b.size(); ++i)
      b[i] = static_cast<uint8_t>(hex_value(rec[1 + 2 * i]) << 4 | hex_value(rec[2 + 2 * i]));
    if (b.size() < 5) {
      *error = where + "record too short (" + std::to_string(b.size()) + " bytes, at least 5)";
      return false;
    }
    uint8_t sum = 0;
    for (size_t i = 0; i + 1 < b.size(); ++i) sum = static_cast<uint8_t>(sum + b[i]);
    const uint8_t want = static_cast<uint8_t>(0x100 - sum);
    if (b.back() != want) {
      *error = where + printf_string("bad checksum %02X, the record's bytes need %02X", b.back(), want);
      return false;
    }
    const uint32_t n = b[0];
    if (n + 5 != b.size()) {
      *error = where + printf_string("record length %02X says %u data bytes, the record has %zu", b[0], n,
                                     b.size() - 5);
      return false;
    }
    if (raw_len > kSimavrMaxLine) {
      *error = where + "longer than the " + std::to_string(kSimavrMaxLine) +
               " characters (with the line end) simavr's ihex reader takes: use records of at most 32 data bytes";
      return false;
    }
    const uint32_t offset = static_cast<uint32_t>(b[1]) << 8 | b[2];
    const uint8_t type = b[3];
    switch (type) {
      case 0x00: {  // data
        if (n == 0) {
          *error = where + "data record without data";
          return false;
        }
        const uint32_t addr = base + offset;
        if (addr >= kFlashBytes || n > kFlashBytes - addr) {
          *error = where +
                   printf_string("%u data byte(s) at 0x%04X go beyond the 32 KiB flash (0x0000-0x7FFF)", n, addr) +
                   beyond_flash_hint(addr);
          return false;
        }
        for (uint32_t i = 0; i < n; ++i) {
          if (img->given[addr + i]) {
            *error = where + printf_string("data at 0x%04X overlaps an earlier record", addr + i);
            return false;
          }
          img->given[addr + i] = true;
          img->bytes[addr + i] = b[4 + i];
        }
        img->count += n;
        break;
      }
      case 0x01:  // end of file
        if (n != 0) {
          *error = where + "end-of-file record with data";
          return false;
        }
        eof = true;
        break;
      case 0x02:  // extended segment address
      case 0x04:  // extended linear address
        if (n != 2) {
          *error = where + printf_string("address record (type %02X) with %u data bytes, not 2", type, n);
          return false;
        }
        base = (static_cast<uint32_t>(b[4]) << 8 | b[5]) << (type == 0x02 ? 4 : 16);
        if (type == 0x02) img->segment_records = true;
        break;
      case 0x03:  // start segment address
      case 0x05:  // start linear address
        if (n != 4) {
          *error = where + printf_string("start address record (type %02X) with %u data bytes, not 4", type, n);
          return false;
        }
        break;
      default:
        *error = where + printf_string("unknown record type %02X", type);
        return false;
    }
  }
  if (!eof) {
    *error = "no end-of-file record (:00000001FF): truncated file?";
    return false;
  }
  if (img->count == 0) {
    *error = "no data records";
    return false;
  }
  return true;
}

// Reads the file with simavr's ihex reader, checks that it got exactly the validated image, and
// returns the flash from the lowest to the highest address given (gaps erased: 0xFF).
bool read_ihex_with_simavr(const std::string& path, const HexImage& img, std::vector<uint8_t>* flash,
                           uint32_t* base, std::string* error) {
  ihex_chunk_p chunks = nullptr;
  const int count = read_ihex_chunks(path.c_str(), &chunks);
  // free_ihex_chunks() frees each chunk's data; the array is the caller's.
  const std::unique_ptr<ihex_chunk_t, void (*)(ihex_chunk_t*)> owner(chunks, [](ihex_chunk_t* c) {
    free_ihex_chunks(c);
    free(c);
  });
  if (count <= 0 || !chunks) {
    *error = "simavr's ihex reader found no data in it";
    return false;
  }
  std::vector<bool> seen(kFlashBytes, false);
  uint32_t lo = kFlashBytes, hi = 0, total = 0;
  for (int i = 0; i < count; ++i) {
    const ihex_chunk_t& c = chunks[i];
    if (c.size == 0) continue;
    bool same = c.data && c.baseaddr < kFlashBytes && c.size <= kFlashBytes - c.baseaddr;
    for (uint32_t j = 0; same && j < c.size; ++j) {
      const uint32_t a = c.baseaddr + j;
      same = img.given[a] && !seen[a] && img.bytes[a] == c.data[j];
      seen[a] = true;
    }
    if (!same) {
      *error = printf_string("simavr's ihex reader does not read it as written (its chunk %d: %u byte(s) at 0x%04X)", i,
                             c.size, c.baseaddr);
      // simavr 1.6 ORs an extended segment address into the record's offset instead of adding.
      if (img.segment_records)
        *error += "; it ORs extended segment addresses (type 02) into the offsets instead of adding them";
      return false;
    }
    total += c.size;
    lo = std::min(lo, c.baseaddr);
    hi = std::max(hi, c.baseaddr + c.size);
  }
  if (total != img.count) {
    *error = printf_string("simavr's ihex reader got %u of its %u data bytes", total, img.count);
    return false;
  }
  flash->assign(hi - lo, 0xFF);
  for (int i = 0; i < count; ++i)
    if (chunks[i].size) std::memcpy(flash->data() + (chunks[i].baseaddr - lo), chunks[i].data, chunks[i].size);
  *base = lo;
  return true;
}

}  // namespace
bool sniff_firmware(const std::string& path, FirmwareFormat* format, std::string* text, std::string* error) {
  return sniff_text(path, format, text, error);
}

bool read_intel_hex(const std::string& path, const std::string& text, FlashImage* image, std::string* error) {
  HexImage img;
  if (!parse_ihex(text, &img, error)) return false;
  if (!read_ihex_with_simavr(path, img, &image->flash, &image->base, error)) return false;
  image->data_bytes = img.count;
  return true;
}

namespace {

// Optiboot takes the top 512 bytes of the ATmega328P's flash (its BOOTSZ fuses on a Nano: 256
// words, datasheet DS40002061B §27.8.16); avrdude refuses to write over it.
constexpr uint32_t kBootloaderBytes = 512;
// The interrupt vector table: 26 vectors of one 2-word slot each at address 0 (datasheet §12.1,
// Table 12-6). avr-gcc fills each with a JMP (0x940C), or an RJMP (0xCxxx) where the linker
// relaxed it. A file without it is not an ATmega328P program and leaves the MCU lost.
constexpr uint32_t kVectors = 26;
constexpr uint32_t kVectorBytes = 4;

bool is_jump(uint8_t low, uint8_t high) { return (low == 0x0C && high == 0x94) || (high & 0xF0) == 0xC0; }

}  // namespace

bool check_nano_application(const FlashImage& image, std::string* error) {
  const uint32_t end = image.base + static_cast<uint32_t>(image.flash.size());
  const uint32_t application_bytes = kFlashBytes - kBootloaderBytes;
  if (end > application_bytes) {
    *error = printf_string("the program ends at byte %u, beyond the %u bytes below the bootloader", end,
                           application_bytes);
    return false;
  }
  const uint32_t table_end = kVectors * kVectorBytes;
  bool table = image.base == 0 && image.flash.size() >= table_end;
  for (uint32_t v = 0; table && v < kVectors; ++v)
    table = is_jump(image.flash[v * kVectorBytes], image.flash[v * kVectorBytes + 1]);
  if (!table) {
    *error = "not an ATmega328P program: it does not start with the interrupt vector table's 26 jumps "
             "(build it with make firmware)";
    return false;
  }
  return true;
}

int check_firmware_command(const std::string& path) {
  FirmwareFormat format = FirmwareFormat::kElf;
  std::string text, error;
  FlashImage image;
  bool ok = sniff_firmware(path, &format, &text, &error);
  if (ok && format == FirmwareFormat::kElf) {
    error = "an ELF file: upload the Intel HEX that avrdude flashes (build/firmware/cart2d-nano.hex)";
    ok = false;
  }
  if (ok && !read_intel_hex(path, text, &image, &error)) {
    error = "not a valid Intel HEX file: " + error;
    ok = false;
  }
  ok = ok && check_nano_application(image, &error);
  const std::string line =
      ok ? json::Object()
               .add("ok", true)
               .add("bytes", static_cast<unsigned long long>(image.data_bytes))
               .add("end", static_cast<unsigned long long>(image.base + image.flash.size()))
               .str()
         : json::Object().add("ok", false).add("error", error).str();
  std::printf("%s\n", line.c_str());
  return ok ? 0 : 1;
}

}  // namespace cart2d
