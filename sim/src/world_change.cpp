#include "world_change.hpp"

#include <cmath>  // std::isfinite, std::floor, std::fabs, std::llround
#include <map>
#include <set>

namespace cart2d {

namespace {

constexpr double kMaxCoordinateM = 1e5;  // |x|, |y| of anything placed
constexpr double kMaxSizeM = 1e4;        // a box's side, a grid's extent
constexpr double kMaxGridCells = 16e6;   // width · height (a 4000 × 4000 map)

bool number_of(const json::Value* v, double* out) {
  if (!v || !v->is_number() || !std::isfinite(v->number)) return false;
  *out = v->number;
  return true;
}

bool pair_of(const json::Value& v, double* a, double* b) {
  if (!v.is_array() || v.array.size() != 2) return false;
  return number_of(&v.array[0], a) && number_of(&v.array[1], b);
}

bool coordinate_ok(double v) { return std::fabs(v) <= kMaxCoordinateM; }

// An optional number member within [lo, hi]; "" or the reason.
std::string optional_number(const json::Value& msg, const char* key, double lo, double hi, double* out) {
  const json::Value* v = msg.find(key);
  if (!v) return "";
  if (!number_of(v, out) || *out < lo || *out > hi)
    return std::string(key) + " must be a number in [" + json::number(lo) + ", " + json::number(hi) + "]";
  return "";
}

std::string optional_colour(const json::Value& msg, const char* key, uint32_t* rgb) {
  const json::Value* v = msg.find(key);
  if (!v) return "";
  if (!v->is_string() || !parse_colour(v->string, rgb)) return std::string(key) + " must be \"#rrggbb\"";
  return "";
}

// An id is a string, or a number written as JSON writes it.
std::string id_of(const json::Value& v, std::string* out) {
  if (v.is_string() && !v.string.empty() && v.string.size() <= 200) *out = v.string;
  else if (v.is_number()) *out = json::number(v.number);
  else return "an id must be a non-empty string (at most 200 characters) or a number";
  return "";
}

std::string parse_box(const json::Value& v, size_t index, Box* b) {
  const std::string where = "boxes[" + std::to_string(index) + "]: ";
  if (!v.is_object()) return where + "must be an object {x, y, sx, sy, height, colour, id}";
  double sx = 0.0, sy = 0.0;
  if (!number_of(v.find("x"), &b->cx_m) || !number_of(v.find("y"), &b->cy_m) || !coordinate_ok(b->cx_m) ||
      !coordinate_ok(b->cy_m))
    return where + "x and y (m, the centre) must be numbers within ±" + json::number(kMaxCoordinateM);
  if (!number_of(v.find("sx"), &sx) || !number_of(v.find("sy"), &sy) || !(sx > 0.0) || !(sy > 0.0) || sx > kMaxSizeM ||
      sy > kMaxSizeM)
    return where + "sx and sy (m, the size) must be numbers in (0, " + json::number(kMaxSizeM) + "]";
  b->hx_m = sx / 2;
  b->hy_m = sy / 2;
  b->height_m = World::kBoxHeightM;
  b->colour_rgb = World::kBoxColour;
  b->kind = BoxKind::kBox;
  if (std::string e = optional_number(v, "height", 0.0, kMaxSizeM, &b->height_m); !e.empty()) return where + e;
  if (std::string e = optional_colour(v, "colour", &b->colour_rgb); !e.empty()) return where + e;
  if (const json::Value* id = v.find("id"))
    if (std::string e = id_of(*id, &b->id); !e.empty()) return where + e;
  if (const json::Value* m = v.find("material")) {
    if (!m->is_string() || m->string != "wall") return where + "material must be \"wall\" (the look's wall paint) or absent";
    b->wall_paint = true;
  }
  return "";
}

std::string parse_box_list(const json::Value& msg, const char* key, std::vector<Box>* out) {
  const json::Value* boxes = msg.find(key);
  if (!boxes) return "";
  if (!boxes->is_array()) return std::string(key) + " must be an array of {x, y, sx, sy, height, colour, id}";
  for (size_t k = 0; k < boxes->array.size(); ++k) {
    Box b;
    if (std::string e = parse_box(boxes->array[k], k, &b); !e.empty()) return e;
    out->push_back(std::move(b));
  }
  return "";
}

std::string parse_grid(const json::Value& walls, WorldChange* c) {
  if (!walls.is_object()) return "walls must be an object {origin, resolution, width, height, rle or bits}";
  double w = 0.0, h = 0.0;
  if (const json::Value* o = walls.find("origin"); !o || !pair_of(*o, &c->grid_origin_x_m, &c->grid_origin_y_m) ||
                                                   !coordinate_ok(c->grid_origin_x_m) || !coordinate_ok(c->grid_origin_y_m))
    return "walls.origin must be [x, y] (m): the lower-left corner of cell (0, 0)";
  if (!number_of(walls.find("resolution"), &c->grid_resolution_m) || !(c->grid_resolution_m > 0.0) ||
      c->grid_resolution_m > 10.0)
    return "walls.resolution must be a cell side in (0, 10] m";
  if (!number_of(walls.find("width"), &w) || !number_of(walls.find("height"), &h) || w < 1 || h < 1 ||
      w != std::floor(w) || h != std::floor(h) || w * h > kMaxGridCells)
    return "walls.width and walls.height must be whole numbers of cells, at most " + json::number(kMaxGridCells) +
           " cells in all";
  if (std::fmax(w, h) * c->grid_resolution_m > kMaxSizeM) return "walls: the grid is larger than " + json::number(kMaxSizeM) + " m";
  c->grid.width = static_cast<int>(w);
  c->grid.height = static_cast<int>(h);
  if (std::string e = optional_number(walls, "wall_height", 0.0, kMaxSizeM, &c->wall_height_m); !e.empty())
    return "walls." + e;
  if (std::string e = optional_colour(walls, "colour", &c->wall_colour); !e.empty()) return "walls." + e;
  const json::Value* rle = walls.find("rle");
  const json::Value* bits = walls.find("bits");
  if ((rle != nullptr) == (bits != nullptr)) return "walls needs exactly one of rle (run lengths) and bits (base64)";
  std::string error;
  if (rle) {
    if (!rle->is_array()) return "walls.rle must be an array of run lengths";
    std::vector<double> runs;
    runs.reserve(rle->array.size());
    for (const json::Value& r : rle->array) {
      if (!r.is_number()) return "walls.rle must be an array of run lengths";
      runs.push_back(r.number);
    }
    if (!decode_runs(runs, &c->grid, &error)) return "walls.rle: " + error;
  } else {
    if (!bits->is_string()) return "walls.bits must be a base64 string";
    if (!decode_bitmap(bits->string, &c->grid, &error)) return "walls." + error;
  }
  c->has_grid = true;
  return "";
}

std::string parse_world(const json::Value& msg, WorldChange* c) {
  c->clear_boxes = true;
  if (const json::Value* walls = msg.find("walls"))
    if (std::string e = parse_grid(*walls, c); !e.empty()) return e;
  const json::Value* boundary = msg.find("boundary");
  if (!boundary || (boundary->is_bool() && boundary->boolean)) {
    c->has_boundary = c->has_grid;  // by default, around the grid (a floor with no edge is asked for)
    c->boundary[0] = c->grid_origin_x_m;
    c->boundary[1] = c->grid_origin_y_m;
    c->boundary[2] = c->grid_origin_x_m + c->grid.width * c->grid_resolution_m;
    c->boundary[3] = c->grid_origin_y_m + c->grid.height * c->grid_resolution_m;
    if (boundary && !c->has_grid) return "boundary: true needs walls (or give [x_min, y_min, x_max, y_max])";
  } else if (boundary->is_array() && boundary->array.size() == 4) {
    for (int k = 0; k < 4; ++k)
      if (!number_of(&boundary->array[k], &c->boundary[k]) || !coordinate_ok(c->boundary[k]))
        return "boundary must be [x_min, y_min, x_max, y_max] (m)";
    if (!(c->boundary[2] > c->boundary[0]) || !(c->boundary[3] > c->boundary[1]))
      return "boundary must have x_min < x_max and y_min < y_max";
    c->has_boundary = true;
  } else if (!boundary->is_bool()) {
    return "boundary must be true, false or [x_min, y_min, x_max, y_max] (m)";
  }
  return parse_box_list(msg, "boxes", &c->add_boxes);
}

std::string parse_boxes(const json::Value& msg, WorldChange* c) {
  if (const json::Value* clear = msg.find("clear")) {
    if (!clear->is_bool()) return "clear must be true or false";
    c->clear_boxes = clear->boolean;
  }
  if (const json::Value* remove = msg.find("remove")) {
    if (!remove->is_array()) return "remove must be an array of box ids";
    for (const json::Value& v : remove->array) {
      std::string id;
      if (std::string e = id_of(v, &id); !e.empty()) return "remove: " + e;
      c->remove_ids.push_back(id);
    }
  }
  if (msg.find("boxes")) return "boxes takes add (and remove, clear); world replaces everything";
  return parse_box_list(msg, "add", &c->add_boxes);
}

// [[x, y], ...] cell centres (m).
std::string parse_points(const json::Value& list, const char* key, std::vector<std::pair<double, double>>* out) {
  if (!list.is_array()) return std::string(key) + " must be an array of [x, y] cell centres (m)";
  for (const json::Value& p : list.array) {
    double x = 0.0, y = 0.0;
    if (!pair_of(p, &x, &y) || std::fabs(x) > 1000 || std::fabs(y) > 1000)
      return std::string("each point of ") + key + " must be [x, y] (m), within ±1000";
    out->push_back({x, y});
  }
  return "";
}

std::string parse_obstacles(const json::Value& msg, const ArenaParams& arena, WorldChange* c) {
  double step = arena.grid_step_m, ox = 0.0, oy = 0.0;
  double size = arena.grid_nodes;
  if (msg.find("step") && (!number_of(msg.find("step"), &step) || step <= 0.0 || step > 10.0))
    return "step must be a positive number (m)";
  if (const json::Value* o = msg.find("origin"); o && !pair_of(*o, &ox, &oy)) return "origin must be [x, y] (m)";
  if (msg.find("size") && (!number_of(msg.find("size"), &size) || size < 1 || size > 1000 || size != std::floor(size)))
    return "size must be a whole number of nodes per side";
  if (const json::Value* cells = msg.find("cells")) {
    if (!cells->is_array()) return "cells must be an array of [i, j] node indices";
    for (const auto& cell : cells->array) {
      double i = 0, j = 0;
      if (!pair_of(cell, &i, &j) || i != std::floor(i) || j != std::floor(j) || i < 0 || j < 0 || i >= size || j >= size)
        return "each cell must be [i, j] with whole i, j in [0, size)";
      c->add_obstacles.push_back({ox + i * step, oy + j * step, step / 2.0});
    }
    c->replace_obstacles = true;
  }
  std::vector<std::pair<double, double>> points;
  if (const json::Value* list = msg.find("points")) {
    if (std::string e = parse_points(*list, "points", &points); !e.empty()) return e;
    c->replace_obstacles = true;
  }
  if (const json::Value* list = msg.find("add"))
    if (std::string e = parse_points(*list, "add", &points); !e.empty()) return e;
  for (const auto& [x, y] : points) c->add_obstacles.push_back({x, y, step / 2.0});
  if (const json::Value* list = msg.find("remove"))
    if (std::string e = parse_points(*list, "remove", &c->remove_obstacles); !e.empty()) return e;
  if (!c->replace_obstacles && !msg.find("add") && !msg.find("remove"))
    return "obstacles needs cells or points (the new set), or add / remove";
  if (const json::Value* p = msg.find("physical")) {
    if (!p->is_bool()) return "physical must be true or false";
    c->physical = p->boolean;
  }
  if (std::string e = optional_number(msg, "height", 0.0, kMaxSizeM, &c->twin_height_m); !e.empty()) return e;
  return optional_colour(msg, "colour", &c->twin_colour);
}

// A place to micrometres: obstacles and their boxes are matched by centre.
using Place = std::pair<long long, long long>;
Place place_of(double x_m, double y_m) { return {std::llround(x_m * 1e6), std::llround(y_m * 1e6)}; }

// In one pass over the obstacles and one over the boxes, whatever their numbers.
void apply_obstacles(const WorldChange& c, World* world) {
  std::set<Place> gone;  // obstacles (and their twins) that go: removed, or replaced by an addition
  for (const auto& [x, y] : c.remove_obstacles) gone.insert(place_of(x, y));
  for (const Obstacle& o : c.add_obstacles) gone.insert(place_of(o.cx_m, o.cy_m));
  std::vector<Obstacle> next;
  if (!c.replace_obstacles)
    for (const Obstacle& o : world->obstacles())
      if (!gone.count(place_of(o.cx_m, o.cy_m))) next.push_back(o);
  world->remove_boxes_if([&](const Box& b) {
    return b.obstacle_twin && (c.replace_obstacles || gone.count(place_of(b.cx_m, b.cy_m)));
  });
  std::map<Place, size_t> last;  // of obstacles added at one place, the last counts
  for (size_t k = 0; k < c.add_obstacles.size(); ++k) last[place_of(c.add_obstacles[k].cx_m, c.add_obstacles[k].cy_m)] = k;
  for (size_t k = 0; k < c.add_obstacles.size(); ++k) {
    const auto it = c.add_obstacles.begin() + static_cast<long>(k);
    if (last[place_of(it->cx_m, it->cy_m)] != k) continue;
    next.push_back(*it);
    if (!c.physical) continue;
    Box b;
    b.cx_m = it->cx_m;
    b.cy_m = it->cy_m;
    b.hx_m = b.hy_m = it->half_m;
    b.height_m = c.twin_height_m;
    b.colour_rgb = c.twin_colour;
    b.kind = BoxKind::kBox;
    b.obstacle_twin = true;
    b.id = "obstacle@" + json::number(it->cx_m) + "," + json::number(it->cy_m);
    world->add(b, false);  // its place held no twin any more: no id to replace
  }
  world->set_obstacles(std::move(next));
}

}  // namespace

std::string parse_world_change(const std::string& type, const json::Value& msg, const ArenaParams& defaults,
                               WorldChange* out) {
  *out = WorldChange{};
  if (const json::Value* at = msg.find("at"); at && (!number_of(at, &out->at_s) || out->at_s < 0.0 || out->at_s > 1e9))
    return "at must be a simulated time in [0, 1e9] s";
  if (type == "world") {
    out->what = WorldChange::What::kWorld;
    return parse_world(msg, out);
  }
  if (type == "boxes") {
    out->what = WorldChange::What::kBoxes;
    return parse_boxes(msg, out);
  }
  out->what = WorldChange::What::kObstacles;
  return parse_obstacles(msg, defaults, out);
}

void apply_world_change(const WorldChange& c, World* world) {
  if (c.what == WorldChange::What::kObstacles) {
    apply_obstacles(c, world);
    return;
  }
  if (c.what == WorldChange::What::kWorld) {
    world->clear_physical();
    if (c.has_grid)
      world->add_wall_grid(c.grid_origin_x_m, c.grid_origin_y_m, c.grid_resolution_m, c.grid, c.wall_height_m,
                           c.wall_colour);
    if (c.has_boundary)
      world->add_boundary(c.boundary[0], c.boundary[1], c.boundary[2], c.boundary[3], c.wall_height_m, c.wall_colour);
  }
  if (c.clear_boxes) world->clear_boxes();
  // Removed ids and the ids of added boxes go in one pass; of boxes added with one id, the last.
  std::set<std::string> ids(c.remove_ids.begin(), c.remove_ids.end());
  std::map<std::string, size_t> last;
  for (size_t k = 0; k < c.add_boxes.size(); ++k)
    if (!c.add_boxes[k].id.empty()) last[c.add_boxes[k].id] = k;
  for (const auto& [id, k] : last) ids.insert(id);
  if (!ids.empty()) world->remove_boxes_if([&](const Box& b) { return b.kind == BoxKind::kBox && ids.count(b.id); });
  for (size_t k = 0; k < c.add_boxes.size(); ++k) {
    const Box& b = c.add_boxes[k];
    if (b.id.empty() || last[b.id] == k) world->add(b, false);
  }
}

}  // namespace cart2d
