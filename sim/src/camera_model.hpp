// The mounted camera's geometry: where it sits on the cart, its pinhole intrinsics and its lens
// distortion (OpenCV's radial model), with the two directions the simulator needs: a world point
// to its pixel (tests, the checkerboard's expected corners) and a pixel to its ray (rendering).
//
// Frames (REP-103/105 and OpenCV): base_link x forward, y left, z up, origin on the floor under the
// wheel-axis centre; the camera frame x right, y down, z along the optical axis; pixel (u, v) u right,
// v down, origin the top-left pixel, pixel centres at integers (so the image centre is
// ((w - 1) / 2, (h - 1) / 2)).
//
// Distortion (OpenCV, "Camera Calibration and 3D Reconstruction", radial terms only): a point
// (x, y) on the z = 1 plane with r² = x² + y² is seen at (x, y)·(1 + k1 r² + k2 r⁴), then
// u = fx·x_d + cx, v = fy·y_d + cy.
#pragma once

#include <vector>

#include "body.hpp"  // Pose

namespace cart2d {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

// The camera on the cart: robot.toml [camera].
struct CameraMount {
  double x_m = 0.0;       // lens ahead of the wheel axis
  double y_m = 0.0;       // lens left of the centre line
  double height_m = 0.0;  // lens above the floor
  double pitch_rad = 0.0; // optical axis below horizontal
  static CameraMount from_params();
};

struct CameraIntrinsics {
  int width_px = 0, height_px = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double k1 = 0.0, k2 = 0.0;
  // Square pixels, the principal point at the image centre, fx from the horizontal field of view.
  static CameraIntrinsics nominal(int width_px, int height_px, double hfov_rad, double k1, double k2);
  // robot.toml: [camera] size and field of view, [sim.camera] distortion.
  static CameraIntrinsics from_params();
};

class CameraModel {
 public:
  CameraModel(const CameraMount& mount, const CameraIntrinsics& intrinsics);

  const CameraMount& mount() const { return mount_; }
  const CameraIntrinsics& intrinsics() const { return intr_; }

  // The lens centre in the world for the cart at this pose.
  Vec3 centre(const Pose& pose) const;
  // A world point in the camera frame (OpenCV axes).
  Vec3 to_camera(const Pose& pose, const Vec3& world) const;
  // Where a world point is seen (distorted pixel); false if it is behind the camera.
  bool project(const Pose& pose, const Vec3& world, double* u, double* v) const;
  // A point on the z = 1 plane through the lens model, to pixel coordinates.
  void distort(double x, double y, double* u, double* v) const;
  // The inverse: the undistorted z = 1 point seen at pixel (u, v) (Newton on the radius).
  void undistort(double u, double v, double* x, double* y) const;

  // The unit ray of every pixel in base_link axes (row-major, the same for every pose: only a
  // rotation about z remains per frame), made once.
  const std::vector<Vec3>& rays_base() const { return rays_base_; }
  // Four rays per pixel, at (u ± 1/4, v ± 1/4), for anti-aliasing edges: pixel i's are
  // [4i, 4i + 4) (top-left, top-right, bottom-left, bottom-right).
  const std::vector<Vec3>& subrays_base() const { return subrays_base_; }

 private:
  Vec3 camera_to_base(const Vec3& c) const;
  Vec3 ray_base(double u, double v) const;

  CameraMount mount_;
  CameraIntrinsics intr_;
  std::vector<Vec3> rays_base_;
  std::vector<Vec3> subrays_base_;
};

}  // namespace cart2d
