#include "world.hpp"

#include <algorithm>  // std::min, std::max, std::remove_if, std::find
#include <cmath>      // std::cos, std::sin, std::fabs, std::hypot

namespace cart2d {

namespace {

constexpr double kSamePlaceM = 1e-6;  // two centres this close are the same place

bool same_place(double ax, double ay, double bx, double by) {
  return std::fabs(ax - bx) <= kSamePlaceM && std::fabs(ay - by) <= kSamePlaceM;
}

// The farthest any feature of the footprint lies from the axle centre.
double feature_reach_m(const RobotGeometry& g) {
  return std::max(g.footprint_radius_m, std::hypot(g.bumper_x_m, g.switch_y_m));
}

}  // namespace

World::World(const ArenaParams& arena) { set_square_arena(arena); }

void World::set_square_arena(const ArenaParams& arena) {
  arena_ = arena;
  clear_physical();
  add_boundary(arena.x_min(), arena.y_min(), arena.x_max(), arena.y_max());
}

void World::clear_physical() {
  boxes_.clear();
  deferred_.clear();
  changed();
}

void World::add_boundary(double x0_m, double y0_m, double x1_m, double y1_m, double height_m, uint32_t colour_rgb) {
  const double t = kWallThicknessM;
  const double cx = (x0_m + x1_m) / 2, cy = (y0_m + y1_m) / 2;
  const double hx = (x1_m - x0_m) / 2 + t, hy = (y1_m - y0_m) / 2 + t;  // overlapping at the corners
  auto wall = [&](double x, double y, double half_x, double half_y) {
    Box b;
    b.cx_m = x;
    b.cy_m = y;
    b.hx_m = half_x;
    b.hy_m = half_y;
    b.height_m = height_m;
    b.colour_rgb = colour_rgb;
    b.kind = BoxKind::kWall;
    add(b);
  };
  wall(x0_m - t / 2, cy, t / 2, hy);  // west
  wall(x1_m + t / 2, cy, t / 2, hy);  // east
  wall(cx, y0_m - t / 2, hx, t / 2);  // south
  wall(cx, y1_m + t / 2, hx, t / 2);  // north
}

void World::add_wall_grid(double origin_x_m, double origin_y_m, double resolution_m, const OccupancyGrid& grid,
                          double height_m, uint32_t colour_rgb) {
  for (const CellRect& r : merge_cells(grid)) {
    Box b;
    b.hx_m = r.w * resolution_m / 2;
    b.hy_m = r.h * resolution_m / 2;
    b.cx_m = origin_x_m + r.i * resolution_m + b.hx_m;
    b.cy_m = origin_y_m + r.j * resolution_m + b.hy_m;
    b.height_m = height_m;
    b.colour_rgb = colour_rgb;
    b.kind = BoxKind::kWall;
    add(b);
  }
}

size_t World::add(Box b, bool replace_id) {
  if (replace_id && !b.id.empty()) remove_id(b.id);
  b.serial = next_serial_++;
  if (!b.solid) deferred_.push_back(static_cast<uint32_t>(boxes_.size()));
  boxes_.push_back(std::move(b));
  changed();
  return boxes_.size() - 1;
}

void World::rebuild_deferred() {
  deferred_.clear();
  for (size_t k = 0; k < boxes_.size(); ++k)
    if (!boxes_[k].solid) deferred_.push_back(static_cast<uint32_t>(k));
}

size_t World::remove_id(const std::string& id) {
  if (id.empty()) return 0;
  return remove_boxes_if([&](const Box& b) { return b.id == id; });
}

void World::clear_boxes() {
  remove_boxes_if([](const Box& b) { return b.kind == BoxKind::kBox; });
}

size_t World::count(BoxKind kind) const {
  if (counted_version_ != version_) {  // asked for by every truth message: counted once per change
    walls_ = 0;
    for (const Box& b : boxes_) walls_ += b.kind == BoxKind::kWall;
    counted_version_ = version_;
  }
  return kind == BoxKind::kWall ? walls_ : boxes_.size() - walls_;
}

void World::rebuild_boxes() const {
  std::vector<Aabb> items;
  items.reserve(boxes_.size());
  for (const Box& b : boxes_) items.push_back({b.cx_m - b.hx_m, b.cy_m - b.hy_m, b.cx_m + b.hx_m, b.cy_m + b.hy_m});
  box_grid_.build(items);
  boxes_dirty_ = false;
}

void World::probes(const Pose& pose, const RobotGeometry& geom, std::vector<ContactProbe>* out, double margin_m) const {
  out->clear();
  if (boxes_dirty_) rebuild_boxes();
  const double reach = feature_reach_m(geom) + margin_m;
  candidates_.clear();
  box_grid_.query({pose.x_m - reach, pose.y_m - reach, pose.x_m + reach, pose.y_m + reach}, &candidates_);
  last_candidates_ = candidates_.size();
  for (uint32_t k : candidates_) {
    const Box& b = boxes_[k];
    if (!b.solid || box_beyond(b, pose.x_m, pose.y_m, reach)) continue;
    probe_box(k, pose, geom, margin_m, out);
  }
}

void World::probe_box(uint32_t index, const Pose& pose, const RobotGeometry& geom, double margin_m,
                      std::vector<ContactProbe>* out) const {
  const Box& b = boxes_[index];
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  // Disc: its nearest point moves with v only (a turn spins the disc about its own centre).
  const BoxDistance disc = box_distance(b, pose.x_m, pose.y_m);
  const double disc_gap = disc.dist_m - geom.footprint_radius_m;
  if (disc_gap <= margin_m) out->push_back({ContactProbe::kDisc, index, disc_gap, disc.nx * c + disc.ny * s, 0.0, 0.0});
  for (int side = 0; side < 2; ++side) {
    const double by = side == 0 ? geom.switch_y_m : -geom.switch_y_m;
    // Lever arm r = R(θ)·(bumper_x, by); point velocity = v·heading + ω·(−r_y, r_x).
    const double rx = c * geom.bumper_x_m - s * by, ry = s * geom.bumper_x_m + c * by;
    const BoxDistance d = box_distance(b, pose.x_m + rx, pose.y_m + ry);
    if (d.dist_m > margin_m) continue;
    out->push_back({side == 0 ? ContactProbe::kSwitchLeft : ContactProbe::kSwitchRight, index, d.dist_m,
                    d.nx * c + d.ny * s, -d.nx * ry + d.ny * rx, 0.0});
  }
  // The bumper between the switches against the rectangle's corners ahead of the axle (the switch
  // points cover its ends; a flat face meets the bumper at the switch points first).
  for (int corner = 0; corner < 4; ++corner) {
    const double qx = b.cx_m + (corner & 1 ? b.hx_m : -b.hx_m) - pose.x_m;
    const double qy = b.cy_m + (corner & 2 ? b.hy_m : -b.hy_m) - pose.y_m;
    const double xb = c * qx + s * qy, yb = -s * qx + c * qy;
    const double gap = xb - geom.bumper_x_m;
    if (std::fabs(yb) >= geom.switch_y_m || xb <= 0.0 || gap > margin_m) continue;
    out->push_back({ContactProbe::kBumper, index, gap, -1.0, yb, yb});
  }
}

double World::footprint_gap_m(const Pose& pose, const RobotGeometry& geom, const Box& b) const {
  // The same features as probe_box, with no margin: the smallest gap of any.
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  double gap = box_distance(b, pose.x_m, pose.y_m).dist_m - geom.footprint_radius_m;
  for (double by : {geom.switch_y_m, -geom.switch_y_m}) {
    const double rx = c * geom.bumper_x_m - s * by, ry = s * geom.bumper_x_m + c * by;
    gap = std::min(gap, box_distance(b, pose.x_m + rx, pose.y_m + ry).dist_m);
  }
  for (int corner = 0; corner < 4; ++corner) {
    const double qx = b.cx_m + (corner & 1 ? b.hx_m : -b.hx_m) - pose.x_m;
    const double qy = b.cy_m + (corner & 2 ? b.hy_m : -b.hy_m) - pose.y_m;
    const double xb = c * qx + s * qy, yb = -s * qx + c * qy;
    if (std::fabs(yb) < geom.switch_y_m && xb > 0.0) gap = std::min(gap, xb - geom.bumper_x_m);
  }
  return gap;
}

long World::overlapping(const Pose& pose, const RobotGeometry& geom) const {
  if (boxes_dirty_) rebuild_boxes();
  const double reach = feature_reach_m(geom) + kProbeMarginM;
  std::vector<uint32_t> near;
  box_grid_.query({pose.x_m - reach, pose.y_m - reach, pose.x_m + reach, pose.y_m + reach}, &near);
  std::sort(near.begin(), near.end());  // the first in the list, whatever the grid's order
  for (uint32_t k : near)
    if (!box_beyond(boxes_[k], pose.x_m, pose.y_m, reach) &&
        footprint_gap_m(pose, geom, boxes_[k]) < -kOverlapToleranceM)
      return static_cast<long>(k);
  return -1;
}

size_t World::defer_overlapping(const Pose& pose, const RobotGeometry& geom) {
  size_t n = 0;
  if (boxes_dirty_) rebuild_boxes();
  const double reach = feature_reach_m(geom) + kProbeMarginM;
  std::vector<uint32_t> near;
  box_grid_.query({pose.x_m - reach, pose.y_m - reach, pose.x_m + reach, pose.y_m + reach}, &near);
  for (uint32_t k : near) {
    Box& b = boxes_[k];
    if (!b.solid || box_beyond(b, pose.x_m, pose.y_m, reach)) continue;
    if (footprint_gap_m(pose, geom, b) >= -kOverlapToleranceM) continue;
    b.solid = false;
    deferred_.push_back(k);
    ++n;
  }
  if (n) ++version_;  // the same rectangles, but the probes change
  return n;
}

void World::settle(const Pose& pose, const RobotGeometry& geom) {
  size_t kept = 0;
  for (uint32_t k : deferred_) {
    Box& b = boxes_[k];
    if (footprint_gap_m(pose, geom, b) > kSettleGapM) {
      b.solid = true;
      ++version_;
    } else {
      deferred_[kept++] = k;
    }
  }
  deferred_.resize(kept);
}

// -- virtual obstacles --------------------------------------------------------------------------

void World::set_obstacles(std::vector<Obstacle> obstacles) {
  obstacles_ = std::move(obstacles);
  obstacles_dirty_ = true;
}

bool World::disc_overlaps(const Obstacle& o, double x_m, double y_m, double r_m) const {
  const double dx = std::max(std::fabs(x_m - o.cx_m) - o.half_m, 0.0);
  const double dy = std::max(std::fabs(y_m - o.cy_m) - o.half_m, 0.0);
  return dx * dx + dy * dy < (r_m + 1e-9) * (r_m + 1e-9);
}

void World::rebuild_obstacles() const {
  std::vector<Aabb> items;
  items.reserve(obstacles_.size());
  for (const Obstacle& o : obstacles_) items.push_back({o.cx_m - o.half_m, o.cy_m - o.half_m, o.cx_m + o.half_m, o.cy_m + o.half_m});
  obstacle_grid_.build(items);
  obstacles_dirty_ = false;
}

void World::obstacles_near(double x_m, double y_m, double r_m, std::vector<uint32_t>* out) const {
  if (obstacles_dirty_) rebuild_obstacles();
  obstacle_grid_.query({x_m - r_m, y_m - r_m, x_m + r_m, y_m + r_m}, out);
}

// -- contact statistics -------------------------------------------------------------------------

void ContactMonitor::update(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
                            const std::vector<ContactProbe>& probes) {
  update_boxes(t_s, world, pose, geom, probes);
  update_obstacles(t_s, world, pose, geom.footprint_radius_m);
}

// An obstacle is touched when the footprint overlaps it or, if it is physical, touches its box
// (which the footprint cannot overlap).
void ContactMonitor::update_obstacles(double t_s, const World& world, const Pose& pose, double radius_m) {
  scratch_.clear();
  world.obstacles_near(pose.x_m, pose.y_m, radius_m + kReleaseM, &scratch_);
  std::sort(scratch_.begin(), scratch_.end());  // events in the obstacles' order
  std::vector<Centre> now;
  for (uint32_t k : scratch_) {
    const Obstacle& o = world.obstacles()[k];
    const bool twin_touched = std::any_of(touching_twins_.begin(), touching_twins_.end(),
                                          [&](const Centre& c) { return same_place(c.x_m, c.y_m, o.cx_m, o.cy_m); });
    if (!twin_touched && !world.disc_overlaps(o, pose.x_m, pose.y_m, radius_m)) continue;
    now.push_back({o.cx_m, o.cy_m});
    const bool was = std::any_of(touching_obstacles_.begin(), touching_obstacles_.end(),
                                 [&](const Centre& c) { return same_place(c.x_m, c.y_m, o.cx_m, o.cy_m); });
    if (was) continue;
    ++collisions_;
    if (first_collision_t_ < 0) first_collision_t_ = t_s;
    events_.push_back({"collision", t_s, o.cx_m, o.cy_m, ""});
  }
  touching_obstacles_.swap(now);
}

void ContactMonitor::update_boxes(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
                                  const std::vector<ContactProbe>& probes) {
  const std::vector<Box>& boxes = world.boxes();
  // The smallest gap per rectangle near the cart; a deferred one overlaps the cart.
  std::vector<std::pair<uint32_t, double>> gaps;
  for (const ContactProbe& p : probes) {
    auto it = std::find_if(gaps.begin(), gaps.end(), [&](const auto& g) { return g.first == p.box; });
    if (it == gaps.end()) gaps.push_back({p.box, p.gap_m});
    else it->second = std::min(it->second, p.gap_m);
  }
  for (uint32_t k : world.deferred()) gaps.push_back({k, world.footprint_gap_m(pose, geom, boxes[k])});

  double wall_gap = 1e9;
  std::vector<uint64_t> touching;
  touching_twins_.clear();
  for (const auto& [k, gap] : gaps) {
    const Box& b = boxes[k];
    if (b.kind == BoxKind::kWall) {
      wall_gap = std::min(wall_gap, gap);
      continue;
    }
    const bool was = std::find(touching_boxes_.begin(), touching_boxes_.end(), b.serial) != touching_boxes_.end();
    if (gap <= kTouchM || (was && gap <= kReleaseM)) {
      if (std::find(touching.begin(), touching.end(), b.serial) != touching.end()) continue;
      touching.push_back(b.serial);
      if (b.obstacle_twin) touching_twins_.push_back({b.cx_m, b.cy_m});
      if (was) continue;
      ++box_contacts_;
      if (first_box_contact_t_ < 0) first_box_contact_t_ = t_s;
      events_.push_back({"box_contact", t_s, b.cx_m, b.cy_m, b.id});
    }
  }
  touching_boxes_.swap(touching);

  if (!in_wall_contact_ && wall_gap <= kTouchM) {
    in_wall_contact_ = true;
    ++wall_contacts_;
    if (first_wall_contact_t_ < 0) first_wall_contact_t_ = t_s;
    events_.push_back({"wall_contact", t_s, pose.x_m, pose.y_m, ""});
  } else if (in_wall_contact_ && wall_gap > kReleaseM) {
    in_wall_contact_ = false;
  }
}

void ContactMonitor::reset() { *this = ContactMonitor(); }

std::vector<ContactMonitor::Event> ContactMonitor::take_events() {
  std::vector<Event> out;
  out.swap(events_);
  return out;
}

}  // namespace cart2d
