// What survives a reset: the cause, the boot count and the pose, told apart from random RAM.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "protocol_table.hpp"
#include "retained.hpp"

namespace {

using core::BootInfo;
using core::Pose;
using core::RetainedState;

// Power-on: the RAM holds whatever the cells settled to.
RetainedState random_ram(unsigned seed) {
  RetainedState s;
  std::mt19937 rng(seed);
  uint8_t* bytes = reinterpret_cast<uint8_t*>(&s);
  for (size_t i = 0; i < sizeof s; ++i) bytes[i] = static_cast<uint8_t>(rng());
  return s;
}

TEST(Retained, PowerOnStartsTheCountAndRestoresNothing) {
  RetainedState s = random_ram(1);
  const BootInfo info = core::boot(s, proto::RESET_POWER_ON);
  EXPECT_EQ(proto::RESET_POWER_ON, info.reset_cause);
  EXPECT_EQ(1, info.boot_count);
  EXPECT_FALSE(info.pose_restored);
}

TEST(Retained, AnExternalResetKeepsThePoseAndCountsTheBoot) {
  RetainedState s = random_ram(2);
  core::boot(s, proto::RESET_POWER_ON);
  core::retain_pose(s, Pose{1.084f, 1.123f, -0.5f});
  const BootInfo info = core::boot(s, proto::RESET_EXTERNAL);
  EXPECT_EQ(proto::RESET_EXTERNAL, info.reset_cause);
  EXPECT_EQ(2, info.boot_count);
  ASSERT_TRUE(info.pose_restored);
  EXPECT_FLOAT_EQ(1.084f, info.pose.x_m);
  EXPECT_FLOAT_EQ(1.123f, info.pose.y_m);
  EXPECT_FLOAT_EQ(-0.5f, info.pose.theta_rad);
  EXPECT_EQ(3, core::boot(s, proto::RESET_WATCHDOG).boot_count);
}

TEST(Retained, ARebootIsToldFromAHang) {
  RetainedState s = random_ram(3);
  core::boot(s, proto::RESET_POWER_ON);
  core::mark_reboot(s);
  EXPECT_EQ(proto::RESET_WATCHDOG | proto::RESET_REBOOT, core::boot(s, proto::RESET_WATCHDOG).reset_cause);
  // The marker is spent: the next watchdog reset is a hang.
  EXPECT_EQ(proto::RESET_WATCHDOG, core::boot(s, proto::RESET_WATCHDOG).reset_cause);
  // A marker left from before an external reset does not make a later one a reboot either.
  core::mark_reboot(s);
  core::boot(s, proto::RESET_EXTERNAL);
  EXPECT_EQ(proto::RESET_WATCHDOG, core::boot(s, proto::RESET_WATCHDOG).reset_cause);
}

TEST(Retained, BrownOutAndUnknownCausesLoseTheRam) {
  for (uint8_t cause : {uint8_t(proto::RESET_BROWN_OUT), uint8_t(0),
                        uint8_t(proto::RESET_EXTERNAL | proto::RESET_POWER_ON)}) {
    RetainedState s = random_ram(4);
    core::boot(s, proto::RESET_POWER_ON);
    core::retain_pose(s, Pose{0.5f, 0.5f, 0.0f});
    const BootInfo info = core::boot(s, cause);
    EXPECT_FALSE(info.pose_restored) << int(cause);
    EXPECT_EQ(1, info.boot_count) << int(cause);
  }
}

// Behind Optiboot 4.4 MCUSR reads 0 (it cleared it and passed nothing on): the RAM tells what it can.
TEST(Retained, BehindOptibootTheRamTellsPowerOnFromAResetThatKeptIt) {
  RetainedState s = random_ram(6);
  BootInfo info = core::boot(s, core::kMcusrClearedByBootloader);  // power-on: random RAM
  EXPECT_EQ(proto::RESET_POWER_ON, info.reset_cause);
  EXPECT_EQ(1, info.boot_count);
  core::retain_pose(s, Pose{0.5f, 0.25f, 0.1f});
  info = core::boot(s, core::kMcusrClearedByBootloader);  // the button, a port opening or a hang
  EXPECT_EQ(proto::RESET_EXTERNAL | proto::RESET_WATCHDOG, info.reset_cause);
  EXPECT_EQ(2, info.boot_count);
  EXPECT_TRUE(info.pose_restored);
  core::mark_reboot(s);
  info = core::boot(s, core::kMcusrClearedByBootloader);
  EXPECT_EQ(proto::RESET_WATCHDOG | proto::RESET_REBOOT, info.reset_cause);
  EXPECT_EQ(3, info.boot_count);
  // Flags the chip gave are taken as they are.
  EXPECT_EQ(proto::RESET_WATCHDOG, core::boot(s, proto::RESET_WATCHDOG).reset_cause);
}

TEST(Retained, APoseTornByTheResetIsNotRestored) {
  RetainedState s = random_ram(5);
  core::boot(s, proto::RESET_POWER_ON);
  core::retain_pose(s, Pose{0.5f, 0.5f, 0.0f});
  s.pose[0] = 0.75f;  // the reset came between writing x and the check word
  EXPECT_FALSE(core::boot(s, proto::RESET_EXTERNAL).pose_restored);
}

TEST(Retained, RandomRamIsNeverTakenForAPoseOrACount) {
  int restored = 0, counted = 0;
  for (unsigned seed = 0; seed < 20000; ++seed) {
    RetainedState s = random_ram(seed);
    const BootInfo info = core::boot(s, proto::RESET_EXTERNAL);  // e.g. a glitch right after power-on
    restored += info.pose_restored;
    counted += info.boot_count != 1;
  }
  // Two 16-bit check words: about one chance in 65 536 each.
  EXPECT_LE(restored, 2);
  EXPECT_LE(counted, 2);
}

TEST(Retained, AllZeroRamDoesNotPass) {
  RetainedState s;
  std::memset(&s, 0, sizeof s);
  const BootInfo info = core::boot(s, proto::RESET_EXTERNAL);
  EXPECT_FALSE(info.pose_restored);
  EXPECT_EQ(1, info.boot_count);
}

}  // namespace
