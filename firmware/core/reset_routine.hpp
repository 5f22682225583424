// The automatic pose reset (the seed listed COMMAND_RESET_ROUTINE but never wrote it):
// creep forwards until a front switch closes, hold that side while the other side keeps
// creeping until both switches are closed (the bumper is then square to the wall), hold for a
// few ticks to be sure, and report done. Gives up after a timeout.
#pragma once

#include <stdint.h>

#include "speed_controller.hpp"  // WheelSpeeds

namespace core {

class ResetRoutine {
 public:
  enum class State : uint8_t { kIdle, kRunning, kDone, kFailed };

  void start(uint16_t timeout_ticks);
  // One control tick: the wheel speeds to drive, from the switch states.
  WheelSpeeds step(bool left_pressed, bool right_pressed, float creep_mps);
  State state() const { return state_; }

 private:
  static constexpr uint8_t kSettleTicks = 5;  // both switches closed for 40 ms
  State state_ = State::kIdle;
  uint16_t ticks_left_ = 0;
  uint8_t settled_ = 0;
};

}  // namespace core
