#include "path.hpp"

#include "num.hpp"  // sqrtf, clamp

namespace core {

uint8_t Path::begin(float count) {
  // Written so that NaN fails too, before any float -> integer conversion.
  if (!(count >= 1.0f)) return proto::REASON_OUT_OF_RANGE;
  if (count > kWaypointCapacity) return proto::REASON_OVER_CAPACITY;
  if (count != static_cast<float>(static_cast<uint8_t>(count))) return proto::REASON_OUT_OF_RANGE;
  count_ = static_cast<uint8_t>(count);
  received_ = 0;
  index_ = 0;
  return 0;
}

uint8_t Path::append(float index, const float* xy, uint8_t n) {
  if (!upload_open()) return proto::REASON_BAD_STATE;
  if (!(index >= 0.0f && index <= received_) || index != static_cast<float>(static_cast<uint8_t>(index)))
    return proto::REASON_OUT_OF_RANGE;
  const uint8_t first = static_cast<uint8_t>(index);
  if (first + n > count_) return proto::REASON_OVER_CAPACITY;
  for (uint8_t i = 0; i < n; ++i) points_[first + i] = Point{xy[2 * i], xy[2 * i + 1]};
  if (first + n > received_) received_ = first + n;
  if (!upload_open()) update_segment();
  return 0;
}

void Path::set_single(const Point& point) {
  points_[0] = point;
  count_ = received_ = 1;
  index_ = 0;
  exit_factor_ = 0.0f;
  dir_ = Point{0.0f, 0.0f};
}

void Path::start_from(const Pose& pose) {
  start_.x_m = pose.x_m;
  start_.y_m = pose.y_m;
  if (!upload_open()) update_segment();  // the first corner's angle depends on the start
}

void Path::advance() {
  if (index_ < count_) ++index_;
  update_segment();
}

void Path::clear() { count_ = received_ = index_ = 0; }

// Called when the current waypoint changes: the direction of the segment that leads to it,
// and how fast the cart may pass it: the follower's speed law just after the switch, when the
// heading error is the turn (full speed straight on, zero from 45 degrees on).
void Path::update_segment() {
  exit_factor_ = 0.0f;
  dir_ = Point{0.0f, 0.0f};
  if (index_ >= count_) return;
  const Point& here = points_[index_];
  const Point& from = previous();
  const float in_x = here.x_m - from.x_m, in_y = here.y_m - from.y_m;
  const float in_sq = in_x * in_x + in_y * in_y;
  if (in_sq > 1e-12f) {
    const float inverse = 1.0f / sqrtf(in_sq);
    dir_ = Point{in_x * inverse, in_y * inverse};
  }
  if (index_ + 1 >= count_) return;
  const Point& next = points_[index_ + 1];
  const float out_x = next.x_m - here.x_m, out_y = next.y_m - here.y_m;
  exit_factor_ = heading_speed_factor(in_x * out_x + in_y * out_y, in_x * out_y - in_y * out_x);
}

float Path::pass_radius(float tol_pass_m, float tol_final_m) const {
  return fmaxf(tol_final_m, tol_pass_m * exit_factor_);
}

bool Path::passed(const Pose& pose) const {
  const Point& here = points_[index_];
  return (pose.x_m - here.x_m) * dir_.x_m + (pose.y_m - here.y_m) * dir_.y_m > 0.0f;
}

Approach Path::approach(float v_max_mps) const {
  Approach a;
  a.x_m = points_[index_].x_m;
  a.y_m = points_[index_].y_m;
  a.final = at_last();
  a.exit_speed_mps = v_max_mps * exit_factor_;
  a.dir_x = dir_.x_m;
  a.dir_y = dir_.y_m;
  return a;
}

}  // namespace core
