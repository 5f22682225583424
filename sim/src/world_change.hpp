// Changes to the simulated world from the side channel (`world`, `boxes`, `obstacles`; see
// sim/README.md): each message is parsed and checked in full when it arrives, into a WorldChange
// that can then be applied at once or at its simulated time ("at") and cannot fail then.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "json.hpp"
#include "occupancy.hpp"
#include "world.hpp"

namespace cart2d {

struct WorldChange {
  enum class What { kWorld, kBoxes, kObstacles };
  What what = What::kWorld;
  double at_s = -1.0;  // simulated time to apply it; < 0: now

  // kWorld: the physical world is replaced by a walls grid, a boundary and the boxes below.
  bool has_grid = false;
  double grid_origin_x_m = 0.0, grid_origin_y_m = 0.0, grid_resolution_m = 0.0;
  OccupancyGrid grid;
  double wall_height_m = World::kWallHeightM;
  uint32_t wall_colour = World::kWallColour;
  bool has_boundary = false;
  double boundary[4] = {0.0, 0.0, 0.0, 0.0};  // x0, y0, x1, y1

  // kWorld and kBoxes.
  bool clear_boxes = false;
  std::vector<std::string> remove_ids;
  std::vector<Box> add_boxes;

  // kObstacles: the set replaced (if replace_obstacles), then points removed, then added; each
  // added one also a box when physical.
  bool replace_obstacles = false;
  std::vector<std::pair<double, double>> remove_obstacles;
  std::vector<Obstacle> add_obstacles;
  bool physical = false;
  double twin_height_m = World::kBoxHeightM;
  uint32_t twin_colour = World::kBoxColour;
};

// Parses a message of type "world", "boxes" or "obstacles". `defaults` gives the obstacle cell
// and the node grid that "cells" index. Returns "" or the reason it is refused.
std::string parse_world_change(const std::string& type, const json::Value& msg, const ArenaParams& defaults,
                               WorldChange* out);

// Applies it (the caller then tells the Rig: Rig::world_changed).
void apply_world_change(const WorldChange& change, World* world);

}  // namespace cart2d
