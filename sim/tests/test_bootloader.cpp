// Optiboot in the boot section (Mcu::load_bootloader): BOOTRST sends every reset to 0x7E00, a
// power-on or watchdog reset goes on to the application at once, an external reset waits for a
// programmer first, and a page write takes the chip's programming time. Runs the real firmware
// (build/firmware/cart2d-nano.hex, `make firmware`) under the Optiboot this build makes from
// Debian's source. All times are simulated.
#include <gtest/gtest.h>

#include <string>

#include "atmega328p.hpp"
#include "rig.hpp"
#include "robot_params.hpp"

extern "C" {
#include <sim_avr.h>
}

namespace cart2d {
namespace {

const double kHz = params::control::f_cpu_hz;

class Bootloader : public ::testing::Test {
 protected:
  void init(bool with_bootloader) {
    RigConfig rc;
    rc.firmware = CART2D_FIRMWARE_HEX;
    if (with_bootloader) rc.bootloader = OPTIBOOT_HEX;
    rc.open_pty = false;
    rc.start = Pose{0.9, 0.9, 0.0};
    std::string err;
    ASSERT_TRUE(rig_.init(rc, &err)) << err << " (make firmware; make sim)";
  }
  uint32_t pc() const { return rig_.mcu().avr()->pc; }
  bool in_boot_section() const { return pc() >= m328p::kBootSectionStart; }
  void run_s(double s) { ASSERT_TRUE(rig_.run_cycles(static_cast<uint64_t>(s * kHz))) << rig_.mcu().state_name(); }
  void run_to_release() {
    ASSERT_TRUE(rig_.mcu().in_reset());
    ASSERT_TRUE(rig_.run_cycles(rig_.mcu().release_cycle() - rig_.cycle()));
  }
  // Steps a few cycles at a time until the core leaves the boot section; the cycles it took.
  uint64_t cycles_until_application(uint64_t limit) {
    const uint64_t start = rig_.cycle();
    while (in_boot_section() && rig_.cycle() - start < limit) EXPECT_TRUE(rig_.run_cycles(1));
    return rig_.cycle() - start;
  }
  // Bytes the MCU sent since the last call, and when (s) the last of them was ready.
  std::string output(double* last_ready_s = nullptr) {
    std::vector<double> ready_cycles;
    std::string out = rig_.uart().take_output(rig_.cycle(), &ready_cycles);
    if (last_ready_s && !ready_cycles.empty()) *last_ready_s = ready_cycles.back() / kHz;
    return out;
  }

  Rig rig_;
};

TEST_F(Bootloader, WithoutItTheResetVectorIsAddressZero) {
  init(false);
  EXPECT_EQ(rig_.mcu().avr()->reset_pc, 0u);
  run_to_release();
  EXPECT_EQ(pc(), 0u);
}

TEST_F(Bootloader, BootrstSendsThePowerOnResetTo0x7E00) {
  init(true);
  const avr_t* avr = rig_.mcu().avr();
  EXPECT_EQ(avr->reset_pc, m328p::kBootSectionStart);
  EXPECT_EQ(avr->fuse[AVR_FUSE_HIGH], 0xDE);  // a Nano with Optiboot: BOOTRST, BOOTSZ = 256 words
  EXPECT_EQ(avr->flash[0x7E00], 0x11);         // Optiboot's first instruction, eor r1, r1
  EXPECT_EQ(avr->flash[0x7E01], 0x24);
  run_to_release();
  EXPECT_EQ(pc(), 0x7E00u);  // the first instruction after the time-out is the bootloader's
}

TEST_F(Bootloader, PowerOnReachesTheApplicationAtOnce) {
  init(true);
  run_to_release();
  // Optiboot 4.4 reads MCUSR, sees no EXTRF and jumps to the application: a dozen instructions.
  EXPECT_LT(cycles_until_application(1000), 40u);
  EXPECT_EQ(pc(), 0u);  // through the application's reset vector
  EXPECT_EQ(rig_.mcu().avr()->data[m328p::kMCUSR], 0u) << "Optiboot clears MCUSR";
  run_s(0.5);
  EXPECT_GT(output().size(), 100u) << "the firmware sends telemetry";
  EXPECT_EQ(rig_.mcu().reset_count(ResetCause::kWatchdog), 0u);
}

TEST_F(Bootloader, EveryResetStartsInTheBootSection) {
  init(true);
  run_to_release();
  run_s(0.2);
  ASSERT_FALSE(in_boot_section());
  rig_.reset_mcu(ResetCause::kPowerOn, 0.1);
  run_to_release();
  EXPECT_EQ(pc(), 0x7E00u);
  EXPECT_LT(cycles_until_application(1000), 40u);
}

TEST_F(Bootloader, ExternalResetWaitsForTheProgrammerThenTheWatchdogStartsTheApplication) {
  init(true);
  run_to_release();
  run_s(0.2);
  rig_.reset_mcu(ResetCause::kExternal);
  run_to_release();
  output();  // the firmware's telemetry before the reset
  const double released_s = rig_.time_s();
  EXPECT_EQ(pc(), 0x7E00u);
  // Optiboot flashes the LED three times (6 x 62.5 ms on Timer1), then waits for STK500 bytes
  // under a 1 s watchdog; nothing arrives, the watchdog resets the chip, and with WDRF alone
  // Optiboot starts the application.
  while (rig_.mcu().reset_count(ResetCause::kWatchdog) == 0 && rig_.time_s() - released_s < 3.0) {
    ASSERT_TRUE(in_boot_section() || rig_.mcu().in_reset()) << "the application ran at t = " << rig_.time_s() - released_s;
    run_s(0.001);
  }
  const double waited_s = rig_.time_s() - released_s;
  EXPECT_GT(waited_s, 1.3);
  EXPECT_LT(waited_s, 1.45);
  EXPECT_EQ(output(), "") << "Optiboot says nothing unless asked";
  run_to_release();
  EXPECT_EQ(pc(), 0x7E00u);
  EXPECT_LT(cycles_until_application(1000), 60u);
  run_s(0.5);
  EXPECT_GT(output().size(), 100u);
}

// Optiboot's LED flashes run Timer1 in mode 0 with both output-compare pins off: no PWM of the
// bridges, so the H-bridge model has nothing to warn about (it warned at every gateway start, the
// port's opening being an external reset).
TEST_F(Bootloader, OptibootsLedTimerIsNoMisreadPwm) {
  init(true);
  run_to_release();
  run_s(0.2);
  testing::internal::CaptureStderr();
  rig_.reset_mcu(ResetCause::kExternal);
  run_to_release();
  run_s(0.3);  // in the LED flashes
  const uint8_t* d = rig_.mcu().avr()->data;
  const unsigned wgm = (d[m328p::kTCCR1A] & 0x3u) | ((d[m328p::kTCCR1B] >> 1) & 0xCu);
  const bool clocked = (d[m328p::kTCCR1B] & 0x7u) != 0;
  run_s(2.0);  // the watchdog, the application, its motors set up
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_TRUE(clocked && wgm == 0) << "Optiboot's LED timer, as this test assumes: mode " << wgm;
  EXPECT_EQ(err.find("WGM"), std::string::npos) << err;
}

TEST_F(Bootloader, AByteThatIsNotStk500StartsTheApplicationAfter16Ms) {
  init(true);
  run_to_release();
  rig_.reset_mcu(ResetCause::kExternal);
  run_to_release();
  run_s(0.4);  // past the LED flashes: Optiboot reads the UART
  // A gateway's request (docs/protocol.md: 0x7E, LEN, ...): 0x7E is no STK500 command, so
  // verifySpace() wants CRC_EOP next, gets LEN, shortens the watchdog to 16 ms (WDP = 0) and
  // spins. simavr 1.6 kept the 1 s period until Mcu::on_wdtcsr_write.
  const double sent_s = rig_.time_s();
  rig_.uart().inject(std::string("\x7E\x03", 2));
  while (rig_.mcu().reset_count(ResetCause::kWatchdog) == 0 && rig_.time_s() - sent_s < 1.5) run_s(0.0005);
  const double bitten_s = rig_.time_s() - sent_s;
  EXPECT_GT(bitten_s, 0.016);  // 2K cycles at 128 kHz, after the two bytes' 170 us
  EXPECT_LT(bitten_s, 0.020);
  run_to_release();
  EXPECT_LT(cycles_until_application(1000), 60u);
}

TEST_F(Bootloader, APageWriteTakesTheProgrammingTime) {
  init(true);
  run_to_release();
  rig_.reset_mcu(ResetCause::kExternal);
  run_to_release();
  run_s(0.4);  // past the LED flashes: Optiboot reads the UART
  // STK500v1 (stk500.h): LOAD_ADDRESS word 0x0040, PROG_PAGE 128 bytes of flash; each answered
  // with STK_INSYNC (0x14) once the command's CRC_EOP (0x20) arrives, STK_OK (0x10) when done.
  rig_.uart().inject(std::string("\x55\x40\x00\x20", 4));
  run_s(0.01);
  EXPECT_EQ(output(), "\x14\x10");
  std::string page("\x64\x00\x80\x46", 4);
  for (int i = 0; i < 128; ++i) page += static_cast<char>(i);
  page += '\x20';
  rig_.uart().inject(page);
  double insync_s = 0, ok_s = 0;
  while (output(&insync_s).empty()) run_s(0.0001);
  while (output(&ok_s).empty() && rig_.time_s() < insync_s + 0.1) run_s(0.0001);
  // The page write's 4.1 ms (datasheet: 3.7-4.5 ms) before STK_OK, which then takes 86 us on the wire.
  EXPECT_GT(ok_s - insync_s, 0.0041);
  EXPECT_LT(ok_s - insync_s, 0.0050);
  EXPECT_EQ(rig_.mcu().spm()->pages_erased, 1u);
  EXPECT_EQ(rig_.mcu().spm()->pages_written, 1u);
  const avr_t* avr = rig_.mcu().avr();
  for (int i = 0; i < 128; ++i) ASSERT_EQ(avr->flash[0x80 + i], i) << "byte " << i;
}

TEST_F(Bootloader, DebiansPrebuiltHexIsRefusedItRunsPastTheFlash) {
  // arduino-core-avr rebuilds optiboot_atmega328.hex with avr-gcc 5.4: 532 bytes of code from
  // 0x7E00, 20 of them beyond 0x7FFF (sim/CMakeLists.txt builds one that fits).
  Mcu mcu;
  std::string err;
  ASSERT_TRUE(mcu.load(CART2D_FIRMWARE_HEX, static_cast<uint32_t>(kHz), &err)) << err;
  EXPECT_FALSE(mcu.load_bootloader(DEBIAN_OPTIBOOT_HEX, &err));
  EXPECT_NE(err.find("beyond the 32 KiB flash"), std::string::npos) << err;
  EXPECT_EQ(mcu.avr()->reset_pc, 0u);
}

TEST_F(Bootloader, AnApplicationReachingIntoTheBootSectionIsRefused) {
  Mcu mcu;
  std::string err;
  ASSERT_TRUE(mcu.load(CART2D_FIRMWARE_HEX, static_cast<uint32_t>(kHz), &err)) << err;
  mcu.avr()->flash[0x7F00] = 0x00;  // as if the application's image went that far
  EXPECT_FALSE(mcu.load_bootloader(OPTIBOOT_HEX, &err));
  EXPECT_NE(err.find("reaches into the boot section"), std::string::npos) << err;
}

}  // namespace
}  // namespace cart2d
