// The side channel's world messages: `world` (replace the physical world), `boxes` (add, remove),
// `obstacles` (the virtual ones, optionally physical too), each now or at a simulated time; and
// `world_get`. Timed changes apply at the first slice boundary at or after their cycle, so a run
// is the same at any speed.
#include <algorithm>  // std::upper_bound
#include <cmath>      // std::llround

#include "log.hpp"
#include "simulator.hpp"

namespace cart2d {

std::string Simulator::cmd_world_change(const std::string& type, const json::Value& msg, std::string* extra) {
  WorldChange change;
  if (std::string error = parse_world_change(type, msg, rig_.world().arena(), &change); !error.empty()) return error;
  if (change.at_s >= 0.0) {
    const uint64_t cycle = static_cast<uint64_t>(std::llround(change.at_s * rig_.mcu().frequency_hz()));
    if (cycle > rig_.cycle()) {
      auto later = std::upper_bound(scheduled_.begin(), scheduled_.end(), cycle,
                                    [](uint64_t c, const ScheduledChange& s) { return c < s.cycle; });
      scheduled_.insert(later, ScheduledChange{cycle, type, std::move(change)});
      *extra = "\"scheduled\":true,\"at\":" + json::number(msg.find("at")->number);
      return "";
    }
  }
  apply_change(type, change);
  *extra = world_counts_json();
  if (type == "obstacles") *extra += ",\"count\":" + std::to_string(rig_.world().obstacles().size());
  return "";
}

void Simulator::apply_change(const std::string& type, const WorldChange& change) {
  apply_world_change(change, &rig_.world());
  rig_.world_changed();
  LOG_DEBUG("world changed (%s) at t = %.6f s", type.c_str(), rig_.time_s());
  control_.broadcast("{\"type\":\"event\",\"event\":\"world_changed\",\"t\":" + json::number(rig_.time_s()) +
                     ",\"what\":" + json::quote(type) + "," + world_counts_json() + "}");
}

void Simulator::apply_due_changes() {
  size_t due = 0;
  while (due < scheduled_.size() && scheduled_[due].cycle <= rig_.cycle()) ++due;
  if (due == 0) return;
  std::vector<ScheduledChange> now(std::make_move_iterator(scheduled_.begin()),
                                   std::make_move_iterator(scheduled_.begin() + static_cast<long>(due)));
  scheduled_.erase(scheduled_.begin(), scheduled_.begin() + static_cast<long>(due));
  for (const ScheduledChange& s : now) apply_change(s.type, s.change);
}

std::string Simulator::footprint_overlap(const Pose& pose) const {
  const World& w = rig_.world();
  const long k = w.overlapping(pose, rig_.cart().params().geometry);
  if (k < 0) return "";
  const Box& b = w.boxes()[static_cast<size_t>(k)];
  const std::string where = "centred at (" + json::number(b.cx_m) + ", " + json::number(b.cy_m) + "), " +
                            json::number(2 * b.hx_m) + " x " + json::number(2 * b.hy_m) + " m";
  if (b.kind == BoxKind::kWall) return "a wall " + where;
  return (b.id.empty() ? std::string("a box ") : "box " + json::quote(b.id) + " ") + where;
}

uint64_t Simulator::next_change_cycle() const { return scheduled_.empty() ? UINT64_MAX : scheduled_.front().cycle; }

// "version":V,"walls":W,"boxes":B,"obstacles":O (members to splice into an object).
std::string Simulator::world_counts_json() const {
  const World& w = rig_.world();
  return "\"version\":" + std::to_string(w.version()) + ",\"walls\":" + std::to_string(w.count(BoxKind::kWall)) +
         ",\"boxes\":" + std::to_string(w.count(BoxKind::kBox)) + ",\"obstacles\":" + std::to_string(w.obstacles().size());
}

std::string Simulator::world_json() const {
  const World& w = rig_.world();
  std::string walls = "[", boxes = "[", obstacles = "[";
  for (const Box& b : w.boxes()) {
    json::Object o;
    if (b.kind == BoxKind::kBox) o.add("id", b.id);
    o.add("x", b.cx_m).add("y", b.cy_m).add("sx", 2 * b.hx_m).add("sy", 2 * b.hy_m).add("height", b.height_m);
    o.add("colour", colour_text(b.colour_rgb));
    if (b.wall_paint) o.add("material", "wall");
    if (b.kind == BoxKind::kBox) o.add("obstacle", b.obstacle_twin);
    o.add("solid", b.solid);
    std::string& list = b.kind == BoxKind::kWall ? walls : boxes;
    if (list.size() > 1) list += ",";
    list += o.str();
  }
  for (const Obstacle& o : w.obstacles()) {
    if (obstacles.size() > 1) obstacles += ",";
    obstacles += "[" + json::number(o.cx_m) + "," + json::number(o.cy_m) + "," + json::number(2 * o.half_m) + "]";
  }
  std::string scheduled = "[";
  for (const ScheduledChange& s : scheduled_) {
    if (scheduled.size() > 1) scheduled += ",";
    scheduled += json::Object()
                     .add("at", static_cast<double>(s.cycle) / rig_.mcu().frequency_hz())
                     .add("what", s.type)
                     .str();
  }
  return json::Object()
      .add("version", static_cast<unsigned long long>(w.version()))
      .add_raw("walls", walls + "]")
      .add_raw("boxes", boxes + "]")
      .add_raw("obstacles", obstacles + "]")
      .add_raw("scheduled", scheduled + "]")
      .str();
}

}  // namespace cart2d
