#include "path.hpp"

#include "num.hpp"  // sqrtf, fabsf

namespace core {

// A lower bound of the segment's length, within 30 % (the larger of |dx| and |dy|: exact along
// the axes, 1/sqrt 2 of it on a diagonal), without a square root: every appended point adds
// one, and the MCU handles an append of 15 points between two control ticks. Short, the bound
// only makes the cart brake for the window's end a little early when it is starved.
__attribute__((noinline)) static float length_bound(const Point& a, const Point& b) {
  const float dx = fabsf(b.x_m - a.x_m), dy = fabsf(b.y_m - a.y_m);
  return dx > dy ? dx : dy;
}

// A whole number in [0, 65535]; written so that NaN fails too, before any float -> integer
// conversion.
static bool is_index(float v) {
  return v >= 0.0f && v <= kMaxPathPoints && v == static_cast<float>(static_cast<uint16_t>(v));
}

uint8_t Path::begin(float count, const float* xy, uint8_t n, const Pose& start) {
  if (!(count >= 1.0f)) return proto::REASON_OUT_OF_RANGE;
  if (count > kMaxPathPoints) return proto::REASON_OVER_CAPACITY;
  if (!is_index(count)) return proto::REASON_OUT_OF_RANGE;
  if (n > count) return proto::REASON_ARG_COUNT;
  // Everything checked: the old path goes, whole.
  count_ = static_cast<uint16_t>(count);
  received_ = index_ = 0;
  ahead_m_ = 0.0f;
  start_ = Point{start.x_m, start.y_m};
  store(0, xy, n);
  update_segment();
  return 0;
}

uint8_t Path::append(float index, const float* xy, uint8_t n) {
  if (all_received()) return proto::REASON_BAD_STATE;
  if (!is_index(index)) return proto::REASON_OUT_OF_RANGE;
  if (static_cast<uint16_t>(index) != received_) return proto::REASON_OUT_OF_ORDER;
  if (n > count_ - received_) return proto::REASON_OVER_CAPACITY;
  if (n > room()) return proto::REASON_WINDOW_FULL;
  const uint16_t before = received_;
  store(received_, xy, n);
  // The current waypoint was the last received (or none had arrived): what lies beyond it,
  // and so its exit speed, has just become known.
  if (index_ + 1 >= before) update_segment();
  return 0;
}

void Path::store(uint16_t first, const float* xy, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) {
    const uint16_t k = first + i;
    slot(k) = Point{xy[2 * i], xy[2 * i + 1]};
    if (k > index_) ahead_m_ += length_bound(slot(k - 1), slot(k));
  }
  received_ = first + n;
}

uint16_t Path::room() const {
  const uint16_t to_path_end = count_ - received_;
  const uint16_t to_window_end = kWindow - (received_ - base());  // received - base <= kWindow
  return to_path_end < to_window_end ? to_path_end : to_window_end;
}

void Path::set_single(const Point& point, const Pose& start) {
  slot(0) = point;
  count_ = received_ = 1;
  index_ = 0;
  ahead_m_ = 0.0f;
  start_from(start);
}

void Path::start_from(const Pose& pose) {
  start_ = Point{pose.x_m, pose.y_m};
  update_segment();  // the first corner's angle depends on the start
}

void Path::advance() {
  if (index_ >= received_) return;
  const bool next_known = index_ + 1 < received_;
  if (next_known) ahead_m_ -= length_bound(slot(index_), slot(index_ + 1));
  ++index_;
  // Nothing received beyond the new waypoint: exactly zero (the sums above round).
  if (index_ + 1 >= received_ || ahead_m_ < 0.0f) ahead_m_ = 0.0f;
  update_segment();
}

// Called when the current waypoint changes, or what lies beyond it arrives: the direction of the
// segment that leads to it, and how fast the cart may pass it: the follower's speed law just
// after the switch, when the heading error is the turn (full speed straight on, zero from 45
// degrees on, and zero while the point after it is unknown).
void Path::update_segment() {
  exit_factor_ = 0.0f;
  dir_ = Point{0.0f, 0.0f};
  if (index_ >= received_) return;
  const Point& here = slot(index_);
  const Point& from = previous();
  const float in_x = here.x_m - from.x_m, in_y = here.y_m - from.y_m;
  const float in_sq = in_x * in_x + in_y * in_y;
  if (in_sq > 1e-12f) {
    const float inverse = 1.0f / sqrtf(in_sq);
    dir_ = Point{in_x * inverse, in_y * inverse};
  }
  if (at_last_received()) return;
  const Point& next = slot(index_ + 1);
  const float out_x = next.x_m - here.x_m, out_y = next.y_m - here.y_m;
  exit_factor_ = heading_speed_factor(in_x * out_x + in_y * out_y, in_x * out_y - in_y * out_x);
}

float Path::pass_radius(float tol_pass_m, float tol_final_m) const {
  return fmaxf(tol_final_m, tol_pass_m * exit_factor_);
}

bool Path::passed(const Pose& pose) const {
  const Point& here = current();
  return (pose.x_m - here.x_m) * dir_.x_m + (pose.y_m - here.y_m) * dir_.y_m > 0.0f;
}

Approach Path::approach(float v_max_mps) const {
  Approach a;
  a.x_m = current().x_m;
  a.y_m = current().y_m;
  // The last point received is approached as the path's end is: the cart must be able to stop
  // on it, and it does unless more points arrive first.
  a.final = at_last_received();
  a.exit_speed_mps = v_max_mps * exit_factor_;
  a.dir_x = dir_.x_m;
  a.dir_y = dir_.y_m;
  a.beyond_m = ahead_m_;
  return a;
}

}  // namespace core
