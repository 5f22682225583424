#include "camera_render.hpp"

#include <algorithm>
#include <cmath>

#include "robot_params.hpp"  // params::sim::camera
#include "rng.hpp"

namespace cart2d {

namespace {

Rgb rgb_of(uint32_t c, double shade = 1.0) {
  auto channel = [shade](uint32_t v) {
    return static_cast<uint8_t>(std::clamp(std::lround(static_cast<double>(v & 0xff) * shade), 0L, 255L));
  };
  return {channel(c >> 16), channel(c >> 8), channel(c)};
}

// Faces lit by a fixed diffuse light from above: sides a shade darker than tops, the two side
// orientations apart, so that a box's edges show as they do under a ceiling lamp.
constexpr double kShadeTop = 1.0, kShadeFaceX = 0.8, kShadeFaceY = 0.9;

// A box the camera may see, with its slab bounds.
struct Slab {
  double x0, x1, y0, y1, h;
  uint32_t colour;
};

// Ray O + t·d against an axis-aligned box on the floor (Kay & Kajiya slabs). Returns the entry
// distance and the entered face's shade, if the ray enters it ahead of the origin.
bool hit_slab(const Vec3& o, const Vec3& d, const Slab& s, double* t_out, double* shade) {
  double t0 = 0.0, t1 = 1e30;
  double entry_shade = kShadeTop;
  const double lo[3] = {s.x0, s.y0, 0.0}, hi[3] = {s.x1, s.y1, s.h};
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  const double face_shade[3] = {kShadeFaceX, kShadeFaceY, kShadeTop};
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(dd[a]) < 1e-12) {
      if (oo[a] < lo[a] || oo[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - oo[a]) / dd[a], tb = (hi[a] - oo[a]) / dd[a];
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) {
      t0 = ta;
      entry_shade = face_shade[a];
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  if (t0 <= 0.0) return false;  // the lens inside a box: nothing to see there
  *t_out = t0;
  *shade = entry_shade;
  return true;
}

// A deterministic value in [-levels, levels] for a floor tile (a hash, not a random stream:
// the same tile looks the same in every frame).
int floor_texture(double x_m, double y_m) {
  const auto ix = static_cast<int64_t>(std::floor(x_m / CameraRenderer::kFloorTileM));
  const auto iy = static_cast<int64_t>(std::floor(y_m / CameraRenderer::kFloorTileM));
  uint64_t h = static_cast<uint64_t>(ix) * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(iy) * 0xC2B2AE3D27D4EB4Full;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return static_cast<int>(h % (2 * CameraRenderer::kFloorTextureLevels + 1)) - CameraRenderer::kFloorTextureLevels;
}

}  // namespace

void Checkerboard::axes(Vec3* ex, Vec3* ey, Vec3* n) const {
  const double cr = std::cos(roll_rad), sr = std::sin(roll_rad);
  const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad);
  const double cy = std::cos(yaw_rad), sy = std::sin(yaw_rad);
  // Columns of Rz(yaw)·Ry(pitch)·Rx(roll).
  *ex = {cy * cp, sy * cp, -sp};
  *ey = {cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr};
  *n = {cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr};
}

Vec3 Checkerboard::corner(double i, double j) const {
  Vec3 ex, ey, n;
  axes(&ex, &ey, &n);
  const double a = i * square_m, b = j * square_m;
  return {x_m + a * ex.x + b * ey.x, y_m + a * ex.y + b * ey.y, z_m + a * ex.z + b * ey.z};
}

void CameraRenderer::render_clean(const World& world, const Pose& pose, const Checkerboard* board,
                                  std::vector<Rgb>* out) const {
  const Vec3 o = model_.centre(pose);
  const double c = std::cos(pose.theta_rad), s = std::sin(pose.theta_rad);

  // Boxes in front of the lens and within range (a map's wall grid can hold many).
  std::vector<Slab> slabs;
  for (const Box& b : world.boxes()) {
    const double x0 = b.cx_m - b.hx_m, x1 = b.cx_m + b.hx_m, y0 = b.cy_m - b.hy_m, y1 = b.cy_m + b.hy_m;
    const double ahead = std::max({(x0 - o.x) * c + (y0 - o.y) * s, (x1 - o.x) * c + (y0 - o.y) * s,
                                   (x0 - o.x) * c + (y1 - o.y) * s, (x1 - o.x) * c + (y1 - o.y) * s});
    if (ahead <= 0.0 || box_distance(b, o.x, o.y).dist_m > kMaxRangeM || b.height_m <= 0.0) continue;
    slabs.push_back({x0, x1, y0, y1, b.height_m, b.colour_rgb});
  }

  Vec3 bx, by, bn;
  Vec3 b0;
  if (board) {
    board->axes(&bx, &by, &bn);
    b0 = board->corner(0, 0);
  }

  const Rgb background = rgb_of(kBackgroundColour);
  const Rgb dark = rgb_of(kBoardDark), light = rgb_of(kBoardLight);
  const std::vector<Vec3>& rays = model_.rays_base();
  out->resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const Vec3& r = rays[i];
    const Vec3 d{c * r.x - s * r.y, s * r.x + c * r.y, r.z};
    double best = 1e30;
    Rgb colour = background;
    if (d.z < -1e-12) {
      best = -o.z / d.z;
      const double fx = o.x + best * d.x, fy = o.y + best * d.y;
      const int level = static_cast<int>(kFloorColour & 0xff) + floor_texture(fx, fy);
      const auto g = static_cast<uint8_t>(level);
      colour = {g, g, g};
    }
    for (const Slab& sl : slabs) {
      double t = 0.0, shade = 1.0;
      if (hit_slab(o, d, sl, &t, &shade) && t < best) {
        best = t;
        colour = rgb_of(sl.colour, shade);
      }
    }
    if (board) {
      const double denom = bn.x * d.x + bn.y * d.y + bn.z * d.z;
      if (std::fabs(denom) > 1e-12) {
        const double t = (bn.x * (b0.x - o.x) + bn.y * (b0.y - o.y) + bn.z * (b0.z - o.z)) / denom;
        // On a tie with the floor (a board lying on it), the board wins.
        if (t > 0.0 && t <= best * (1.0 + 1e-9)) {
          const Vec3 p{o.x + t * d.x - b0.x, o.y + t * d.y - b0.y, o.z + t * d.z - b0.z};
          const double a = (p.x * bx.x + p.y * bx.y + p.z * bx.z) / board->square_m;
          const double b = (p.x * by.x + p.y * by.y + p.z * by.z) / board->square_m;
          if (a >= -2.0 && a <= board->cols + 1.0 && b >= -2.0 && b <= board->rows + 1.0) {
            best = t;
            const bool squares = a >= -1.0 && a < board->cols && b >= -1.0 && b < board->rows;
            const auto parity = static_cast<int64_t>(std::floor(a)) + static_cast<int64_t>(std::floor(b));
            colour = squares && parity % 2 == 0 ? dark : light;
          }
        }
      }
    }
    (*out)[i] = colour;
  }
}

void CameraRenderer::render(const World& world, const Pose& pose, const Checkerboard* board, double exposure,
                            double noise_sigma, uint64_t seed, uint64_t frame, std::vector<uint8_t>* rgb) const {
  std::vector<Rgb> clean;
  render_clean(world, pose, board, &clean);
  rgb->resize(clean.size() * 3);
  // Normal noise from four 16-bit uniforms of one draw (their sum has variance 4/12, hence the
  // √3): close to Gaussian within ±3.5σ, and a fraction of the cost of Box–Muller per sample.
  Rng rng(seed, static_cast<uint64_t>(params::sim::camera::seed_stream) + frame);
  const double scale = noise_sigma * std::sqrt(3.0) / 65536.0;
  const bool noisy = noise_sigma > 0.0;
  for (size_t i = 0; i < clean.size(); ++i) {
    const uint8_t ch[3] = {clean[i].r, clean[i].g, clean[i].b};
    for (int k = 0; k < 3; ++k) {
      double v = ch[k] * exposure;
      if (noisy) {
        const uint64_t w = rng.next();
        const double sum = static_cast<double>((w & 0xffff) + ((w >> 16) & 0xffff) + ((w >> 32) & 0xffff) + (w >> 48));
        v += (sum - 2.0 * 65535.0) * scale;
      }
      (*rgb)[3 * i + static_cast<size_t>(k)] = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  }
}

}  // namespace cart2d
