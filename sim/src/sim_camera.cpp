#include "sim_camera.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "camera_effects.hpp"
#include "log.hpp"
#include "robot_params.hpp"  // params::camera, params::sim::camera

namespace cart2d {

namespace {

constexpr double kPi = 3.14159265358979323846;

double elapsed_ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// A finite number member within [lo, hi] into *out if present; false (and *error) if it is bad.
bool read_number(const json::Value& msg, const char* key, double lo, double hi, double* out, std::string* error) {
  const json::Value* v = msg.find(key);
  if (!v) return true;
  if (!v->is_number() || !std::isfinite(v->number) || v->number < lo || v->number > hi) {
    *error = std::string(key) + " must be a number in [" + json::number(lo) + ", " + json::number(hi) + "]";
    return false;
  }
  *out = v->number;
  return true;
}

bool read_int(const json::Value& msg, const char* key, int lo, int hi, int* out, std::string* error) {
  double v = *out;
  if (!read_number(msg, key, lo, hi, &v, error)) return false;
  if (v != std::floor(v)) {
    *error = std::string(key) + " must be a whole number";
    return false;
  }
  *out = static_cast<int>(v);
  return true;
}

}  // namespace

CameraSettings CameraSettings::from_params() {
  CameraSettings s;
  s.width_px = static_cast<int>(params::camera::width_px);
  s.height_px = static_cast<int>(params::camera::height_px);
  s.fps = params::sim::camera::fps;
  s.latency_ms = params::sim::camera::latency_ms;
  s.noise_sigma = params::sim::camera::noise_sigma;
  s.exposure = params::sim::camera::exposure;
  s.k1 = params::sim::camera::k1;
  s.k2 = params::sim::camera::k2;
  s.jpeg_quality = static_cast<int>(params::sim::camera::jpeg_quality);
  return s;
}

std::string CameraSettings::json() const {
  return json::Object()
      .add("width", width_px)
      .add("height", height_px)
      .add("fps", fps)
      .add("latency_ms", latency_ms)
      .add("noise_sigma", noise_sigma)
      .add("exposure", exposure)
      .add("k1", k1)
      .add("k2", k2)
      .add("jpeg_quality", jpeg_quality)
      .str();
}

SimCamera::SimCamera(double cpu_hz, uint64_t seed, const CameraSettings& settings)
    : cpu_hz_(cpu_hz), seed_(seed), settings_(settings), clock_(settings.fps, settings.latency_ms / 1000.0, cpu_hz) {
  rebuild();
}

void SimCamera::rebuild() {
  CameraIntrinsics intr = CameraIntrinsics::nominal(settings_.width_px, settings_.height_px,
                                                    params::camera::hfov_deg * kPi / 180.0, settings_.k1, settings_.k2);
  model_ = std::make_unique<CameraModel>(CameraMount::from_params(), intr);
  renderer_ = std::make_unique<CameraRenderer>(*model_);
  renderer_->set_markers(&markers_);
  clock_ = CameraClock(settings_.fps, settings_.latency_ms / 1000.0, cpu_hz_);
}

std::string SimCamera::configure(const json::Value& msg, uint64_t now_cycle) {
  CameraSettings next = settings_;
  std::string error;
  // The OV2640 gives up to UXGA (1600 × 1200); fps and latency within what a camera link can do.
  if (!read_int(msg, "width", 16, 1600, &next.width_px, &error) ||
      !read_int(msg, "height", 16, 1200, &next.height_px, &error) ||
      !read_number(msg, "fps", 0.1, 120.0, &next.fps, &error) ||
      !read_number(msg, "latency_ms", 0.0, 10000.0, &next.latency_ms, &error) ||
      !read_number(msg, "noise_sigma", 0.0, 100.0, &next.noise_sigma, &error) ||
      !read_number(msg, "exposure", 0.0, 10.0, &next.exposure, &error) ||
      !read_number(msg, "k1", -1.0, 1.0, &next.k1, &error) || !read_number(msg, "k2", -1.0, 1.0, &next.k2, &error) ||
      !read_int(msg, "jpeg_quality", 1, 100, &next.jpeg_quality, &error))
    return error;
  const bool geometry = next.width_px != settings_.width_px || next.height_px != settings_.height_px ||
                        next.k1 != settings_.k1 || next.k2 != settings_.k2;
  const bool timing = next.fps != settings_.fps || next.latency_ms != settings_.latency_ms;
  settings_ = next;
  if (geometry) rebuild();
  if (geometry || timing) {
    clock_ = CameraClock(settings_.fps, settings_.latency_ms / 1000.0, cpu_hz_);
    in_flight_.clear();
    next_k_ = clock_.first_frame_from(now_cycle);
  }
  return "";
}

std::string SimCamera::set_target(const json::Value& board) {
  if (board.is_null()) {
    board_.reset();
    return "";
  }
  if (!board.is_object()) return "board must be an object or null";
  Checkerboard b;
  std::string error;
  if (!read_int(board, "cols", 2, 100, &b.cols, &error) || !read_int(board, "rows", 2, 100, &b.rows, &error) ||
      !read_number(board, "square_m", 0.001, 1.0, &b.square_m, &error) ||
      !read_number(board, "x", -1e4, 1e4, &b.x_m, &error) || !read_number(board, "y", -1e4, 1e4, &b.y_m, &error) ||
      !read_number(board, "z", -100.0, 100.0, &b.z_m, &error) ||
      !read_number(board, "roll", -10.0, 10.0, &b.roll_rad, &error) ||
      !read_number(board, "pitch", -10.0, 10.0, &b.pitch_rad, &error) ||
      !read_number(board, "yaw", -10.0, 10.0, &b.yaw_rad, &error))
    return error;
  if (!board.find("x") || !board.find("y")) return "board needs x and y (m)";
  board_ = b;
  return "";
}

void SimCamera::set_on(bool on, uint64_t now_cycle) {
  if (on && !on_) next_k_ = clock_.first_frame_from(now_cycle);
  if (!on) in_flight_.clear();
  on_ = on;
}

void SimCamera::remove_item(const SceneItem* item) {
  items_.erase(std::remove(items_.begin(), items_.end(), item), items_.end());
}

bool SimCamera::capture(uint64_t k, const World& world, const Pose& pose, CameraFrame* frame, std::string* error,
                        const Twist& twist) {
  auto t0 = std::chrono::steady_clock::now();
  FrameScene scene;
  scene.world = &world;
  scene.pose = pose;
  scene.twist = twist;
  scene.board = board();
  scene.items = items_;
  const CameraLook& look = world.look().camera;
  if (!look.auto_exposure) ae_gain_ = 1.0;
  renderer_->render(scene, settings_.exposure * ae_gain_, settings_.noise_sigma, seed_, k, &rgb_);
  // The auto-exposure meters this frame for the next: it lags a change of view by a few frames.
  if (look.auto_exposure) ae_gain_ = next_auto_exposure(look, ae_gain_, mean_level(rgb_));
  last_render_ms_ = elapsed_ms(t0);
  t0 = std::chrono::steady_clock::now();
  frame->seq = k;
  frame->t_s = clock_.capture_s(k);
  frame->available_cycle = clock_.available_cycle(k);
  if (!encoder_.encode(rgb_, settings_.width_px, settings_.height_px, settings_.jpeg_quality, &frame->jpeg, error))
    return false;
  last_encode_ms_ = elapsed_ms(t0);
  ++frames_;
  return true;
}

void SimCamera::step(uint64_t end_cycle, const World& world, const Pose& pose, std::vector<CameraFrame>* ready,
                     const Twist& twist) {
  if (!on_) return;
  // Frames whose capture time fell within this step: all see the pose at its end (a step is
  // 0.25 ms, far shorter than a frame period, so at most one is normally due).
  while (clock_.capture_cycle(next_k_) <= end_cycle) {
    CameraFrame frame;
    std::string error;
    if (capture(next_k_, world, pose, &frame, &error, twist)) in_flight_.push_back(std::move(frame));
    else LOG_WARN("camera frame %llu not encoded: %s", static_cast<unsigned long long>(next_k_), error.c_str());
    ++next_k_;
  }
  while (!in_flight_.empty() && in_flight_.front().available_cycle <= end_cycle) {
    ready->push_back(std::move(in_flight_.front()));
    in_flight_.pop_front();
  }
}

}  // namespace cart2d
