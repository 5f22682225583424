// Paces simulated time against the wall clock at a chosen factor (1 = real time), or not at all
// ("max"). Only the main loop consults it: the physics never sees wall time, so a run is the same
// at any speed. Also measures the real-time factor actually achieved.
#pragma once

namespace cart2d {

// Monotonic wall-clock seconds.
double wall_now_s();

class Pacer {
 public:
  // factor ≤ 0 means "as fast as possible".
  void set_factor(double factor) { factor_ = factor; }
  double factor() const { return factor_; }
  bool unlimited() const { return factor_ <= 0.0; }

  // Restarts pacing from this pair of times (after start, pause, speed change).
  void anchor(double sim_s, double wall_s);
  // How long to wait before simulating beyond sim_s (0 if late). When the host falls more than
  // kMaxLagS behind it re-anchors instead of sprinting to catch up.
  double delay_s(double sim_s, double wall_s);
  // Feeds the real-time-factor estimate; call once per loop.
  void sample(double sim_s, double wall_s);
  double rtf() const { return rtf_; }

  static constexpr double kMaxLagS = 0.25;

 private:
  double factor_ = 1.0;
  double anchor_sim_ = 0.0, anchor_wall_ = 0.0;
  double win_sim_ = 0.0, win_wall_ = -1.0;
  double rtf_ = 0.0;
};

}  // namespace cart2d
