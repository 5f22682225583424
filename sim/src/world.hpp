// The arena: four walls around the node grid (they stop the cart) and obstacle cells (virtual,
// like the planner's: the cart may drive through them, and every such overlap is reported).
//
// Frames follow REP-103 (x forward, y left, θ counter-clockwise). The grid's origin node is (0, 0)
// and its nodes sit at multiples of grid_step; the walls lie `margin` outside the outer nodes.
#pragma once

#include <string>
#include <vector>

#include "body.hpp"          // Pose, VelocityConstraint
#include "robot_params.hpp"  // params::body, params::sim

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct RobotGeometry {
  double footprint_radius_m = params::body::footprint_radius_m;  // disc around the centre of the wheel axis
  double bumper_x_m = params::body::bumper_x_m;                  // flat front bumper, in body frame
  double switch_y_m = params::body::switch_y_m;                  // the two front switches at (bumper_x, ±switch_y)
};

// Defaults: the simulated arena (config/robot.toml, [sim]).
struct ArenaParams {
  double grid_step_m = params::sim::grid_step_m;
  int grid_nodes = static_cast<int>(params::sim::grid_nodes);
  double margin_m = params::sim::arena_margin_m;
};

// One feature of the cart measured against one wall: its gap (negative = penetration) and the
// rate of change of that gap per unit (v, ω): d(gap)/dt = jv·v + jw·ω.
struct WallProbe {
  enum Feature { kDisc = 0, kSwitchLeft = 1, kSwitchRight = 2 };
  Feature feature = kDisc;
  int wall = 0;  // 0 west (x min), 1 east (x max), 2 south (y min), 3 north (y max)
  double gap_m = 0.0;
  double jv = 0.0;
  double jw = 0.0;
};

struct Obstacle {
  double cx_m = 0.0, cy_m = 0.0;  // centre
  double half_m = params::sim::grid_step_m / 2.0;  // half the side of the square (default: one grid cell)
};

class World {
 public:
  explicit World(const ArenaParams& arena);

  void set_margin(double margin_m);
  // The node grid the walls surround: `nodes` per side, `step_m` apart.
  void set_grid(int nodes, double step_m);
  const ArenaParams& arena() const { return arena_; }
  double x_min() const { return -arena_.margin_m; }
  double y_min() const { return -arena_.margin_m; }
  double x_max() const { return (arena_.grid_nodes - 1) * arena_.grid_step_m + arena_.margin_m; }
  double y_max() const { return x_max(); }

  // Every feature (disc, both switch points) against every wall.
  void probes(const Pose& pose, const RobotGeometry& geom, std::vector<WallProbe>* out) const;
  // Smallest gap of one switch point (left = +y) to any wall.
  double switch_gap_m(const Pose& pose, const RobotGeometry& geom, bool left) const;

  void set_obstacles(std::vector<Obstacle> obstacles) { obstacles_ = std::move(obstacles); }
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  // True if a disc overlaps obstacle k (touching counts: distance < radius + 1e-9).
  bool disc_overlaps(const Obstacle& o, double x_m, double y_m, double r_m) const;

 private:
  ArenaParams arena_;
  std::vector<Obstacle> obstacles_;
};

// Counts contact onsets along the trajectory: obstacle collisions (each obstacle the footprint
// starts to overlap) and wall contacts (any feature reaching a wall), with the first time of each.
class ContactMonitor {
 public:
  struct Event {
    std::string kind;  // "collision" or "wall_contact"
    double t_s = 0.0;
    double x_m = 0.0, y_m = 0.0;  // obstacle centre, or the cart's position for a wall
  };

  void update(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
              const std::vector<WallProbe>& probes);
  void obstacles_changed() { touching_.clear(); }
  void reset();
  std::vector<Event> take_events();

  long collisions() const { return collisions_; }
  long wall_contacts() const { return wall_contacts_; }
  double first_collision_t() const { return first_collision_t_; }        // < 0: none yet
  double first_wall_contact_t() const { return first_wall_contact_t_; }  // < 0: none yet
  bool in_collision() const { return in_collision_; }
  bool in_wall_contact() const { return in_wall_contact_; }

  static constexpr double kTouchM = 1e-4;    // a wall gap at or below this starts a contact...
  static constexpr double kReleaseM = 1e-3;  // ...and the contact ends above this (hysteresis)

 private:
  std::vector<char> touching_;
  bool in_collision_ = false;
  bool in_wall_contact_ = false;
  long collisions_ = 0;
  long wall_contacts_ = 0;
  double first_collision_t_ = -1.0;
  double first_wall_contact_t_ = -1.0;
  std::vector<Event> events_;
};

}  // namespace cart2d
