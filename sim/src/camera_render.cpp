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
  Rgb top, face_x, face_y;  // the colour as lit on each face
  int u0 = 0, u1 = 0, v0 = 0, v1 = 0;  // the pixels it may cover (rays elsewhere skip it)
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

namespace {

// What one frame's rays are cast against: the lens, the heading, the boxes in view, the board.
struct Scene {
  Vec3 o;
  double c = 1.0, s = 0.0;
  std::vector<Slab> slabs;
  const Checkerboard* board = nullptr;
  std::vector<const Marker*> markers;  // marker_render.cpp
  Vec3 bx, by, bn, b0;
  Rgb background = rgb_of(CameraRenderer::kBackgroundColour);
  Rgb dark = rgb_of(CameraRenderer::kBoardDark), light = rgb_of(CameraRenderer::kBoardLight);
};

// A ray's colour and the surface it met (floor 0, background 1, box 2 + index·4 + face,
// board 1 << 30 | square): pixels whose surfaces differ are on an edge.
struct Hit {
  Rgb colour;
  uint32_t surface = 0;
};

constexpr uint32_t kSurfaceBoard = 1u << 30;

Hit trace(const Scene& sc, const Vec3& r, int u, int v) {
  const Vec3 d{sc.c * r.x - sc.s * r.y, sc.s * r.x + sc.c * r.y, r.z};
  const Vec3& o = sc.o;
  double best = 1e30;
  Hit hit{sc.background, 1};
  if (d.z < -1e-12) {
    best = -o.z / d.z;
    const int level = static_cast<int>(CameraRenderer::kFloorColour & 0xff) +
                      floor_texture(o.x + best * d.x, o.y + best * d.y);
    const auto g = static_cast<uint8_t>(level);
    hit = {{g, g, g}, 0};
  }
  for (size_t k = 0; k < sc.slabs.size(); ++k) {
    const Slab& box = sc.slabs[k];
    if (u < box.u0 || u > box.u1 || v < box.v0 || v > box.v1) continue;
    double t = 0.0, shade = 1.0;
    if (hit_slab(o, d, sc.slabs[k], &t, &shade) && t < best) {
      best = t;
      const Slab& sl = sc.slabs[k];
      const uint32_t face = shade == kShadeTop ? 0 : shade == kShadeFaceX ? 1 : 2;
      hit = {face == 0 ? sl.top : face == 1 ? sl.face_x : sl.face_y, 2 + static_cast<uint32_t>(k) * 4 + face};
    }
  }
  uint32_t marker_colour = 0;
  if (hit_markers(sc.markers, o, d, CameraRenderer::kBoardDark, CameraRenderer::kBoardLight, &best, &marker_colour, &hit.surface))
    hit.colour = rgb_of(marker_colour);
  if (sc.board) {
    const Vec3 &bn = sc.bn, &b0 = sc.b0;
    const double denom = bn.x * d.x + bn.y * d.y + bn.z * d.z;
    if (std::fabs(denom) > 1e-12) {
      const double t = (bn.x * (b0.x - o.x) + bn.y * (b0.y - o.y) + bn.z * (b0.z - o.z)) / denom;
      // On a tie with the floor (a board lying on it), the board wins.
      if (t > 0.0 && t <= best * (1.0 + 1e-9)) {
        const Vec3 p{o.x + t * d.x - b0.x, o.y + t * d.y - b0.y, o.z + t * d.z - b0.z};
        const double a = (p.x * sc.bx.x + p.y * sc.bx.y + p.z * sc.bx.z) / sc.board->square_m;
        const double b = (p.x * sc.by.x + p.y * sc.by.y + p.z * sc.by.z) / sc.board->square_m;
        const int cols = sc.board->cols, rows = sc.board->rows;
        if (a >= -2.0 && a <= cols + 1.0 && b >= -2.0 && b <= rows + 1.0) {
          const bool squares = a >= -1.0 && a < cols && b >= -1.0 && b < rows;
          const auto ia = static_cast<int64_t>(std::floor(a)), ib = static_cast<int64_t>(std::floor(b));
          const bool dark = squares && (ia + ib) % 2 == 0;
          const uint32_t square = squares ? static_cast<uint32_t>((ia + 1) * (rows + 1) + (ib + 1)) : 0xffff;
          hit = {dark ? sc.dark : sc.light,
                 kSurfaceBoard | (dark ? square : 0xffff)};
        }
      }
    }
  }
  return hit;
}

}  // namespace

// The pixel rectangle a box may cover: its twelve edges sampled (the lens bows straight edges,
// so corners alone are not enough) and projected, widened by two pixels; the whole image if any
// of it is behind or beside the lens plane.
namespace {

void pixel_bounds(const CameraModel& model_, const Pose& pose, Slab* slab) {
  const int w = model_.intrinsics().width_px, h = model_.intrinsics().height_px;
  const double xs[2] = {slab->x0, slab->x1}, ys[2] = {slab->y0, slab->y1}, zs[2] = {0.0, slab->h};
  double u_min = 1e30, u_max = -1e30, v_min = 1e30, v_max = -1e30;
  constexpr int kSamples = 8;
  for (int axis = 0; axis < 3; ++axis) {
    for (int a = 0; a < 2; ++a) {
      for (int b = 0; b < 2; ++b) {
        for (int k = 0; k <= kSamples; ++k) {
          const double f = static_cast<double>(k) / kSamples;
          Vec3 p;
          if (axis == 0) p = {xs[0] + f * (xs[1] - xs[0]), ys[a], zs[b]};
          else if (axis == 1) p = {xs[a], ys[0] + f * (ys[1] - ys[0]), zs[b]};
          else p = {xs[a], ys[b], zs[0] + f * (zs[1] - zs[0])};
          const Vec3 cam = model_.to_camera(pose, p);
          // Far off-axis points distort wildly: beyond ~60° the box may be anywhere.
          if (cam.z <= 0.5 * std::sqrt(cam.x * cam.x + cam.y * cam.y)) {
            slab->u0 = 0, slab->u1 = w - 1, slab->v0 = 0, slab->v1 = h - 1;
            return;
          }
          double u = 0.0, v = 0.0;
          model_.distort(cam.x / cam.z, cam.y / cam.z, &u, &v);
          u_min = std::min(u_min, u), u_max = std::max(u_max, u);
          v_min = std::min(v_min, v), v_max = std::max(v_max, v);
        }
      }
    }
  }
  slab->u0 = std::max(0, static_cast<int>(std::floor(u_min)) - 2);
  slab->u1 = std::min(w - 1, static_cast<int>(std::ceil(u_max)) + 2);
  slab->v0 = std::max(0, static_cast<int>(std::floor(v_min)) - 2);
  slab->v1 = std::min(h - 1, static_cast<int>(std::ceil(v_max)) + 2);
}

}  // namespace

void CameraRenderer::render_clean(const World& world, const Pose& pose, const Checkerboard* board,
                                  std::vector<Rgb>* out) const {
  Scene sc;
  sc.o = model_.centre(pose);
  sc.c = std::cos(pose.theta_rad);
  sc.s = std::sin(pose.theta_rad);
  const Vec3& o = sc.o;
  const double c = sc.c, s = sc.s;
  // Boxes in front of the lens and within range (a map's wall grid can hold many).
  for (const Box& b : world.boxes()) {
    const double x0 = b.cx_m - b.hx_m, x1 = b.cx_m + b.hx_m, y0 = b.cy_m - b.hy_m, y1 = b.cy_m + b.hy_m;
    const double ahead = std::max({(x0 - o.x) * c + (y0 - o.y) * s, (x1 - o.x) * c + (y0 - o.y) * s,
                                   (x0 - o.x) * c + (y1 - o.y) * s, (x1 - o.x) * c + (y1 - o.y) * s});
    if (ahead <= 0.0 || box_distance(b, o.x, o.y).dist_m > kMaxRangeM || b.height_m <= 0.0) continue;
    Slab slab{x0, x1, y0, y1, b.height_m, b.colour_rgb, rgb_of(b.colour_rgb, kShadeTop),
              rgb_of(b.colour_rgb, kShadeFaceX), rgb_of(b.colour_rgb, kShadeFaceY)};
    pixel_bounds(model_, pose, &slab);
    if (slab.u0 <= slab.u1 && slab.v0 <= slab.v1) sc.slabs.push_back(slab);
  }
  sc.markers = markers_ahead(markers_, sc.o, sc.c, sc.s);
  if (board) {
    sc.board = board;
    board->axes(&sc.bx, &sc.by, &sc.bn);
    sc.b0 = board->corner(0, 0);
  }

  const std::vector<Vec3>& rays = model_.rays_base();
  const std::vector<Vec3>& subrays = model_.subrays_base();
  const int w = model_.intrinsics().width_px, h = model_.intrinsics().height_px;
  std::vector<uint32_t> surface(rays.size());
  out->resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit hit = trace(sc, rays[i], static_cast<int>(i % static_cast<size_t>(w)), static_cast<int>(i / static_cast<size_t>(w)));
    (*out)[i] = hit.colour;
    surface[i] = hit.surface;
  }
  // Anti-aliasing where surfaces meet (a box's outline, the board's squares): those pixels are
  // the mean of four rays, as a sensor pixel integrates its area; edges then land at sub-pixel
  // places (what corner detection and calibration rely on). Elsewhere one ray is enough.
  std::vector<uint8_t> edge(rays.size(), 0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * static_cast<size_t>(w) + static_cast<size_t>(u);
      if (u + 1 < w && surface[i] != surface[i + 1]) edge[i] = edge[i + 1] = 1;
      if (v + 1 < h && surface[i] != surface[i + static_cast<size_t>(w)]) edge[i] = edge[i + static_cast<size_t>(w)] = 1;
    }
  }
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!edge[i]) continue;
    int r = 0, g = 0, b = 0;
    for (size_t k = 0; k < 4; ++k) {
      const Rgb sub = trace(sc, subrays[4 * i + k], static_cast<int>(i % static_cast<size_t>(w)),
                            static_cast<int>(i / static_cast<size_t>(w))).colour;
      r += sub.r;
      g += sub.g;
      b += sub.b;
    }
    (*out)[i] = {static_cast<uint8_t>((r + 2) / 4), static_cast<uint8_t>((g + 2) / 4), static_cast<uint8_t>((b + 2) / 4)};
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
      (*rgb)[3 * i + static_cast<size_t>(k)] = static_cast<uint8_t>(std::clamp(v, 0.0, 255.0) + 0.5);
    }
  }
}

}  // namespace cart2d
