// The side channel's `markers` message: {"type":"markers","markers":[...]} puts the fiducial
// markers in the world the camera sees (marker_render.hpp; [] removes them). The gateway's
// cart2d/simulation/markers.py sends them, each with OpenCV's bitmap of its id.
#include "simulator.hpp"

namespace cart2d {

std::string SimCamera::set_markers(const json::Value& list) {
  std::vector<Marker> parsed;
  if (std::string error = parse_markers(list, &parsed); !error.empty()) return error;
  markers_ = std::move(parsed);  // the renderer holds a pointer to markers_, not its elements
  return "";
}

std::string Simulator::cmd_markers(const json::Value& msg) {
  const json::Value* list = msg.find("markers");
  if (!list) return "markers needs markers (an array, empty to remove them)";
  return camera_->set_markers(*list);
}

}  // namespace cart2d
