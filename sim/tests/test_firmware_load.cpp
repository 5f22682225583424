// Loading the firmware: the Intel HEX that avrdude flashes must give the same MCU as the ELF, and
// malformed files must be refused with a message (never a crash or a half-loaded flash).
// Uses build/firmware/cart2d-nano.{elf,hex} from `make firmware` at the repository root.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_file.hpp"
#include "mcu.hpp"
#include "rig.hpp"
#include "robot_params.hpp"

extern "C" {
#include <sim_avr.h>
#include <sim_elf.h>
}

namespace cart2d {
namespace {

const uint32_t kFcpu = static_cast<uint32_t>(params::control::f_cpu_hz);

bool exists(const std::string& path, struct stat* st) { return ::stat(path.c_str(), st) == 0; }

// The built firmware, or a failure that says how to build it.
::testing::AssertionResult firmware_built() {
  struct stat elf {}, hex {};
  if (!exists(CART2D_FIRMWARE_ELF, &elf) || !exists(CART2D_FIRMWARE_HEX, &hex))
    return ::testing::AssertionFailure() << CART2D_FIRMWARE_ELF << " or " << CART2D_FIRMWARE_HEX
                                         << " is missing: run `make firmware` at the repository root";
  if (hex.st_mtim.tv_sec < elf.st_mtim.tv_sec ||
      (hex.st_mtim.tv_sec == elf.st_mtim.tv_sec && hex.st_mtim.tv_nsec < elf.st_mtim.tv_nsec))
    return ::testing::AssertionFailure() << CART2D_FIRMWARE_HEX << " is older than the ELF: run `make firmware`";
  return ::testing::AssertionSuccess();
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> split_lines(const std::string& text) {  // without their "\r\n" / "\n"
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    lines.push_back(l);
  }
  return lines;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\r\n";
  return out;
}

// One Intel HEX record with a correct checksum.
std::string record(uint8_t type, uint16_t addr, const std::vector<uint8_t>& data) {
  std::vector<uint8_t> b = {static_cast<uint8_t>(data.size()), static_cast<uint8_t>(addr >> 8),
                            static_cast<uint8_t>(addr & 0xFF), type};
  b.insert(b.end(), data.begin(), data.end());
  uint8_t sum = 0;
  for (uint8_t v : b) sum = static_cast<uint8_t>(sum + v);
  b.push_back(static_cast<uint8_t>(0x100 - sum));
  std::string out = ":";
  char hex[3];
  for (uint8_t v : b) {
    std::snprintf(hex, sizeof hex, "%02X", v);
    out += hex;
  }
  return out;
}

class FirmwareLoad : public ::testing::Test {
 protected:
  void TearDown() override {
    for (const std::string& path : written_) std::remove(path.c_str());
  }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = ::testing::TempDir() + "cart2d_fw_" + name;
    std::ofstream(path, std::ios::binary) << text;
    written_.push_back(path);
    return path;
  }

  // The real hex, as lines, with `edit` applied.
  std::string real_hex_with(const std::string& name, void (*edit)(std::vector<std::string>*)) {
    std::vector<std::string> lines = split_lines(read_text(CART2D_FIRMWARE_HEX));
    edit(&lines);
    return write(name, join_lines(lines));
  }

  // Loading must fail, without building a core, with "firmware PATH: ..." containing `what`.
  void expect_refused(const std::string& path, const std::string& what) {
    Mcu mcu;
    std::string err;
    EXPECT_FALSE(mcu.load(path, kFcpu, &err));
    EXPECT_EQ(mcu.avr(), nullptr);
    EXPECT_EQ(err.rfind("firmware " + path + ": ", 0), 0u) << err;
    EXPECT_NE(err.find(what), std::string::npos) << "message: " << err;
    std::printf("  refused: %s\n", err.c_str());
  }

  std::vector<std::string> written_;
};

TEST_F(FirmwareLoad, HexGivesTheSameFlashAsTheElf) {
  ASSERT_TRUE(firmware_built());
  // The ELF's flash image: .text + .data (the initial values that crt copies to RAM).
  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  ASSERT_EQ(elf_read_firmware(CART2D_FIRMWARE_ELF, &fw), 0);
  const uint32_t size = fw.flashsize;
  std::free(fw.flash);
  std::free(fw.eeprom);
  std::free(fw.fuse);
  std::free(fw.lockbits);
  for (uint32_t i = 0; i < fw.symbolcount; ++i) std::free(fw.symbol[i]);
  std::free(fw.symbol);
  ASSERT_GT(size, 1000u);

  Mcu elf, hex;
  std::string err;
  ASSERT_TRUE(elf.load(CART2D_FIRMWARE_ELF, kFcpu, &err)) << err;
  ASSERT_TRUE(hex.load(CART2D_FIRMWARE_HEX, kFcpu, &err)) << err;
  EXPECT_STREQ(hex.avr()->mmcu, elf.avr()->mmcu);  // simavr's atmega328p core
  EXPECT_EQ(hex.avr()->frequency, kFcpu);
  EXPECT_EQ(hex.frequency_hz(), kFcpu);
  ASSERT_EQ(hex.avr()->flashend, elf.avr()->flashend);
  EXPECT_EQ(std::memcmp(hex.avr()->flash, elf.avr()->flash, size), 0) << "first " << size << " bytes differ";
  // Beyond the image both are erased flash.
  EXPECT_EQ(std::memcmp(hex.avr()->flash, elf.avr()->flash, elf.avr()->flashend + 1), 0);
  EXPECT_EQ(hex.avr()->flash[size], 0xFF);
}

TEST_F(FirmwareLoad, HexRunsLikeTheElf) {
  ASSERT_TRUE(firmware_built());
  // The whole rig (its UART part also turns off simavr's console printing of UART output), one
  // at a time: one simulated MCU per process.
  struct Run {
    std::string uart;
    std::vector<uint8_t> ram;
    uint32_t pc = 0;
  } runs[2];
  const char* files[2] = {CART2D_FIRMWARE_ELF, CART2D_FIRMWARE_HEX};
  for (int i = 0; i < 2; ++i) {
    Rig rig;
    RigConfig rc;
    rc.firmware = files[i];
    rc.open_pty = false;
    rc.start = Pose{0.9, 0.9, 0.0};
    std::string err;
    ASSERT_TRUE(rig.init(rc, &err)) << err;
    ASSERT_TRUE(rig.run_cycles(kFcpu / 2)) << files[i] << ": " << rig.mcu().state_name();  // 0.5 s
    runs[i].uart = rig.uart().take_output(rig.cycle());
    const avr_t* avr = rig.mcu().avr();
    runs[i].ram.assign(avr->data, avr->data + avr->ramend + 1);
    runs[i].pc = avr->pc;
  }
  EXPECT_GT(runs[1].uart.size(), 100u) << "no telemetry from the hex";
  EXPECT_TRUE(runs[0].uart == runs[1].uart) << "different UART output";
  EXPECT_EQ(runs[0].pc, runs[1].pc);
  EXPECT_TRUE(runs[0].ram == runs[1].ram) << "registers, I/O and SRAM differ after 0.5 s";
}

TEST_F(FirmwareLoad, HexDataGoesToItsAddresses) {
  // Lower-case digits, LF line ends, trailing blanks, an extended linear address of 0, a gap.
  const std::string text = record(0x04, 0, {0x00, 0x00}) + "\n" + record(0x00, 0x0000, {0x0C, 0x94, 0x34, 0x00}) +
                           "  \n" + record(0x00, 0x0100, {0xDE, 0xAD}) + "\n" + ":00000001ff\n\n";
  const std::string path = write("gap.hex", text);
  Mcu mcu;
  std::string err;
  ASSERT_TRUE(mcu.load(path, kFcpu, &err)) << err;
  const uint8_t* f = mcu.avr()->flash;
  EXPECT_EQ(f[0], 0x0C);
  EXPECT_EQ(f[3], 0x00);
  for (int a = 4; a < 0x100; ++a) ASSERT_EQ(f[a], 0xFF) << a;
  EXPECT_EQ(f[0x100], 0xDE);
  EXPECT_EQ(f[0x101], 0xAD);
  EXPECT_EQ(f[0x102], 0xFF);
  EXPECT_EQ(mcu.avr()->pc, 0u);  // the reset vector
}

TEST_F(FirmwareLoad, RefusesAFlippedChecksumDigit) {
  ASSERT_TRUE(firmware_built());
  const std::string path = real_hex_with("badsum.hex", [](std::vector<std::string>* l) {
    char& d = (*l)[2].back();
    d = d == '0' ? '1' : '0';
  });
  expect_refused(path, "line 3: bad checksum");
}

TEST_F(FirmwareLoad, RefusesARecordBeyond32KiB) {
  ASSERT_TRUE(firmware_built());
  const std::string at = real_hex_with("beyond.hex", [](std::vector<std::string>* l) {
    l->insert(l->end() - 1, record(0x00, 0x8000, std::vector<uint8_t>(16, 0)));
  });
  expect_refused(at, "16 data byte(s) at 0x8000 go beyond the 32 KiB flash");
  const std::string straddling = real_hex_with("straddle.hex", [](std::vector<std::string>* l) {
    l->insert(l->end() - 1, record(0x00, 0x7FF8, std::vector<uint8_t>(16, 0)));
  });
  expect_refused(straddling, "at 0x7FF8 go beyond the 32 KiB flash");
}

TEST_F(FirmwareLoad, RefusesAnEepromSectionWithAHint) {
  ASSERT_TRUE(firmware_built());
  const std::string path = real_hex_with("eeprom.hex", [](std::vector<std::string>* l) {
    l->insert(l->end() - 1, record(0x04, 0, {0x00, 0x81}));
    l->insert(l->end() - 1, record(0x00, 0, {1, 2, 3}));
  });
  expect_refused(path, "-R .eeprom");
}

TEST_F(FirmwareLoad, RefusesTextThatIsNotHex) {
  expect_refused(write("notes.txt", "GOTO 1.0 0.5\nthis is not firmware\n"),
                 "neither an ELF file nor Intel HEX");
}

TEST_F(FirmwareLoad, RefusesEmptyAndMissingFiles) {
  expect_refused(write("empty.hex", ""), "empty file");
  expect_refused(write("blank.hex", "\r\n  \n"), "empty file");
  expect_refused(::testing::TempDir() + "cart2d_fw_does_not_exist.hex", "cannot open");
}

TEST_F(FirmwareLoad, RefusesMalformedRecords) {
  const std::string eof = ":00000001FF\n";
  const std::string good = record(0x00, 0, {1, 2, 3, 4});
  std::string bad_char = good;
  bad_char[5] = 'G';
  expect_refused(write("char.hex", bad_char + "\n" + eof), "line 1: bad character 'G' in column 6");
  expect_refused(write("odd.hex", good + "0\n" + eof), "odd number of hex digits");
  expect_refused(write("short.hex", ":0000\n" + eof), "record too short");
  // A length byte that promises more data than the line has, checksum fixed up: simavr's reader
  // would copy 255 bytes out of its 64-byte line buffer.
  std::string longer = good;
  longer.replace(1, 2, "FF");
  longer.replace(longer.size() - 2, 2, "");
  {
    uint8_t sum = 0;
    for (size_t i = 1; i < longer.size(); i += 2)
      sum = static_cast<uint8_t>(sum + std::stoi(longer.substr(i, 2), nullptr, 16));
    char cs[3];
    std::snprintf(cs, sizeof cs, "%02X", static_cast<uint8_t>(0x100 - sum));
    longer += cs;
  }
  expect_refused(write("len.hex", longer + "\n" + eof), "record length FF says 255 data bytes, the record has 4");
  expect_refused(write("type.hex", record(0x06, 0, {}) + "\n" + eof), "unknown record type 06");
  expect_refused(write("noeof.hex", good + "\n"), "no end-of-file record");
  expect_refused(write("nodata.hex", eof), "no data records");
  expect_refused(write("after.hex", good + "\n" + eof + good + "\n"), "line 3: more text after the end-of-file record");
  expect_refused(write("gap.hex", good + "\n\n" + eof), "line 2: empty line before the end-of-file record");
  expect_refused(write("overlap.hex", good + "\n" + record(0x00, 2, {9}) + "\n" + eof), "data at 0x0002 overlaps");
  expect_refused(write("huge.hex", record(0x00, 0, std::vector<uint8_t>(60, 0)) + "\n" + eof),
                 "longer than the 126 characters");
  // simavr ORs the segment into the offset: 0x10 | 0x7010 is not 0x10 + 0x7010.
  expect_refused(write("seg.hex", record(0x02, 0, {0x00, 0x01}) + "\n" + record(0x00, 0x7010, {1}) + "\n" + eof),
                 "simavr's ihex reader does not read it as written");
}

// `cart2d-sim --check-firmware FILE`: the firmware update's check, one JSON line and the status.
struct CheckResult {
  int status = -1;
  std::string out;
};

CheckResult run_check(const std::string& path) {
  const std::string cmd = std::string("'") + CART2D_SIM_EXE + "' --check-firmware '" + path + "' 2>&1";
  CheckResult r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) r.out += buf;
  const int status = ::pclose(p);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The 26 vectors as avr-gcc writes them: JMP (0C 94 ..) or, relaxed, RJMP (.. Cx).
std::string vector_table() {
  std::string text;
  for (int k = 0; k < 26; k += 4) {
    std::vector<uint8_t> data;
    for (int v = k; v < std::min(k + 4, 26); ++v) {
      const std::vector<uint8_t> jump = v % 2 ? std::vector<uint8_t>{0x09, 0xC1, 0x00, 0x00}
                                              : std::vector<uint8_t>{0x0C, 0x94, 0x34, 0x00};
      data.insert(data.end(), jump.begin(), jump.end());
    }
    text += record(0x00, static_cast<uint16_t>(4 * k), data) + "\n";
  }
  return text;
}

TEST_F(FirmwareLoad, TheCheckPassesTheBuiltHexWithItsSize) {
  ASSERT_TRUE(firmware_built());
  const CheckResult r = run_check(CART2D_FIRMWARE_HEX);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(r.out.rfind("{\"ok\":true,\"bytes\":", 0), 0u) << r.out;
  const CheckResult table = run_check(write("table.hex", vector_table() + ":00000001FF\n"));
  EXPECT_EQ(table.status, 0) << table.out;
  EXPECT_EQ(table.out, "{\"ok\":true,\"bytes\":104,\"end\":104}\n");
}

TEST_F(FirmwareLoad, TheCheckRefusesWhatTheSimulatorRefuses) {
  const std::string eof = ":00000001FF\n";
  const std::string table = vector_table();
  const std::vector<std::pair<std::string, std::string>> files = {
      {"junk.hex", table + eof + "junk\n"},
      {"noeof.hex", table},
      {"early_eof.hex", table + eof + record(0x00, 0x200, {1, 2}) + "\n" + eof},
      {"long.hex", table + record(0x00, 0x200, std::vector<uint8_t>(160, 0)) + "\n" + eof},
      {"blank_first.hex", "\n\n" + table + eof},
      {"segment.hex", table + record(0x02, 0, {0x00, 0x01}) + "\n" + record(0x00, 0x0070, {1, 2}) + "\n" + eof},
  };
  for (const auto& [name, text] : files) {
    const std::string path = write(name, text);
    const CheckResult r = run_check(path);
    EXPECT_EQ(r.status, 1) << name << ": " << r.out;
    EXPECT_EQ(r.out.rfind("{\"ok\":false,\"error\":\"not a valid Intel HEX file: ", 0), 0u) << r.out;
    Mcu mcu;
    std::string err;
    EXPECT_FALSE(mcu.load(path, kFcpu, &err)) << name;  // one reader: the simulator refuses it too
    const std::string why = err.substr(err.find(": ") + 2);
    EXPECT_NE(r.out.find(why), std::string::npos) << name << ": " << r.out << " / " << err;
  }
}

TEST_F(FirmwareLoad, TheCheckWantsAnApplicationBelowTheBootloader) {
  const std::string eof = ":00000001FF\n";
  const CheckResult boot = run_check(write("boot.hex", vector_table() + record(0x00, 0x7E00, {0, 0}) + "\n" + eof));
  EXPECT_EQ(boot.status, 1);
  EXPECT_NE(boot.out.find("the program ends at byte 32258, beyond the 32256 bytes below the bootloader"),
            std::string::npos)
      << boot.out;
  const CheckResult data = run_check(write("data.hex", record(0x00, 0, std::vector<uint8_t>(16, 0)) + "\n" + eof));
  EXPECT_EQ(data.status, 1);
  EXPECT_NE(data.out.find("interrupt vector table's 26 jumps"), std::string::npos) << data.out;
  const CheckResult later = run_check(write("later.hex", record(0x00, 0x100, {0x0C, 0x94, 0, 0}) + "\n" + eof));
  EXPECT_NE(later.out.find("interrupt vector table"), std::string::npos) << later.out;
  ASSERT_TRUE(firmware_built());
  const CheckResult elf = run_check(CART2D_FIRMWARE_ELF);
  EXPECT_EQ(elf.status, 1);
  EXPECT_NE(elf.out.find("an ELF file: upload the Intel HEX"), std::string::npos) << elf.out;
}

TEST_F(FirmwareLoad, SimulatorExitsWithTheMessage) {
  ASSERT_TRUE(firmware_built());
  const std::string path = real_hex_with("cli_badsum.hex", [](std::vector<std::string>* l) {
    char& d = (*l)[2].back();
    d = d == '0' ? '1' : '0';
  });
  const std::string cmd = std::string("'") + CART2D_SIM_EXE + "' --firmware '" + path + "' --eeprom '" +
                          ::testing::TempDir() + "cart2d_fw_cli_eeprom.bin' 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = ::pclose(p);
  ASSERT_TRUE(WIFEXITED(status)) << out;
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  EXPECT_NE(out.find("firmware " + path + ": line 3: bad checksum"), std::string::npos) << out;
  EXPECT_EQ(out.find("\"ready\""), std::string::npos) << out;
}

}  // namespace
}  // namespace cart2d
