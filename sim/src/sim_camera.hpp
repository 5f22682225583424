// The simulated ESP32-CAM as the simulator runs it: settings ([sim.camera], overridable by the
// control channel's "camera" message), the checkerboard target, and frames rendered from the true
// pose at their capture cycle, JPEG-encoded, and held until their latency has passed.
// Nothing here reads the wall clock except the cost figures.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera_clock.hpp"
#include "camera_model.hpp"
#include "camera_render.hpp"
#include "jpeg_encoder.hpp"
#include "json.hpp"

namespace cart2d {

struct CameraSettings {
  int width_px = 0, height_px = 0;
  double fps = 0.0, latency_ms = 0.0, noise_sigma = 0.0, exposure = 1.0, k1 = 0.0, k2 = 0.0;
  int jpeg_quality = 80;
  static CameraSettings from_params();  // robot.toml [camera] and [sim.camera]
  std::string json() const;
};

struct CameraFrame {
  uint64_t seq = 0;  // k: captured at k / fps
  double t_s = 0.0;
  uint64_t available_cycle = 0;
  std::string jpeg;
};

class SimCamera {
 public:
  SimCamera(double cpu_hz, uint64_t seed, const CameraSettings& settings = CameraSettings::from_params());

  const CameraSettings& settings() const { return settings_; }
  const CameraModel& model() const { return *model_; }
  // Changes the members of msg that name a setting (fps, latency_ms, noise_sigma, exposure, k1, k2,
  // width, height, jpeg_quality); all or nothing: "" or why not. The first frame at or after
  // `now_cycle` is the next to be taken.
  std::string configure(const json::Value& msg, uint64_t now_cycle);
  // {"cols","rows","square_m","x","y","z","roll","pitch","yaw"} or null; "" or why not.
  std::string set_target(const json::Value& board);
  const Checkerboard* board() const { return board_ ? &*board_ : nullptr; }
  // The fiducial markers in view of the camera (marker_render.hpp: its message's "markers"); "" or why not.
  std::string set_markers(const json::Value& markers);
  size_t markers() const { return markers_.size(); }

  // Capturing from the first frame at or after `now_cycle` (turned on), or not (frames in flight dropped).
  void set_on(bool on, uint64_t now_cycle);
  bool on() const { return on_; }
  // Captures every frame due by end_cycle at this pose (moving with this twist: motion blur) and
  // moves those available by then to *ready.
  void step(uint64_t end_cycle, const World& world, const Pose& pose, std::vector<CameraFrame>* ready,
            const Twist& twist = {});
  // A frame at this pose now, without the schedule (tests, the benchmark).
  bool capture(uint64_t k, const World& world, const Pose& pose, CameraFrame* frame, std::string* error,
               const Twist& twist = {});

  // Things drawn in every frame beside the world (camera_render.hpp's SceneItem; not owned: each
  // must outlive its place here).
  void add_item(const SceneItem* item) { items_.push_back(item); }
  void remove_item(const SceneItem* item);
  // The auto-exposure's gain now (1 while the world's look has none); it moves a step per frame.
  double auto_exposure_gain() const { return ae_gain_; }

  // Wall-clock cost of the last frame (not part of what a frame shows).
  double last_render_ms() const { return last_render_ms_; }
  double last_encode_ms() const { return last_encode_ms_; }
  uint64_t frames() const { return frames_; }

 private:
  void rebuild();

  double cpu_hz_;
  uint64_t seed_;
  CameraSettings settings_;
  std::unique_ptr<CameraModel> model_;
  std::unique_ptr<CameraRenderer> renderer_;
  CameraClock clock_;
  JpegEncoder encoder_;
  std::optional<Checkerboard> board_;
  std::vector<Marker> markers_;
  bool on_ = false;
  uint64_t next_k_ = 0;
  std::deque<CameraFrame> in_flight_;
  std::vector<uint8_t> rgb_;
  std::vector<const SceneItem*> items_;
  double ae_gain_ = 1.0;
  double last_render_ms_ = 0.0, last_encode_ms_ = 0.0;
  uint64_t frames_ = 0;
};

}  // namespace cart2d
