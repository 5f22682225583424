// The waypoint buffer: filled by WAIT_XY_ARRAY (+ XY_APPEND), consumed by the follower.
#pragma once

#include <stdint.h>

#include "odometry.hpp"          // Pose
#include "polar_controller.hpp"  // Approach
#include "robot_params.hpp"      // params::control::waypoint_capacity
#include "protocol_table.hpp"    // proto::Reason

namespace core {

struct Point {
  float x_m;
  float y_m;
};

constexpr uint8_t kWaypointCapacity = params::control::waypoint_capacity;
static_assert(kWaypointCapacity >= 32 && kWaypointCapacity <= 250, "waypoint capacity");

class Path {
 public:
  // Open an upload of `count` points; refused (and the current path kept) if out of range.
  // 0 means accepted.
  uint8_t begin(float count);
  // Store points [index, index + n) from xy = {x0, y0, x1, y1, ...}; they must continue the
  // upload in order. A repeat of points already held is accepted (a retransmission).
  uint8_t append(float index, const float* xy, uint8_t n);
  // Replace the path by one point.
  void set_single(const Point& point);

  bool upload_open() const { return received_ < count_; }
  bool active() const { return count_ > 0 && !upload_open() && index_ < count_; }
  uint8_t count() const { return count_; }
  uint8_t received() const { return received_; }
  uint8_t index() const { return index_; }
  bool at_last() const { return index_ + 1 >= count_; }
  const Point& current() const { return points_[index_]; }

  // Where the path starts: the corner angle at the first waypoint is measured from here.
  void start_from(const Pose& pose);
  void advance();
  void clear();

  // True once the cart is beyond the current waypoint along the segment that leads to it.
  bool passed(const Pose& pose) const;

  // The current waypoint with what lies beyond it, for the polar controller.
  Approach approach(float v_max_mps) const;

  // Within this distance the current waypoint counts as passed: tol_pass where the cart may
  // keep its speed, shrinking to tol_final at a corner it must stop for. Turning early into a
  // sharp corner would cut it, towards the obstacle the planner went around.
  float pass_radius(float tol_pass_m, float tol_final_m) const;

 private:
  void update_segment();
  const Point& previous() const { return index_ > 0 ? points_[index_ - 1] : start_; }

  Point points_[kWaypointCapacity] = {};
  Point start_ = {0.0f, 0.0f};
  float exit_factor_ = 0.0f;    // exit speed at the current waypoint / v_max (corner angle)
  Point dir_ = {0.0f, 0.0f};    // unit direction of the segment into the current waypoint
  uint8_t count_ = 0;
  uint8_t received_ = 0;
  uint8_t index_ = 0;
};

}  // namespace core
