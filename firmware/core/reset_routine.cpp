#include "reset_routine.hpp"

namespace core {

void ResetRoutine::start(uint16_t timeout_ticks) {
  state_ = State::kRunning;
  ticks_left_ = timeout_ticks;
  settled_ = 0;
}

WheelSpeeds ResetRoutine::step(bool left_pressed, bool right_pressed, float creep_mps) {
  WheelSpeeds w;
  if (state_ != State::kRunning) return w;
  if (left_pressed && right_pressed) {
    if (++settled_ >= kSettleTicks) state_ = State::kDone;
    return w;
  }
  settled_ = 0;
  if (ticks_left_ == 0) {
    state_ = State::kFailed;
    return w;
  }
  --ticks_left_;
  // A pressed side stops; the other keeps pushing, which turns the bumper flat to the wall.
  w.left_mps = left_pressed ? 0.0f : creep_mps;
  w.right_mps = right_pressed ? 0.0f : creep_mps;
  return w;
}

}  // namespace core
