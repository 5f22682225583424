// What the firmware keeps across a reset that does not lose the RAM. On the real chip an external
// or a watchdog reset leaves SRAM as it was; power-on and brown-out leave it random. The board
// places one RetainedState where the C runtime does not clear it (.noinit); check words tell a
// surviving value from noise. This lets a reset be told apart and counted, and a cart that
// rebooted mid-path (the watchdog, a glitch on RESET) keep the pose it had.
#pragma once

#include <stdint.h>

#include "odometry.hpp"        // Pose
#include "protocol_table.hpp"  // proto::ResetCause

namespace core {

// Trivially constructible on purpose: an object with initialisers gets a static constructor that
// the C runtime runs at every boot, and it would zero the very values meant to survive.
struct RetainedState {
  float pose[3];  // x (m), y (m), theta (rad): not a Pose, which has initialisers
  uint16_t pose_check;
  uint16_t boot_count;
  uint16_t boot_count_check;
  uint8_t reboot_marker;  // kRebootMarker: the coming watchdog reset was asked for (REBOOT)
};

// reset_flags when MCUSR read 0 at start-up: Optiboot cleared it (see board/system.cpp). Then
// a lost RAM (no valid boot count) means POWER_ON (a brown-out looks the same), and a kept one
// EXTERNAL | WATCHDOG: behind Optiboot the reset button or a host opening the port reaches the
// application only through Optiboot's own watchdog timeout (its wait for a programmer), and a
// hang through the firmware's watchdog: the chip shows WDRF for both. REBOOT is still told by
// its marker (WATCHDOG | REBOOT).
constexpr uint8_t kMcusrClearedByBootloader = 0x80;

struct BootInfo {
  uint8_t reset_cause = 0;  // proto::ResetCause bits
  uint16_t boot_count = 1;  // boots since the RAM was last lost
  bool pose_restored = false;
  Pose pose;
};

static_assert(__has_trivial_constructor(RetainedState), "RetainedState must survive the C runtime's start-up");

// Called once at start-up with the reset flags the chip reported (MCUSR: PORF, EXTRF, BORF,
// WDRF in bits 0..3, the same bits as proto::ResetCause), or kMcusrClearedByBootloader.
// Updates `state` for this boot.
BootInfo boot(RetainedState& state, uint8_t reset_flags);
// The pose to restore after the next reset; every control tick.
void retain_pose(RetainedState& state, const Pose& pose);
// Called just before the firmware lets the watchdog reset it on purpose.
void mark_reboot(RetainedState& state);

}  // namespace core
