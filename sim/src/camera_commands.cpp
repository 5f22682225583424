// The side channel's camera messages: `camera` (frames on or off for this client, settings),
// `target` (place or remove the checkerboard) and `look` (the world's look: materials, lights, the
// camera's effects); frames go out as {"type":"frame",...} lines once their latency has passed in
// simulated time (sim/README.md, "The camera").
#include "log.hpp"
#include "simulator.hpp"

namespace cart2d {

// {"type":"camera","on":bool, settings...}: the ack carries "camera" with the settings in force.
std::string Simulator::cmd_camera(int client, const json::Value& msg, std::string* extra) {
  const json::Value* on = msg.find("on");
  if (on && !on->is_bool()) return "on must be true or false";
  if (std::string error = camera_->configure(msg, rig_.cycle()); !error.empty()) return error;
  if (on) {
    if (ControlChannel::Client* c = control_.find(client)) c->camera = on->boolean;
  }
  bool any = false;
  for (const auto& c : control_.clients()) any = any || (c.camera && !c.dead);
  camera_->set_on(any, rig_.cycle());  // rendering costs: only while someone watches
  *extra = "\"camera\":" + camera_->settings().json() + ",\"on\":" + (any ? "true" : "false");
  return "";
}

std::string Simulator::cmd_target(const json::Value& msg) {
  const json::Value* board = msg.find("board");
  if (!board) return "target needs board (an object, or null to remove it)";
  return camera_->set_target(*board);
}

// {"type":"look","look":{...} or null}: how the world looks to the camera (look.hpp), all or nothing;
// null or {} is today's look. The physics does not change.
std::string Simulator::cmd_look(const json::Value& msg) {
  const json::Value* look = msg.find("look");
  if (!look) return "look needs \"look\": an object {floor, walls, lights, ...} or null";
  Look next;
  if (!look->is_null())
    if (std::string error = parse_look(*look, &next); !error.empty()) return error;
  rig_.world().set_look(next);
  return "";
}

void Simulator::camera_step(uint64_t end_cycle) {
  if (!camera_->on()) return;
  bool any = false;
  for (const auto& c : control_.clients()) any = any || (c.camera && !c.dead);
  if (!any) {  // the last watcher left
    camera_->set_on(false, end_cycle);
    return;
  }
  std::vector<CameraFrame> ready;
  camera_->step(end_cycle, rig_.world(), rig_.cart().pose(), &ready, rig_.cart().body().twist());
  for (const CameraFrame& f : ready) {
    const std::string line = json::Object()
                                 .add("type", "frame")
                                 .add("seq", static_cast<unsigned long long>(f.seq))
                                 .add("t", f.t_s)
                                 .add("jpeg", base64_encode(f.jpeg))
                                 .str();
    for (auto& c : control_.clients())
      if (c.camera && !c.dead) control_.send(c.id, line, true);  // droppable: a slow reader skips frames
  }
}

}  // namespace cart2d
