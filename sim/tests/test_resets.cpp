// Resets, the reset time-out, floating motor inputs, EEPROM timing and hang injection, against a
// tiny AVR program (avr/reset_exerciser.c). All assertions are in simulated time.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "atmega328p.hpp"
#include "eeprom_store.hpp"
#include "rig.hpp"

extern "C" {
#include <sim_avr.h>  // avr_t
}

namespace cart2d {
namespace {

constexpr double kHz = 16000000.0;

struct Report {
  unsigned mcusr = 0, boots = 0, ee_ready = 0;
  bool ok = false;
};

class ResetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    RigConfig rc;
    rc.firmware = RESET_EXERCISER_ELF;
    rc.open_pty = false;
    rc.seed = 3;
    rc.start = Pose{0.6, 0.9, 0.0};
    std::string err;
    ASSERT_TRUE(rig_.init(rc, &err)) << err;
    boot();
  }

  double timeout_s() const { return static_cast<double>(rig_.mcu().timeout_cycles()) / kHz; }
  void run_s(double s) { ASSERT_TRUE(rig_.run_cycles(static_cast<uint64_t>(s * kHz))); }
  // Until the program has left reset and set itself up.
  void boot() {
    ASSERT_GE(rig_.mcu().release_cycle(), rig_.cycle());
    ASSERT_TRUE(rig_.run_cycles(rig_.mcu().release_cycle() - rig_.cycle()));
    run_s(0.005);
  }
  std::string command(char c, double wait_s = 0.005) {
    rig_.uart().take_output(rig_.cycle());
    rig_.uart().inject(std::string(1, c));
    run_s(wait_s);
    return rig_.uart().take_output(rig_.cycle());
  }
  Report report() {
    Report r;
    const std::string line = command('r');
    r.ok = std::sscanf(line.c_str(), "M=%x N=%u E=%u", &r.mcusr, &r.boots, &r.ee_ready) == 3;
    return r;
  }
  uint8_t eeprom_at(uint16_t address) { return EepromStore::read_eeprom(rig_.mcu().avr())[address]; }
  bool eepe() const { return rig_.mcu().avr()->data[m328p::kEECR] & m328p::kEEPE; }
  // Runs in steps of `step` cycles until EEPE reads `level`; the cycle it did (0: not within limit).
  // A sleeping core jumps to its next timer event, so an edge is seen up to a few dozen cycles late.
  uint64_t until_eepe(bool level, double limit_s, uint64_t step = 16) {
    const uint64_t end = rig_.cycle() + static_cast<uint64_t>(limit_s * kHz);
    while (rig_.cycle() < end) {
      if (eepe() == level) return rig_.cycle();
      if (!rig_.run_cycles(step)) return 0;
    }
    return 0;
  }

  Rig rig_;
};

// --- Resets ------------------------------------------------------------------------------------

TEST_F(ResetTest, PowerOnGivesPorfAloneAndTheTimeOut) {
  const Report r = report();
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.mcusr, m328p::kPORF);
  EXPECT_EQ(r.boots, 1u);
  // 14 CK + 65 ms (robot.toml [sim], datasheet §9.2.2) after power was applied at cycle 0.
  EXPECT_EQ(rig_.mcu().release_cycle(), 1040000u + 14u);
  EXPECT_EQ(rig_.mcu().reset_count(ResetCause::kPowerOn), 1u);
}

TEST_F(ResetTest, ExternalResetHoldsThePinsFloatingForTheTimeOutAndKeepsTheSram) {
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.25);
  const uint64_t steps = rig_.physics_steps();
  const double t0 = rig_.time_s();
  rig_.reset_mcu();
  EXPECT_STREQ(rig_.mcu().state_name(), "reset");
  run_s(timeout_s() - 0.001);
  const avr_t* avr = rig_.mcu().avr();
  EXPECT_EQ(avr->pc, 0u);  // not one instruction ran
  EXPECT_EQ(avr->data[m328p::kDDRB], 0u);
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.0);  // floating inputs, held low by the pull-downs
  EXPECT_DOUBLE_EQ(rig_.duties().right, 0.0);
  // The physics went on all along: one step per 0.25 ms.
  EXPECT_NEAR(static_cast<double>(rig_.physics_steps() - steps), (rig_.time_s() - t0) / rig_.step_s(), 1.0);
  run_s(0.002);
  EXPECT_STREQ(rig_.mcu().state_name(), "sleeping");
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.25);
  const Report r = report();
  EXPECT_EQ(r.mcusr, m328p::kPORF | m328p::kEXTRF);  // the program never cleared PORF: flags accumulate
  EXPECT_EQ(r.boots, 2u);                            // .noinit kept
  const auto events = rig_.take_reset_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].cause, ResetCause::kExternal);
  EXPECT_NEAR(events[0].t_s, t0, 1e-9);
}

// COMMAND_REBOOT's way out: the watchdog resets the core inside simavr. The reset must be like
// any other: the physics, the encoders' and the UART's timers re-armed, the time-out honoured.
TEST_F(ResetTest, WatchdogResetIsLikeAnyOtherReset) {
  command('w', 0.001);
  run_s(0.016);  // WDTO_15MS
  ASSERT_EQ(rig_.mcu().reset_count(ResetCause::kWatchdog), 1u);
  EXPECT_STREQ(rig_.mcu().state_name(), "reset");
  boot();
  const uint64_t steps = rig_.physics_steps();
  run_s(0.1);
  EXPECT_NEAR(static_cast<double>(rig_.physics_steps() - steps), 400.0, 1.0);  // the physics runs
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.25);
  const Report r = report();
  ASSERT_TRUE(r.ok) << "the UART is dead after the watchdog reset";
  EXPECT_EQ(r.mcusr, m328p::kPORF | m328p::kWDRF);
  EXPECT_EQ(r.boots, 2u);
  // Only one reset: the watchdog (16 ms after its reset, WDRF forcing WDE) did not count during
  // the 65 ms time-out, and the program stopped it once it ran.
  EXPECT_EQ(rig_.mcu().reset_count(ResetCause::kWatchdog), 1u);
  const auto events = rig_.take_reset_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].cause, ResetCause::kWatchdog);
}

TEST_F(ResetTest, PowerCycleLosesTheSramLeavesPorfAloneAndTheCartCoasts) {
  command('c');  // MCUSR = 0
  run_s(0.5);    // 0.25 duty both sides: the cart rolls
  const double speed = rig_.cart().twist().v_mps;
  ASSERT_GT(speed, 0.05);
  rig_.reset_mcu(ResetCause::kPowerOn, 0.2);
  run_s(0.01);
  EXPECT_GT(rig_.cart().twist().v_mps, 0.0);  // no drive, it coasts down
  EXPECT_LT(rig_.cart().twist().v_mps, speed);
  run_s(0.19 + timeout_s() - 0.001);
  EXPECT_STREQ(rig_.mcu().state_name(), "reset");  // off 0.2 s, then the time-out
  boot();
  const Report r = report();
  EXPECT_EQ(r.mcusr, m328p::kPORF);
  EXPECT_EQ(r.boots, 1u);  // the .noinit magic was lost
}

TEST_F(ResetTest, BrownOutSetsBorfAndLosesTheSram) {
  command('c');
  rig_.reset_mcu(ResetCause::kBrownOut, 0.01);
  run_s(0.01 + timeout_s() - 0.001);
  EXPECT_STREQ(rig_.mcu().state_name(), "reset");
  boot();
  const Report r = report();
  EXPECT_EQ(r.mcusr, m328p::kBORF);
  EXPECT_EQ(r.boots, 1u);
  EXPECT_EQ(rig_.mcu().reset_count(ResetCause::kBrownOut), 1u);
}

// --- Motor inputs during reset -----------------------------------------------------------------

TEST_F(ResetTest, WithoutPullDownsTheFloatingInputsDriveBothMotorsBackwardsFullOn) {
  Faults f;
  f.hbridge_pulldowns = 0;
  rig_.set_faults(f);
  run_s(0.3);
  ASSERT_GT(rig_.cart().wheel_speed_l_radps(), 0.0);
  rig_.reset_mcu();
  run_s(0.03);
  EXPECT_DOUBLE_EQ(rig_.duties().left, -1.0);  // PWM reads high, DIRECTION high = backwards
  EXPECT_DOUBLE_EQ(rig_.duties().right, -1.0);
  run_s(timeout_s() - 0.031);
  EXPECT_LT(rig_.cart().wheel_speed_l_radps(), -5.0);  // it has reversed hard
  EXPECT_LT(rig_.cart().wheel_speed_r_radps(), -5.0);
  boot();
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.25);  // the program drives the pins again
}

// --- EEPROM ------------------------------------------------------------------------------------

TEST_F(ResetTest, EepromWriteKeepsEepeSetForTheProgrammingTimeAndChangesTheByteAtItsEnd) {
  rig_.uart().inject("e");
  const uint64_t start = until_eepe(true, 0.01);
  ASSERT_NE(start, 0u);
  EXPECT_EQ(eeprom_at(0x10), 0xFF);
  ASSERT_TRUE(rig_.run_cycles(54400 - 200));  // 3.4 ms = 54 400 cycles
  EXPECT_TRUE(eepe());
  EXPECT_EQ(eeprom_at(0x10), 0xFF);  // not yet
  const uint64_t end = until_eepe(false, 0.001, 1);
  EXPECT_NEAR(static_cast<double>(end - start), 54400.0, 50.0);
  EXPECT_EQ(eeprom_at(0x10), 0x5A);
  EXPECT_EQ(rig_.eeprom().stats().writes_done, 1u);
}

TEST_F(ResetTest, EepromBlockOfFourBytesTakesFourProgrammingTimes) {
  rig_.uart().inject("b");
  const uint64_t start = until_eepe(true, 0.01);
  ASSERT_NE(start, 0u);
  run_s(0.0135);
  EXPECT_EQ(eeprom_at(0x23), 0xFF);  // the fourth is still being written
  run_s(0.0005);
  EXPECT_EQ(eeprom_at(0x20), 0x11);
  EXPECT_EQ(eeprom_at(0x23), 0x44);
  EXPECT_EQ(rig_.eeprom().stats().writes_done, 4u);
}

TEST_F(ResetTest, EepromCannotBeReadNorAddressedWhileProgramming) {
  command('e', 0.005);  // 0x5A at 0x10, done
  command('p', 0.001);  // a write to 0x30, then EEAR = 0x10 and EERE at once
  const avr_t* avr = rig_.mcu().avr();
  EXPECT_EQ(rig_.eeprom().stats().reads_while_busy, 1u);
  EXPECT_EQ(rig_.eeprom().stats().address_writes_ignored, 2u);  // EEARH and EEARL
  EXPECT_EQ(avr->data[m328p::kEEARL], 0x30);
  EXPECT_EQ(avr->data[m328p::kEEDR], 0x77);  // still the data being written, not 0x5A
}

TEST_F(ResetTest, EepeLaterThanFourCyclesAfterEempeWritesNothing) {
  command('s');
  EXPECT_EQ(rig_.eeprom().stats().strobes_ignored, 1u);
  EXPECT_EQ(rig_.eeprom().stats().writes_started, 0u);
  EXPECT_EQ(eeprom_at(0x12), 0xFF);
}

TEST_F(ResetTest, WriteOnlyModeTakes1_8msAndCanOnlyClearBits) {
  command('e', 0.005);  // 0x5A
  rig_.uart().inject("o");
  const uint64_t start = until_eepe(true, 0.01, 1);
  const uint64_t end = until_eepe(false, 0.01, 1);
  // Sampled between instructions: while the program sleeps the next look comes at the next
  // simulator event (the USART's bit sampling among them), up to ~100 cycles after the change.
  EXPECT_NEAR(static_cast<double>(end - start), 28800.0, 100.0);  // 1.8 ms
  EXPECT_EQ(eeprom_at(0x10), 0x5A & 0x0F);
}

TEST_F(ResetTest, EeReadyIsALevelInterrupt) {
  command('i');
  EXPECT_EQ(report().ee_ready, 3u);  // again and again while EERIE is set and EEPE clear
}

TEST_F(ResetTest, AResetDuringAWriteLeavesTheBytePartlyProgrammed) {
  rig_.uart().inject("e");
  ASSERT_NE(until_eepe(true, 0.01), 0u);
  run_s(0.0025);  // 0.8 ms into the 1.7 ms write phase
  rig_.reset_mcu();
  const uint8_t cell = eeprom_at(0x10);
  EXPECT_EQ(cell & 0x5A, 0x5A);  // erased (0xFF), then only some of the zeros programmed
  EXPECT_NE(cell, 0xFF);          // seed 3: some were
  EXPECT_NE(cell, 0x5A);          // and some were not
  EXPECT_EQ(rig_.eeprom().stats().writes_aborted, 1u);
  EXPECT_FALSE(eepe());
}

TEST(PartlyProgrammed, FollowsTheEraseThenWritePhases) {
  Rng rng(1, 2);
  const uint64_t total = 54400;
  EXPECT_EQ(partly_programmed(0x00, 0x5A, 0, 0, total, &rng), 0x00);
  EXPECT_EQ(partly_programmed(0x00, 0x5A, 0, total / 2, total, &rng), 0xFF);  // erased
  EXPECT_EQ(partly_programmed(0x00, 0x5A, 0, total, total, &rng), 0x5A);
  int erased_bits = 0;
  for (int i = 0; i < 100; ++i) erased_bits += __builtin_popcount(partly_programmed(0x00, 0x5A, 0, total / 4, total, &rng));
  EXPECT_NEAR(erased_bits / 100.0, 4.0, 0.6);  // half-way through the erase: half the bits
  EXPECT_EQ(partly_programmed(0x0F, 0xF0, 1, 28800, 28800, &rng), 0xFF);  // erase only
  EXPECT_EQ(partly_programmed(0x0F, 0x03, 2, 28800, 28800, &rng), 0x03);  // write only: AND
  EXPECT_EQ(partly_programmed(0x0F, 0x03, 2, 0, 28800, &rng), 0x0F);
}

// --- Hang injection ----------------------------------------------------------------------------

TEST_F(ResetTest, HangStopsTheMainLoopButNotTheInterruptsUntilTheNextReset) {
  ASSERT_TRUE(report().ok);
  rig_.inject_hang();
  const uint64_t before = rig_.cycle();
  EXPECT_EQ(command('r'), "");   // woken by the byte, the loop never comes back
  EXPECT_EQ(command('x'), "X");  // the RX interrupt still answers
  uint64_t began = 0;
  ASSERT_TRUE(rig_.mcu().take_hang_began(&began));
  EXPECT_GT(began, before);
  EXPECT_LT(began, before + static_cast<uint64_t>(0.001 * kHz));  // at the first byte's arrival
  EXPECT_FALSE(rig_.mcu().take_hang_began(&began));              // reported once
  EXPECT_DOUBLE_EQ(rig_.duties().left, 0.25);                     // the PWM hardware runs on
  rig_.reset_mcu();
  boot();
  EXPECT_TRUE(report().ok);  // the original word is back
}

}  // namespace
}  // namespace cart2d
