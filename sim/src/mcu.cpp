#include "mcu.hpp"

#include <cerrno>    // errno
#include <cstdarg>   // va_list
#include <cstdio>    // vsnprintf, fopen
#include <cstdlib>   // free
#include <cstring>   // strcmp, strerror
#include <memory>    // unique_ptr

#include "log.hpp"

extern "C" {
#include <avr_extint.h>  // avr_extint_set_strict_lvl_trig
#include <sim_avr.h>     // avr_t, avr_run, avr_reset, avr_global_logger_set
#include <sim_elf.h>     // elf_read_firmware, avr_load_firmware
#include <sim_hex.h>     // read_ihex_chunks, free_ihex_chunks
#include <sim_regbit.h>  // avr_regbit_set
}

namespace cart2d {

// simavr's sleep callback has no user pointer; one simulated MCU per process.
Mcu* g_mcu = nullptr;  // mcu_reset.cpp clears it

// simavr logs through one global function; the default writes traces to stdout, which must
// stay reserved for the ready line.
static void simavr_logger(avr_t*, const int level, const char* format, va_list ap) {
  if (level >= LOG_TRACE && log_level() < LogLevel::kDebug) return;
  char buf[512];
  std::vsnprintf(buf, sizeof buf, format, ap);
  size_t n = std::strlen(buf);
  while (n > 0 && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) buf[--n] = 0;
  if (n == 0) return;
  // simavr's warnings are mostly about register writes in an order it does not expect (OCR1A
  // before TCCR1B at start-up); the parts report what matters to us themselves.
  if (level <= LOG_ERROR) LOG_WARN("simavr: %s", buf);
  else LOG_DEBUG("simavr: %s", buf);
}

// simavr 1.6 emulates INT0/INT1's low-level mode by polling the pin every cycle from the moment
// it reads low in that mode (the power-on default, ISC = 00), and the poll only ends when the pin
// goes high: after the firmware has switched to ANY-edge mode it still raises the interrupt on
// every cycle while an encoder rests with A low. Turning the strict level emulation off makes
// the low-level mode act like a falling edge, which our firmware never uses anyway.
void disable_level_poll(avr_t* avr) {
  avr_extint_set_strict_lvl_trig(avr, 0, 0);
  avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

// ---------------------------------------------------------------------------------------------
// Intel HEX (what avr-objcopy -O ihex makes and avrdude flashes). simavr 1.6 has a reader,
// read_ihex_chunks(), but it trusts its input: it stops quietly at a bad checksum (keeping what it
// read so far), skips lines with bad characters, never checks a record's length byte against the
// line (and copies that many bytes from a 64-byte buffer), and avr_loadcode() abort()s on data
// beyond the flash. So the file is validated completely here first, and what simavr then reads
// must be exactly what the file says, byte for byte, before anything is loaded.

namespace {

constexpr uint32_t kFlashBytes = 32768;        // ATmega328P
constexpr size_t kMaxHexFileBytes = 4u << 20;  // ~10x the largest hex of a 32 KiB flash
// read_ihex_chunks() reads each line with fgets() into 127 bytes: 126 characters including the
// line end. A longer line would be split and its tail taken for a malformed record.
constexpr size_t kSimavrMaxLine = 126;

enum class Format { kElf, kIntelHex };

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
bool sniff(const std::string& path, Format* format, std::string* text, std::string* error) {
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
      *format = Format::kElf;
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
  *format = Format::kIntelHex;
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

bool Mcu::load(const std::string& path, uint32_t f_cpu_hz, std::string* error) {
  avr_global_logger_set(simavr_logger);
  Format format = Format::kElf;
  std::string text;
  if (!sniff(path, &format, &text, error)) {
    *error = "firmware " + path + ": " + *error;
    return false;
  }
  if (format == Format::kIntelHex) return load_ihex(path, text, f_cpu_hz, error);

  const std::string& elf_path = path;
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(elf_path.c_str(), &fw) != 0) {
    *error = "cannot read firmware ELF " + elf_path;
    return false;
  }
  if (fw.mmcu[0] && std::strcmp(fw.mmcu, "atmega328p") != 0)
    LOG_WARN("firmware declares mmcu '%s'; simulating an atmega328p anyway", fw.mmcu);
  if (!create_avr(error)) return false;
  // Without an .mmcu section the ELF says nothing about the clock: use robot.toml's.
  if (fw.frequency && fw.frequency != f_cpu_hz)
    LOG_WARN("firmware declares %u Hz, robot.toml says %u Hz: using robot.toml", fw.frequency, f_cpu_hz);
  fw.frequency = f_cpu_hz;
  avr_load_firmware(avr_, &fw);
  // simavr copied what it needs; the reader's buffers are ours to free (it has no free call).
  free(fw.flash);
  free(fw.eeprom);
  free(fw.fuse);
  free(fw.lockbits);
  for (uint32_t i = 0; i < fw.symbolcount; ++i) free(fw.symbol[i]);
  free(fw.symbol);
  finish_load(f_cpu_hz);
  return true;
}

bool Mcu::create_avr(std::string* error) {
  avr_ = avr_make_mcu_by_name("atmega328p");
  if (!avr_) {
    *error = "simavr does not know the atmega328p";
    return false;
  }
  avr_init(avr_);
  disable_level_poll(avr_);
  g_mcu = this;
  watch_resets();
  return true;
}

void Mcu::finish_load(uint32_t f_cpu_hz) {
  avr_->frequency = f_cpu_hz;
  f_cpu_hz_ = f_cpu_hz;
  // Sleeping only skips cycles to the next timer event; pacing to wall time happens in our loop.
  avr_->sleep = sleep_callback;
  after_reset(ResetCause::kPowerOn, 0);  // power is applied: PORF, random SRAM, the time-out
}

bool Mcu::load_ihex(const std::string& path, const std::string& text, uint32_t f_cpu_hz, std::string* error) {
  HexImage img;
  std::vector<uint8_t> flash;
  uint32_t base = 0;
  std::string why;
  if (!parse_ihex(text, &img, &why) || !read_ihex_with_simavr(path, img, &flash, &base, &why)) {
    *error = "firmware " + path + ": " + why;
    return false;
  }
  if (!create_avr(error)) return false;
  // A .hex carries flash only: no clock, no mmcu, no .eeprom (avr-objcopy -R .eeprom). The MCU
  // starts at the reset vector, address 0, wherever the image begins.
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  fw.frequency = f_cpu_hz;
  fw.flash = flash.data();
  fw.flashsize = static_cast<uint32_t>(flash.size());
  fw.flashbase = base;
  avr_load_firmware(avr_, &fw);  // copies the flash
  finish_load(f_cpu_hz);
  LOG_INFO("firmware %s: Intel HEX, %u bytes of flash at 0x%04X-0x%04X", path.c_str(), img.count, base,
           base + fw.flashsize - 1);
  return true;
}

uint64_t Mcu::cycle() const { return avr_ ? avr_->cycle : 0; }

void Mcu::sleep_callback(avr_t* avr, uint64_t how_long) {
  (void)how_long;
  Mcu* self = g_mcu;
  if (!self || self->avr_ != avr) return;
  // The core calls this on every timer event while asleep; only the first call is the moment
  // the CPU went to sleep (avr->pc already points past the SLEEP instruction).
  if (!self->was_sleeping_) {
    if (self->sleep_hook_) self->sleep_hook_(avr->cycle);
    if (self->hang_requested_) self->plant_hang(avr->pc);
  }
  self->was_sleeping_ = true;
}

void Mcu::set_profile_gate(const bool* gate) {
  profile_gate_ = gate;
  if (gate && profile_.empty()) profile_.assign(32768 / 2, 0);  // one slot per flash word
}

bool Mcu::run_until(uint64_t target_cycle) {
  for (;;) {
    if (holding_ && avr_->cycle >= release_cycle_) release();
    if (avr_->cycle >= target_cycle) return true;
    if (holding_) {
      hold(std::min(target_cycle, release_cycle_));
      continue;
    }
    const uint32_t pc = avr_->pc;
    const uint64_t before = avr_->cycle;
    const int state = avr_run(avr_);
    if (avr_reset_seen_) {  // the watchdog reset the core on its own, inside avr_run()
      after_reset(ResetCause::kWatchdog, 0);
      continue;
    }
    if (profile_gate_ && *profile_gate_ && state == cpu_Running) profile_[(pc / 2) % profile_.size()] += avr_->cycle - before;
    if (state == cpu_Running) {
      if (was_sleeping_) note_wake();
      was_sleeping_ = false;
    } else if (state != cpu_Sleeping) {
      return false;
    }
  }
}

bool Mcu::alive() const {
  return avr_ && (holding_ || avr_->state == cpu_Running || avr_->state == cpu_Sleeping);
}

const char* Mcu::state_name() const {
  if (!avr_) return "none";
  if (holding_) return "reset";
  switch (avr_->state) {
    case cpu_Limbo: return "limbo";
    case cpu_Stopped: return "stopped";
    case cpu_Running: return "running";
    case cpu_Sleeping: return "sleeping";
    case cpu_Step: return "step";
    case cpu_StepDone: return "step_done";
    case cpu_Done: return "done";
    case cpu_Crashed: return "crashed";
    default: return "unknown";
  }
}

}  // namespace cart2d
