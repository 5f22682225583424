#include "world.hpp"

#include <algorithm>  // std::min, std::max
#include <cmath>      // std::cos, std::sin, std::fabs

namespace cart2d {

World::World(const ArenaParams& arena) : arena_(arena) {}

void World::set_margin(double margin_m) { arena_.margin_m = margin_m; }

void World::set_grid(int nodes, double step_m) {
  arena_.grid_nodes = nodes;
  arena_.grid_step_m = step_m;
}

void World::probes(const Pose& pose, const RobotGeometry& geom, std::vector<WallProbe>* out) const {
  out->clear();
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  // Inward wall normals and offsets: gap = n·p − d.
  const double nx[4] = {1.0, -1.0, 0.0, 0.0};
  const double ny[4] = {0.0, 0.0, 1.0, -1.0};
  const double d[4] = {x_min(), -x_max(), y_min(), -y_max()};
  for (int w = 0; w < 4; ++w) {
    const double n_dot_heading = nx[w] * c + ny[w] * s;
    const double n_dot_centre = nx[w] * pose.x_m + ny[w] * pose.y_m;
    // Disc: its nearest point moves with v only (rotation slides it along the wall).
    out->push_back({WallProbe::kDisc, w, n_dot_centre - d[w] - geom.footprint_radius_m, n_dot_heading, 0.0});
    for (int side = 0; side < 2; ++side) {
      const double by = side == 0 ? geom.switch_y_m : -geom.switch_y_m;
      // Lever arm r = R(θ)·(bumper_x, by); point velocity = v·heading + ω·(−r_y, r_x).
      const double rx = c * geom.bumper_x_m - s * by, ry = s * geom.bumper_x_m + c * by;
      const double gap = n_dot_centre + nx[w] * rx + ny[w] * ry - d[w];
      const double jw = nx[w] * -ry + ny[w] * rx;
      out->push_back({side == 0 ? WallProbe::kSwitchLeft : WallProbe::kSwitchRight, w, gap, n_dot_heading, jw});
    }
  }
}

double World::switch_gap_m(const Pose& pose, const RobotGeometry& geom, bool left) const {
  std::vector<WallProbe> all;
  probes(pose, geom, &all);
  double gap = 1e9;
  for (const auto& p : all)
    if (p.feature == (left ? WallProbe::kSwitchLeft : WallProbe::kSwitchRight)) gap = std::min(gap, p.gap_m);
  return gap;
}

bool World::disc_overlaps(const Obstacle& o, double x_m, double y_m, double r_m) const {
  const double dx = std::max(std::fabs(x_m - o.cx_m) - o.half_m, 0.0);
  const double dy = std::max(std::fabs(y_m - o.cy_m) - o.half_m, 0.0);
  return dx * dx + dy * dy < (r_m + 1e-9) * (r_m + 1e-9);
}

void ContactMonitor::update(double t_s, const World& world, const Pose& pose, const RobotGeometry& geom,
                            const std::vector<WallProbe>& probes) {
  const auto& obstacles = world.obstacles();
  if (touching_.size() != obstacles.size()) touching_.assign(obstacles.size(), 0);
  in_collision_ = false;
  for (size_t k = 0; k < obstacles.size(); ++k) {
    const bool now = world.disc_overlaps(obstacles[k], pose.x_m, pose.y_m, geom.footprint_radius_m);
    if (now && !touching_[k]) {
      ++collisions_;
      if (first_collision_t_ < 0) first_collision_t_ = t_s;
      events_.push_back({"collision", t_s, obstacles[k].cx_m, obstacles[k].cy_m});
    }
    touching_[k] = now;
    in_collision_ = in_collision_ || now;
  }
  double gap = 1e9;
  for (const auto& p : probes) gap = std::min(gap, p.gap_m);
  if (!in_wall_contact_ && gap <= kTouchM) {
    in_wall_contact_ = true;
    ++wall_contacts_;
    if (first_wall_contact_t_ < 0) first_wall_contact_t_ = t_s;
    events_.push_back({"wall_contact", t_s, pose.x_m, pose.y_m});
  } else if (in_wall_contact_ && gap > kReleaseM) {
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
