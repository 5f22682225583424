// When the simulated camera's frames are taken and delivered, in simulated time only: frame k is
// captured at t_k = k / fps (from t = 0, so a frame number names the same instant in every run)
// and becomes available at t_k + latency. Times are CPU cycles, as everything the simulator schedules.
#pragma once

#include <cmath>
#include <cstdint>

namespace cart2d {

class CameraClock {
 public:
  CameraClock(double fps, double latency_s, double cpu_hz) : fps_(fps), latency_s_(latency_s), cpu_hz_(cpu_hz) {}

  double capture_s(uint64_t k) const { return static_cast<double>(k) / fps_; }
  // The first cycle at or after t_k (a frame is captured at the first physics step that reaches it).
  uint64_t capture_cycle(uint64_t k) const { return cycle_at_or_after(capture_s(k)); }
  uint64_t available_cycle(uint64_t k) const { return cycle_at_or_after(capture_s(k) + latency_s_); }
  // The first frame whose capture is at or after this cycle.
  uint64_t first_frame_from(uint64_t cycle) const {
    auto k = static_cast<uint64_t>(std::floor(static_cast<double>(cycle) / cpu_hz_ * fps_));
    while (capture_cycle(k) < cycle) ++k;
    while (k > 0 && capture_cycle(k - 1) >= cycle) --k;
    return k;
  }

 private:
  uint64_t cycle_at_or_after(double t_s) const {
    // The tolerance keeps an exact multiple (k / fps · f a whole number) from rounding up a cycle.
    return static_cast<uint64_t>(std::ceil(t_s * cpu_hz_ - 1e-6));
  }
  double fps_, latency_s_, cpu_hz_;
};

}  // namespace cart2d
