#include "hold.hpp"

#include <algorithm>  // std::max

namespace cart2d {

void Hold::host_wrote(uint64_t arrives, uint64_t limit) {
  answer_from_ = std::max(answer_from_, arrives);
  answer_limit_ = std::max(answer_limit_, limit);
}

uint64_t Hold::stop_cycle(uint64_t now, uint64_t mcu_frame_start, uint64_t mcu_line_free, uint64_t quiet) const {
  if (until_ == kNone) return kNone;
  const bool answered = mcu_frame_start >= answer_from_ && now >= mcu_line_free + quiet;
  if (now < answer_limit_ && !answered) return std::max(until_, answer_limit_);
  return until_;
}

void Hold::account(bool waiting, double wall_s) {
  if (waiting && waiting_since_s_ < 0.0) {
    waiting_since_s_ = wall_s;
    ++waits_;
  } else if (!waiting && waiting_since_s_ >= 0.0) {
    waited_s_ += wall_s - waiting_since_s_;
    waiting_since_s_ = -1.0;
  }
}

}  // namespace cart2d
