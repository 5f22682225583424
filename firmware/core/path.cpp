#include "path.hpp"

#include "num.hpp"  // sqrtf, clamp

namespace core {

static float distance(const Point& a, const Point& b) {
  const float dx = b.x_m - a.x_m;
  const float dy = b.y_m - a.y_m;
  return sqrtf(dx * dx + dy * dy);
}

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
  if (!upload_open()) update_after();
  return 0;
}

void Path::set_single(const Point& point) {
  points_[0] = point;
  count_ = received_ = 1;
  index_ = 0;
  after_m_ = 0.0f;
}

void Path::start_from(const Pose& pose) {
  start_.x_m = pose.x_m;
  start_.y_m = pose.y_m;
}

void Path::advance() {
  if (index_ < count_) ++index_;
  update_after();
}

void Path::clear() { count_ = received_ = index_ = 0; }

void Path::update_after() {
  after_m_ = 0.0f;
  for (uint8_t i = index_ + 1; i < count_; ++i) after_m_ += distance(points_[i - 1], points_[i]);
}

bool Path::passed(const Pose& pose) const {
  const Point& here = points_[index_];
  const Point& from = previous();
  return (pose.x_m - here.x_m) * (here.x_m - from.x_m) + (pose.y_m - here.y_m) * (here.y_m - from.y_m) > 0.0f;
}

// The exit speed at a corner shrinks with the turn: full speed straight on, zero for a
// U-turn (the follower's cos(heading error) law gives the same speed just after the switch).
Approach Path::approach(float v_max_mps) const {
  Approach a;
  const Point& here = points_[index_];
  a.x_m = here.x_m;
  a.y_m = here.y_m;
  a.after_m = after_m_;
  a.final = at_last();
  a.exit_speed_mps = 0.0f;
  if (!a.final) {
    const Point& from = previous();
    const Point& next = points_[index_ + 1];
    const float in_x = here.x_m - from.x_m, in_y = here.y_m - from.y_m;
    const float out_x = next.x_m - here.x_m, out_y = next.y_m - here.y_m;
    const float norms = sqrtf((in_x * in_x + in_y * in_y) * (out_x * out_x + out_y * out_y));
    const float cos_turn = norms > 1e-9f ? (in_x * out_x + in_y * out_y) / norms : 0.0f;
    a.exit_speed_mps = v_max_mps * clamp(cos_turn, 0.0f, 1.0f);
  }
  return a;
}

}  // namespace core
