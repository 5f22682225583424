// The path and its waypoint window (docs/protocol.md, "Paths and the waypoint window"): a path
// of up to kMaxPathPoints points streams through a ring of kWindow slots. WAIT_XY_ARRAY begins a
// path (replacing the current one whole), XY_APPEND continues it strictly in order; a slot is
// reused once the cart no longer needs its point: the window starts at the point before the
// current waypoint, where the segment into the current waypoint begins.
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

constexpr uint8_t kWindow = params::control::waypoint_capacity;
// A power of two, so that a point's slot is its index masked (no division on the AVR); at least
// one frame (15 points) beyond the current waypoint and the one before it.
static_assert(kWindow >= 16 && kWindow <= 128 && (kWindow & (kWindow - 1)) == 0, "window size");
// count, received and index are uint16_t (index reaches count on arrival); all are exact floats.
constexpr uint16_t kMaxPathPoints = 65535;

class Path {
 public:
  // A new path of `count` points, the first n of them in xy = {x0, y0, x1, y1, ...}, driven from
  // `start`. It replaces the current path whole; refused, it changes nothing. 0 when accepted,
  // else a proto::Reason.
  uint8_t begin(float count, const float* xy, uint8_t n, const Pose& start);
  // Points [index, index + n) of the path: index must be received() and the points must fit
  // the window and the path. Refused, nothing is stored. 0 when accepted.
  uint8_t append(float index, const float* xy, uint8_t n);
  // Replace the path by one point (GOTO).
  void set_single(const Point& point, const Pose& start);

  uint16_t count() const { return count_; }
  uint16_t received() const { return received_; }
  uint16_t index() const { return index_; }
  // Points XY_APPEND may send now: up to the window's end or the path's, whichever is nearer.
  uint16_t room() const;
  bool all_received() const { return received_ == count_; }
  // A waypoint to drive for (the current one has arrived).
  bool active() const { return index_ < received_; }
  // Not finished: waypoints to drive for, or to wait for.
  bool pending() const { return index_ < count_; }
  // The current waypoint is the path's last.
  bool at_last() const { return index_ + 1 >= count_; }
  // Nothing has arrived after the current waypoint (yet): the cart must be able to stop on it.
  bool at_last_received() const { return index_ + 1 >= received_; }
  const Point& current() const { return slot(index_); }
  // Length of the received path beyond the current waypoint (a lower bound, within 30 %).
  float length_ahead_m() const { return ahead_m_; }

  // Where the path starts: the corner angle at the first waypoint is measured from here.
  void start_from(const Pose& pose);
  // On to the next waypoint (past the last one when the cart has arrived on it). The caller
  // makes sure the next one has arrived, or that the current one is the path's last.
  void advance();

  // True once the cart is beyond the current waypoint along the segment that leads to it.
  bool passed(const Pose& pose) const;

  // The current waypoint with what lies beyond it, for the polar controller.
  Approach approach(float v_max_mps) const;

  // Within this distance the current waypoint counts as passed: tol_pass where the cart may
  // keep its speed, shrinking to tol_final at a corner it must stop for. Turning early into a
  // sharp corner would cut it, towards the obstacle the planner went around.
  float pass_radius(float tol_pass_m, float tol_final_m) const;

 private:
  Point& slot(uint16_t i) { return points_[i & (kWindow - 1)]; }
  const Point& slot(uint16_t i) const { return points_[i & (kWindow - 1)]; }
  // The first index the window holds: the one before the current waypoint.
  uint16_t base() const { return index_ > 0 ? index_ - 1 : 0; }
  void store(uint16_t first, const float* xy, uint8_t n);
  void update_segment();
  void update_exit(float in_x, float in_y);
  const Point& previous() const { return index_ > 0 ? slot(index_ - 1) : start_; }

  Point points_[kWindow] = {};
  Point start_ = {0.0f, 0.0f};
  float exit_factor_ = 0.0f;    // exit speed at the current waypoint / v_max (corner angle)
  Point dir_ = {0.0f, 0.0f};    // unit direction of the segment into the current waypoint
  float ahead_m_ = 0.0f;        // length_ahead_m()
  uint16_t count_ = 0;
  uint16_t received_ = 0;
  uint16_t index_ = 0;
};

}  // namespace core
