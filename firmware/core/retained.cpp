#include "retained.hpp"

#include "crc16.hpp"  // crc16_mcrf4xx
#include "num.hpp"    // is_moderate, kMaxAngle_rad

namespace core {

constexpr uint8_t kRebootMarker = 0xB7;
constexpr uint8_t kRamLost = proto::RESET_POWER_ON | proto::RESET_BROWN_OUT;
constexpr uint8_t kChipCauses =
    proto::RESET_POWER_ON | proto::RESET_EXTERNAL | proto::RESET_BROWN_OUT | proto::RESET_WATCHDOG;

static uint16_t check_of(const float* pose) {
  // Not 0xFFFF-seeded zeros: a RAM that powers up all-zero must not pass.
  return crc16_mcrf4xx(reinterpret_cast<const uint8_t*>(pose), 3 * sizeof(float)) ^ 0x5AA5;
}

static bool plausible(const float* p) {
  return is_moderate(p[0]) && is_moderate(p[1]) && is_moderate(p[2]) && fabsf(p[2]) <= kPi + 1e-3f;
}

static bool count_intact(const RetainedState& state) {
  return state.boot_count_check == static_cast<uint16_t>(~state.boot_count);
}

// The cause behind a bootloader that cleared MCUSR (kMcusrClearedByBootloader): what the RAM can tell.
static uint8_t cause_behind_bootloader(const RetainedState& state) {
  if (!count_intact(state)) return proto::RESET_POWER_ON;
  if (state.reboot_marker == kRebootMarker) return proto::RESET_WATCHDOG;  // REBOOT is added below
  return proto::RESET_EXTERNAL | proto::RESET_WATCHDOG;
}

BootInfo boot(RetainedState& state, uint8_t reset_flags) {
  BootInfo info;
  info.reset_cause = reset_flags & kChipCauses;
  if (info.reset_cause == 0 && (reset_flags & kMcusrClearedByBootloader))
    info.reset_cause = cause_behind_bootloader(state);
  // No flag at all (a jump to address 0, or a bootloader that kept them) proves nothing about
  // the RAM: treat it as lost.
  const bool ram_kept = info.reset_cause != 0 && !(info.reset_cause & kRamLost);
  if (ram_kept && (info.reset_cause & proto::RESET_WATCHDOG) && state.reboot_marker == kRebootMarker)
    info.reset_cause |= proto::RESET_REBOOT;
  state.reboot_marker = 0;

  const bool count_valid = ram_kept && count_intact(state);
  info.boot_count = count_valid && state.boot_count != 0xFFFF ? state.boot_count + 1 : 1;
  state.boot_count = info.boot_count;
  state.boot_count_check = static_cast<uint16_t>(~info.boot_count);

  info.pose_restored = ram_kept && state.pose_check == check_of(state.pose) && plausible(state.pose);
  if (info.pose_restored) info.pose = Pose{state.pose[0], state.pose[1], state.pose[2]};
  return info;
}

void retain_pose(RetainedState& state, const Pose& pose) {
  state.pose[0] = pose.x_m;
  state.pose[1] = pose.y_m;
  state.pose[2] = pose.theta_rad;
  state.pose_check = check_of(state.pose);
}

void mark_reboot(RetainedState& state) { state.reboot_marker = kRebootMarker; }

}  // namespace core
