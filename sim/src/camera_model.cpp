#include "camera_model.hpp"

#include <cmath>

#include "robot_params.hpp"  // params::camera, params::sim::camera

namespace cart2d {

namespace {
constexpr double kPi = 3.14159265358979323846;
double radians(double deg) { return deg * kPi / 180.0; }
}  // namespace

CameraMount CameraMount::from_params() {
  CameraMount m;
  m.x_m = params::camera::mount_x_m;
  m.y_m = params::camera::mount_y_m;
  m.height_m = params::camera::height_m;
  m.pitch_rad = radians(params::camera::pitch_deg);
  return m;
}

CameraIntrinsics CameraIntrinsics::nominal(int width_px, int height_px, double hfov_rad, double k1, double k2) {
  CameraIntrinsics c;
  c.width_px = width_px;
  c.height_px = height_px;
  c.fx = c.fy = (width_px / 2.0) / std::tan(hfov_rad / 2.0);
  c.cx = (width_px - 1) / 2.0;
  c.cy = (height_px - 1) / 2.0;
  c.k1 = k1;
  c.k2 = k2;
  return c;
}

CameraIntrinsics CameraIntrinsics::from_params() {
  return nominal(static_cast<int>(params::camera::width_px), static_cast<int>(params::camera::height_px),
                 radians(params::camera::hfov_deg), params::sim::camera::k1, params::sim::camera::k2);
}

CameraModel::CameraModel(const CameraMount& mount, const CameraIntrinsics& intrinsics) : mount_(mount), intr_(intrinsics) {
  const size_t pixels = static_cast<size_t>(intr_.width_px) * static_cast<size_t>(intr_.height_px);
  rays_base_.reserve(pixels);
  subrays_base_.reserve(4 * pixels);
  for (int v = 0; v < intr_.height_px; ++v) {
    for (int u = 0; u < intr_.width_px; ++u) {
      rays_base_.push_back(ray_base(u, v));
      for (double dv : {-0.25, 0.25})
        for (double du : {-0.25, 0.25}) subrays_base_.push_back(ray_base(u + du, v + dv));
    }
  }
}

Vec3 CameraModel::ray_base(double u, double v) const {
  double x = 0.0, y = 0.0;
  undistort(u, v, &x, &y);
  const double n = std::sqrt(x * x + y * y + 1.0);
  return camera_to_base({x / n, y / n, 1.0 / n});
}

// The camera's axes in base_link, pitched down by p about base_link y:
// z_c = (cos p, 0, −sin p), x_c = (0, −1, 0), y_c = z_c × x_c = (−sin p, 0, −cos p).
Vec3 CameraModel::camera_to_base(const Vec3& c) const {
  const double cp = std::cos(mount_.pitch_rad), sp = std::sin(mount_.pitch_rad);
  return {c.z * cp - c.y * sp, -c.x, -c.z * sp - c.y * cp};
}

Vec3 CameraModel::centre(const Pose& pose) const {
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  return {pose.x_m + c * mount_.x_m - s * mount_.y_m, pose.y_m + s * mount_.x_m + c * mount_.y_m, mount_.height_m};
}

Vec3 CameraModel::to_camera(const Pose& pose, const Vec3& world) const {
  const Vec3 o = centre(pose);
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);
  const double dx = world.x - o.x, dy = world.y - o.y, dz = world.z - o.z;
  const Vec3 b{c * dx + s * dy, -s * dx + c * dy, dz};  // base_link axes, from the lens
  const double cp = std::cos(mount_.pitch_rad), sp = std::sin(mount_.pitch_rad);
  // The transpose of camera_to_base's rotation.
  return {-b.y, -sp * b.x - cp * b.z, cp * b.x - sp * b.z};
}

bool CameraModel::project(const Pose& pose, const Vec3& world, double* u, double* v) const {
  const Vec3 c = to_camera(pose, world);
  if (c.z <= 1e-9) return false;
  distort(c.x / c.z, c.y / c.z, u, v);
  return true;
}

void CameraModel::distort(double x, double y, double* u, double* v) const {
  const double r2 = x * x + y * y;
  const double f = 1.0 + intr_.k1 * r2 + intr_.k2 * r2 * r2;
  *u = intr_.fx * x * f + intr_.cx;
  *v = intr_.fy * y * f + intr_.cy;
}

void CameraModel::undistort(double u, double v, double* x, double* y) const {
  const double xd = (u - intr_.cx) / intr_.fx, yd = (v - intr_.cy) / intr_.fy;
  const double rd = std::sqrt(xd * xd + yd * yd);
  if (rd < 1e-12) {
    *x = xd;
    *y = yd;
    return;
  }
  // Solve r (1 + k1 r² + k2 r⁴) = rd; the lens maps radii monotonically over the image.
  double r = rd;
  for (int i = 0; i < 20; ++i) {
    const double r2 = r * r;
    const double g = r * (1.0 + intr_.k1 * r2 + intr_.k2 * r2 * r2) - rd;
    const double dg = 1.0 + 3.0 * intr_.k1 * r2 + 5.0 * intr_.k2 * r2 * r2;
    const double step = g / dg;
    r -= step;
    if (std::fabs(step) < 1e-14) break;
  }
  *x = xd * r / rd;
  *y = yd * r / rd;
}

}  // namespace cart2d
