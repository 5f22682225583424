// What the mounted camera sees: one ray per pixel (CameraModel's table, so the lens distortion is
// exact), cast from the TRUE pose against the floor, the world's rectangles standing on it (walls
// and boxes, each with its height and colour), a checkerboard target and the frame's extra items;
// coloured as the world's look says (look.hpp: materials, lights and shadows, a glossy floor's
// reflections); then the camera's effects (camera_effects.hpp: motion blur, vignetting, exposure,
// noise). Nothing here depends on the wall clock: a seed and a frame number give the same picture.
#pragma once

#include <cstdint>
#include <vector>

#include "body.hpp"  // Pose, Twist
#include "camera_model.hpp"
#include "marker_render.hpp"
#include "world.hpp"

namespace cart2d {

// A printed checkerboard of cols × rows INNER corners and square side square_m, with a white margin
// one square wide around its (cols + 1) × (rows + 1) squares. Its pose is that of its first inner
// corner: (x, y, z) in the world, and the rotation R = Rz(yaw)·Ry(pitch)·Rx(roll) (ROS's fixed-axis
// roll-pitch-yaw) taking the board's axes to the world's: inner corner (i, j) lies at
// (x, y, z) + R·(i·square, j·square, 0). All angles zero: the board lies face up on a plane at
// height z, its columns along world x and its rows along world y. The square whose corner is
// (−square, −square) on the board, next to the first inner corner, is black.
struct Checkerboard {
  int cols = 9, rows = 6;
  double square_m = 0.03;
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
  // Inner corner (i, j) (i along the columns, 0 <= i < cols) in the world.
  Vec3 corner(double i, double j) const;
  // The board's x and y axes and its normal in the world.
  void axes(Vec3* ex, Vec3* ey, Vec3* n) const;
};

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

// Something more the camera draws in a frame (an AprilTag on a wall, another cart...): each frame's
// rays are offered to every item after the world; the nearest hit wins. Items draw in their own
// colours (unlit). Surface ids mark edges for anti-aliasing: two pixels whose ids differ are
// sampled four times; an item's ids should be kSurfaceItems or above, distinct per face or square.
class SceneItem {
 public:
  static constexpr uint32_t kSurfaceItems = 1u << 31;
  virtual ~SceneItem() = default;
  // The ray o + t·d (world frame, d a unit vector) against the item: true, *t (0 < t < t_max),
  // *colour and *surface if it meets the item nearer than t_max.
  virtual bool hit(const Vec3& o, const Vec3& d, double t_max, double* t, Rgb* colour, uint32_t* surface) const = 0;
};

// What one frame shows: the world (with its look), the true pose and its motion (motion blur), the
// checkerboard if one is set, and the extra items drawn this frame.
struct FrameScene {
  const World* world = nullptr;
  Pose pose;
  Twist twist;
  const Checkerboard* board = nullptr;
  std::vector<const SceneItem*> items;
};

class CameraRenderer {
 public:
  static constexpr uint32_t kFloorColour = 0xa8a8a8;      // light grey, with a faint texture
  static constexpr int kFloorTextureLevels = 6;           // ± this, on 2 cm floor tiles
  static constexpr double kFloorTileM = 0.02;
  static constexpr uint32_t kBackgroundColour = 0x4f5d6b;  // beyond an endless floor's horizon
  static constexpr uint32_t kBoardDark = 0x1e1e1e, kBoardLight = 0xebebeb;
  static constexpr double kMaxRangeM = 30.0;              // boxes farther than this are not drawn

  explicit CameraRenderer(const CameraModel& model) : model_(model) {}
  const CameraModel& model() const { return model_; }
  void set_markers(const std::vector<Marker>* markers) { markers_ = markers; }  // marker_render.hpp

  // The linear picture (before the camera's effects), RGB row-major; *depth (if given) the distance
  // along each pixel's ray to what it shows (kMaxRangeM for the background).
  void render_clean(const FrameScene& scene, std::vector<Rgb>* out, std::vector<float>* depth = nullptr) const;
  void render_clean(const World& world, const Pose& pose, const Checkerboard* board, std::vector<Rgb>* out) const;
  // The picture the sensor gives for frame `frame`: the clean picture through the look's camera
  // effects, brightness times gain (the exposure setting times the auto-exposure's), plus noise of
  // noise_sigma levels drawn from the seeded stream of that frame, clamped to 0..255; RGB bytes.
  void render(const FrameScene& scene, double gain, double noise_sigma, uint64_t seed, uint64_t frame,
              std::vector<uint8_t>* rgb) const;
  void render(const World& world, const Pose& pose, const Checkerboard* board, double exposure, double noise_sigma,
              uint64_t seed, uint64_t frame, std::vector<uint8_t>* rgb) const;

 private:
  const CameraModel& model_;
  const std::vector<Marker>* markers_ = nullptr;
};

}  // namespace cart2d
