#include "pacer.hpp"

#include <ctime>  // clock_gettime

namespace cart2d {

double wall_now_s() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + ts.tv_nsec * 1e-9;
}

void Pacer::anchor(double sim_s, double wall_s) {
  anchor_sim_ = sim_s;
  anchor_wall_ = wall_s;
  win_sim_ = sim_s;
  win_wall_ = wall_s;
}

double Pacer::delay_s(double sim_s, double wall_s) {
  if (unlimited()) return 0.0;
  const double due = anchor_wall_ + (sim_s - anchor_sim_) / factor_;
  const double delay = due - wall_s;
  if (delay < -kMaxLagS) {
    anchor_sim_ = sim_s;
    anchor_wall_ = wall_s;
    return 0.0;
  }
  return delay > 0.0 ? delay : 0.0;
}

void Pacer::sample(double sim_s, double wall_s) {
  if (win_wall_ < 0.0) {
    anchor(sim_s, wall_s);
    return;
  }
  const double dt = wall_s - win_wall_;
  if (dt < 0.5) return;
  rtf_ = (sim_s - win_sim_) / dt;
  win_sim_ = sim_s;
  win_wall_ = wall_s;
}

}  // namespace cart2d
