// The simulated world: physical rectangles the cart cannot pass (walls: an arena's boundary, a
// map's occupied cells; boxes: things standing on the floor) and the planner's virtual obstacles
// (the cart drives through them, and every such overlap is reported). The two are kept apart:
// the world holds what is physically there, the planner's map what the gateway believes.
//
// Frames follow REP-103 (x forward, y left, θ counter-clockwise). By default the world is the
// seed's square arena: four walls `margin` outside a square node grid whose origin node is (0, 0).
//
// The cart meets the rectangles with four kinds of feature: its footprint disc (centred on the
// axle), its two bumper-switch points (bumper_x, ±switch_y), and the flat bumper between them,
// against a rectangle's corner. Each gives a gap (negative = penetration) and its rate per unit
// (v, ω), d(gap)/dt = jv·v + jw·ω: the disc's is the gradient of the distance (box.hpp) along the
// heading (the disc turns about its own centre: jw = 0); a point's adds its lever arm; a corner at
// (x_b, y_b) in the body frame has gap x_b − bumper_x, and d/dt x_b = −v + ω·y_b.
#pragma once

#include <algorithm>  // std::remove_if
#include <cstdint>
#include <string>
#include <vector>

#include "body.hpp"  // Pose
#include "box.hpp"
#include "box_grid.hpp"
#include "look.hpp"
#include "occupancy.hpp"
#include "robot_params.hpp"  // params::body, params::sim

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct RobotGeometry {
  double footprint_radius_m = params::body::footprint_radius_m;  // disc around the centre of the wheel axis
  double bumper_x_m = params::body::bumper_x_m;                  // flat front bumper, in body frame
  double switch_y_m = params::body::switch_y_m;                  // the two front switches at (bumper_x, ±switch_y)
};

// Defaults: the simulated arena (config/robot.toml, [sim]): the square node grid of the default
// world, and the default cell of a virtual obstacle.
struct ArenaParams {
  double grid_step_m = params::sim::grid_step_m;
  int grid_nodes = static_cast<int>(params::sim::grid_nodes);
  double margin_m = params::sim::arena_margin_m;
  // Where the square arena's walls stand.
  double x_min() const { return -margin_m; }
  double y_min() const { return -margin_m; }
  double x_max() const { return (grid_nodes - 1) * grid_step_m + margin_m; }
  double y_max() const { return x_max(); }
};

// One feature of the cart measured against one rectangle.
struct ContactProbe {
  enum Feature { kDisc = 0, kSwitchLeft = 1, kSwitchRight = 2, kBumper = 3 };
  Feature feature = kDisc;
  uint32_t box = 0;  // index into World::boxes()
  double gap_m = 0.0;
  double jv = 0.0;
  double jw = 0.0;
  double lateral_m = 0.0;  // kBumper: where the corner presses, body y (+ = left)
};

struct Obstacle {
  double cx_m = 0.0, cy_m = 0.0;  // centre
  double half_m = params::sim::grid_step_m / 2.0;  // half the side of the square (default: one grid cell)
};

class World {
 public:
  static constexpr double kWallThicknessM = 1.0;  // a boundary wall: far thicker than a step's motion
  static constexpr double kWallHeightM = 0.5;     // defaults for the camera
  static constexpr double kBoxHeightM = 0.3;
  static constexpr uint32_t kWallColour = 0xd8d8d8;
  static constexpr uint32_t kBoxColour = 0xb8742f;
  // Probes are made for features within this of a rectangle (the cart's contacts act within 2 cm,
  // the contact statistics within 1 mm).
  static constexpr double kProbeMarginM = 0.05;
  // A footprint overlaps a rectangle when a feature is deeper inside than this (touching is fine).
  static constexpr double kOverlapToleranceM = 1e-9;

  World() = default;  // an endless floor
  explicit World(const ArenaParams& arena);  // the square arena

  // The square node grid of the default arena (also the default obstacle cell).
  const ArenaParams& arena() const { return arena_; }
  // Replaces every rectangle by the four walls of the square arena around this grid.
  void set_square_arena(const ArenaParams& arena);

  // -- physical rectangles (every change bumps version()) --
  void clear_physical();
  // Four walls of kWallThicknessM outside the rectangle [x0, x1] × [y0, y1].
  void add_boundary(double x0_m, double y0_m, double x1_m, double y1_m, double height_m = kWallHeightM,
                    uint32_t colour_rgb = kWallColour);
  // The occupied cells of a grid with its lower-left corner at the origin, merged (occupancy.hpp).
  void add_wall_grid(double origin_x_m, double origin_y_m, double resolution_m, const OccupancyGrid& grid,
                     double height_m = kWallHeightM, uint32_t colour_rgb = kWallColour);
  // Adds a rectangle (a box with a non-empty id replaces the box of that id, unless the caller
  // knows there is none); returns its index.
  size_t add(Box b, bool replace_id = true);
  // Removes the boxes of this id; returns how many.
  size_t remove_id(const std::string& id);
  // Removes every rectangle for which pred(box) holds, in one pass; returns how many.
  template <class Pred>
  size_t remove_boxes_if(Pred pred);
  // Removes every box (kind kBox), walls stay.
  void clear_boxes();
  const std::vector<Box>& boxes() const { return boxes_; }
  size_t count(BoxKind kind) const;
  uint64_t version() const { return version_; }

  // How it looks to the camera (look.hpp); the physics never reads it.
  void set_look(const Look& look) { look_ = look; }
  const Look& look() const { return look_; }

  // Contact probes of every feature within `margin` of a solid rectangle near the pose.
  void probes(const Pose& pose, const RobotGeometry& geom, std::vector<ContactProbe>* out,
              double margin_m = kProbeMarginM) const;
  // The smallest gap of any feature of the footprint to this rectangle (< 0: they overlap).
  double footprint_gap_m(const Pose& pose, const RobotGeometry& geom, const Box& b) const;
  // The first rectangle (solid or not) the footprint overlaps, or -1.
  long overlapping(const Pose& pose, const RobotGeometry& geom) const;

  // A rectangle that appears under the cart does not throw it aside: it stays non-solid until the
  // footprint has left it by kSettleGapM (its overlap counts as a contact meanwhile; the margin is
  // the contact statistics' release distance, so leaving it does not count as a new contact).
  size_t defer_overlapping(const Pose& pose, const RobotGeometry& geom);
  void settle(const Pose& pose, const RobotGeometry& geom);
  static constexpr double kSettleGapM = 1e-3;
  const std::vector<uint32_t>& deferred() const { return deferred_; }

  // -- virtual obstacles --
  void set_obstacles(std::vector<Obstacle> obstacles);
  void add_obstacle(const Obstacle& o) {  // (tests) after the others
    obstacles_.push_back(o);
    obstacles_dirty_ = true;
  }
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  // True if a disc overlaps obstacle o (touching counts: distance < radius + 1e-9).
  bool disc_overlaps(const Obstacle& o, double x_m, double y_m, double r_m) const;
  // Appends the indices of obstacles that a disc at (x, y) of radius r may overlap.
  void obstacles_near(double x_m, double y_m, double r_m, std::vector<uint32_t>* out) const;

  // Narrow-phase tests made by the last probes() call (for tests and benchmarks).
  size_t last_candidates() const { return last_candidates_; }

 private:
  void changed() {
    ++version_;
    boxes_dirty_ = true;
  }
  void rebuild_boxes() const;
  void rebuild_deferred();
  void rebuild_obstacles() const;
  void probe_box(uint32_t index, const Pose& pose, const RobotGeometry& geom, double margin_m,
                 std::vector<ContactProbe>* out) const;

  ArenaParams arena_;
  std::vector<Box> boxes_;
  std::vector<uint32_t> deferred_;
  std::vector<Obstacle> obstacles_;
  Look look_;
  uint64_t version_ = 0;
  uint64_t next_serial_ = 1;
  mutable BoxGrid box_grid_, obstacle_grid_;
  mutable bool boxes_dirty_ = true, obstacles_dirty_ = true;
  mutable std::vector<uint32_t> candidates_;
  mutable size_t last_candidates_ = 0;
  mutable uint64_t counted_version_ = UINT64_MAX;
  mutable size_t walls_ = 0;
};

template <class Pred>
size_t World::remove_boxes_if(Pred pred) {
  const size_t before = boxes_.size();
  boxes_.erase(std::remove_if(boxes_.begin(), boxes_.end(), pred), boxes_.end());
  if (boxes_.size() == before) return 0;
  rebuild_deferred();  // indices moved
  changed();
  return before - boxes_.size();
}

// Counts contact onsets along the trajectory, with the first time of each kind: obstacle
// collisions (each virtual obstacle the footprint starts to overlap, or whose box, if it is
// physical, a feature starts to touch), wall contacts (any feature reaching any wall) and box
// contacts (each box a feature starts to touch).
class ContactMonitor {
 public:
  struct Event {
    std::string kind;  // "collision", "wall_contact" or "box_contact"
    double t_s = 0.0;
    double x_m = 0.0, y_m = 0.0;  // obstacle or box centre, or the cart's position for a wall
    std::string id;               // a box's id
  };

  void update(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
              const std::vector<ContactProbe>& probes);
  void reset();
  std::vector<Event> take_events();

  long collisions() const { return collisions_; }
  long wall_contacts() const { return wall_contacts_; }
  long box_contacts() const { return box_contacts_; }
  double first_collision_t() const { return first_collision_t_; }        // < 0: none yet
  double first_wall_contact_t() const { return first_wall_contact_t_; }  // < 0: none yet
  double first_box_contact_t() const { return first_box_contact_t_; }    // < 0: none yet
  bool in_collision() const { return !touching_obstacles_.empty(); }
  bool in_wall_contact() const { return in_wall_contact_; }
  bool in_box_contact() const { return !touching_boxes_.empty(); }

  static constexpr double kTouchM = 1e-4;    // a gap at or below this starts a contact...
  static constexpr double kReleaseM = 1e-3;  // ...and the contact ends above this (hysteresis)

 private:
  void update_obstacles(double t_s, const World& world, const Pose& pose, double radius_m);
  void update_boxes(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
                    const std::vector<ContactProbe>& probes);

  struct Centre {
    double x_m, y_m;
  };
  std::vector<Centre> touching_obstacles_;
  std::vector<Centre> touching_twins_;  // physical obstacles' boxes in contact
  std::vector<uint64_t> touching_boxes_;  // serials
  bool in_wall_contact_ = false;
  long collisions_ = 0;
  long wall_contacts_ = 0;
  long box_contacts_ = 0;
  double first_collision_t_ = -1.0;
  double first_wall_contact_t_ = -1.0;
  double first_box_contact_t_ = -1.0;
  std::vector<Event> events_;
  std::vector<uint32_t> scratch_;
};

}  // namespace cart2d
