#include "camera_render.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "camera_effects.hpp"
#include "camera_light.hpp"
#include "camera_materials.hpp"

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
  Rgb top, face_x, face_y;  // the colour as lit on each face (today's fixed light)
  int u0 = 0, u1 = 0, v0 = 0, v1 = 0;  // the pixels it may cover (rays elsewhere skip it)
  int ru0 = 1, ru1 = 0, rv0 = 1, rv1 = 0;  // ...and its reflection in a glossy floor (none: empty)
  bool painted = false;  // in the look's wall paint, with its skirting
  uint32_t paint = 0;    // its colour under the look's lights
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

// What one frame's rays are cast against: the lens, the heading, the boxes in view, the board,
// the extra items, and the look with its lights.
struct Scene {
  Vec3 o;
  double c = 1.0, s = 0.0;
  std::vector<Slab> slabs;
  const Checkerboard* board = nullptr;
  std::vector<const Marker*> markers;  // marker_render.cpp
  Vec3 bx, by, bn, b0;
  Rgb background = rgb_of(CameraRenderer::kBackgroundColour);
  Rgb dark = rgb_of(CameraRenderer::kBoardDark), light = rgb_of(CameraRenderer::kBoardLight);
  const std::vector<const SceneItem*>* items = nullptr;
  const Look* look = nullptr;
  std::unique_ptr<Lighting> lighting;  // with lights only
  double pixel_rad = 1.0 / 300.0;       // the angle one pixel spans (texture filtering)
};

// A ray's colour and the surface it met (floor 0, or 1 << 29 | the lamps whose shadow covers it;
// background 1; box 2 + index·4 + face, | 1 << 28 on its skirting; board 1 << 30 | square; an
// item's own ids): pixels whose surfaces differ are on an edge.
struct Hit {
  Rgb colour;
  uint32_t surface = 0;
  double t = CameraRenderer::kMaxRangeM;
};

constexpr uint32_t kSurfaceBoard = 1u << 30;
constexpr uint32_t kSurfaceShadow = 1u << 29;
constexpr uint32_t kSurfaceSkirting = 1u << 28;

Rgb to_rgb(const Colour& c) {
  auto channel = [](double v) { return static_cast<uint8_t>(std::clamp(v, 0.0, 255.0) + 0.5); };
  return {channel(c.r), channel(c.g), channel(c.b)};
}

Colour scaled(const Colour& c, double k) { return {c.r * k, c.g * k, c.b * k}; }

// The nearest box along o + t·d with t < *best among those whose pixel bounds (the reflected
// ones if `mirrored`) hold (u, v); its index and entered face, or -1.
long nearest_slab(const Scene& sc, const Vec3& o, const Vec3& d, int u, int v, bool mirrored, double* best,
                  uint32_t* face) {
  long found = -1;
  for (size_t k = 0; k < sc.slabs.size(); ++k) {
    const Slab& box = sc.slabs[k];
    if (mirrored ? (u < box.ru0 || u > box.ru1 || v < box.rv0 || v > box.rv1)
                 : (u < box.u0 || u > box.u1 || v < box.v0 || v > box.v1))
      continue;
    double t = 0.0, shade = 1.0;
    if (hit_slab(o, d, box, &t, &shade) && t < *best) {
      *best = t;
      found = static_cast<long>(k);
      *face = shade == kShadeTop ? 0 : shade == kShadeFaceX ? 1 : 2;
    }
  }
  return found;
}

// A box's face as lit: today's fixed shades, or its paint under the look's lamps.
Rgb box_colour(const Scene& sc, const Slab& sl, uint32_t face, const Vec3& p, const Vec3& d, bool* skirting) {
  const Look& look = *sc.look;
  *skirting = sl.painted && face != 0 && p.z < look.walls.skirting_m;
  if (!sl.painted && !look.lit()) return face == 0 ? sl.top : face == 1 ? sl.face_x : sl.face_y;
  Colour albedo = colour_of(*skirting ? look.walls.skirting_colour : sl.paint);
  if (!look.lit()) {
    const double shade = face == 0 ? kShadeTop : face == 1 ? kShadeFaceX : kShadeFaceY;
    return to_rgb(scaled(albedo, shade));
  }
  const Vec3 n = face == 0 ? Vec3{0, 0, 1} : face == 1 ? Vec3{d.x > 0 ? -1.0 : 1.0, 0, 0} : Vec3{0, d.y > 0 ? -1.0 : 1.0, 0};
  return to_rgb(scaled(albedo, sc.lighting->surface(p, n)));
}

// What a glossy floor at p mirrors along the view ray d: the boxes and walls (their reflection
// lies below them in the picture), else the ceiling; and the lamps' images.
Colour reflection(const Scene& sc, const Vec3& p, const Vec3& d, int u, int v) {
  const Vec3 r{d.x, d.y, -d.z};
  const Vec3 o{p.x + r.x * 1e-6, p.y + r.y * 1e-6, 1e-6};
  double best = CameraRenderer::kMaxRangeM;
  uint32_t face = 0;
  Colour out = colour_of(sc.look->ceiling);
  const long k = nearest_slab(sc, o, r, u, v, true, &best, &face);
  if (k >= 0) {
    const Vec3 q{o.x + best * r.x, o.y + best * r.y, o.z + best * r.z};
    bool skirting = false;
    const Rgb c = box_colour(sc, sc.slabs[static_cast<size_t>(k)], face, q, r, &skirting);
    out = {static_cast<double>(c.r), static_cast<double>(c.g), static_cast<double>(c.b)};
  }
  if (sc.lighting) {
    const double glow = 255.0 * sc.lighting->highlight(p, d, sc.look->floor.gloss);
    out = {out.r + glow, out.g + glow, out.b + glow};
  }
  return out;
}

Hit floor_hit(const Scene& sc, const Vec3& d, double t, int u, int v) {
  const Look& look = *sc.look;
  const Vec3 p{sc.o.x + t * d.x, sc.o.y + t * d.y, 0.0};
  Colour c;
  if (look.floor.material == FloorLook::Material::kDefault) {
    const int level = static_cast<int>(CameraRenderer::kFloorColour & 0xff) + floor_texture(p.x, p.y);
    if (!look.lit() && look.floor.gloss <= 0.0) {
      const auto g = static_cast<uint8_t>(level);
      return {{g, g, g}, 0, t};
    }
    c = {static_cast<double>(level), static_cast<double>(level), static_cast<double>(level)};
  } else {
    // A pixel's footprint on the floor: longer as the ray grazes it (the geometric mean of its two sides).
    const double footprint = t * sc.pixel_rad / std::sqrt(std::max(std::fabs(d.z), 0.02));
    c = floor_albedo(look.floor, p.x, p.y, footprint);
  }
  uint32_t surface = 0;
  if (sc.lighting) {
    uint32_t bits = 0;
    c = scaled(c, sc.lighting->floor(p.x, p.y, &bits));
    if (bits) surface = kSurfaceShadow | bits;
  }
  if (look.floor.gloss > 0.0) {
    // More mirror-like as the view grazes the floor (Schlick's Fresnel term, shape only).
    const double k = 1.0 - std::fabs(d.z);
    const double g = look.floor.gloss * (0.35 + 0.65 * k * k * k * k * k);
    const Colour r = reflection(sc, p, d, u, v);
    c = {c.r * (1 - g) + r.r * g, c.g * (1 - g) + r.g * g, c.b * (1 - g) + r.b * g};
  }
  return {to_rgb(c), surface, t};
}

Hit trace(const Scene& sc, const Vec3& r, int u, int v) {
  const Vec3 d{sc.c * r.x - sc.s * r.y, sc.s * r.x + sc.c * r.y, r.z};
  const Vec3& o = sc.o;
  double best = 1e30;
  Hit hit{sc.background, 1};
  if (d.z < -1e-12) {
    best = -o.z / d.z;
    hit = floor_hit(sc, d, best, u, v);
  }
  uint32_t face = 0;
  if (const long k = nearest_slab(sc, o, d, u, v, false, &best, &face); k >= 0) {
    const Vec3 p{o.x + best * d.x, o.y + best * d.y, o.z + best * d.z};
    bool skirting = false;
    const Rgb c = box_colour(sc, sc.slabs[static_cast<size_t>(k)], face, p, d, &skirting);
    hit = {c, (2 + static_cast<uint32_t>(k) * 4 + face) | (skirting ? kSurfaceSkirting : 0u), best};
  }
  uint32_t marker_colour = 0;
  if (hit_markers(sc.markers, o, d, CameraRenderer::kBoardDark, CameraRenderer::kBoardLight, &best, &marker_colour, &hit.surface)) {
    hit.colour = rgb_of(marker_colour);
    hit.t = best;
  }
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
          hit = {dark ? sc.dark : sc.light, kSurfaceBoard | (dark ? square : 0xffff), t};
          best = t;
        }
      }
    }
  }
  if (sc.items) {
    for (const SceneItem* item : *sc.items) {
      double t = 0.0;
      Rgb colour;
      uint32_t surface = 0;
      if (item->hit(o, d, std::min(best, CameraRenderer::kMaxRangeM), &t, &colour, &surface)) {
        best = t;
        hit = {colour, surface, t};
      }
    }
  }
  return hit;
}

}  // namespace

// The pixel rectangle a box (between heights z0 and z1) may cover: each face clipped to the view's
// frustum (Sutherland–Hodgman, in the camera's frame: a wall beside and behind the lens keeps only
// what is in view), its edges sampled (the lens bows straight edges, so corners alone are not
// enough) and projected, widened by two pixels; empty (u0 > u1) if nothing of it is in view.
namespace {

// The frustum's half-widths on the z = 1 plane: the image's corners undistorted, a little wider.
void frustum(const CameraModel& model, double* half_x, double* half_y) {
  const int w = model.intrinsics().width_px, h = model.intrinsics().height_px;
  *half_x = *half_y = 0.0;
  for (double u : {-0.5, w - 0.5})
    for (double v : {-0.5, h - 0.5}) {
      double x = 0.0, y = 0.0;
      model.undistort(u, v, &x, &y);
      *half_x = std::max(*half_x, std::fabs(x) * 1.05);
      *half_y = std::max(*half_y, std::fabs(y) * 1.05);
    }
}

// Clips a polygon (camera frame) to the frustum's five planes.
std::vector<Vec3> clip_to_view(std::vector<Vec3> poly, double hx, double hy) {
  constexpr double kNear = 0.01;
  auto side = [hx, hy](int plane, const Vec3& p) {
    switch (plane) {
      case 0: return p.z - kNear;
      case 1: return hx * p.z - p.x;
      case 2: return hx * p.z + p.x;
      case 3: return hy * p.z - p.y;
      default: return hy * p.z + p.y;
    }
  };
  for (int plane = 0; plane < 5 && !poly.empty(); ++plane) {
    std::vector<Vec3> out;
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec3& a = poly[i];
      const Vec3& b = poly[(i + 1) % poly.size()];
      const double fa = side(plane, a), fb = side(plane, b);
      if (fa >= 0) out.push_back(a);
      if ((fa >= 0) != (fb >= 0)) {
        const double t = fa / (fa - fb);
        out.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)});
      }
    }
    poly.swap(out);
  }
  return poly;
}

void pixel_bounds(const CameraModel& model_, const Pose& pose, const Slab& slab, double z0, double z1, int* u0, int* u1,
                  int* v0, int* v1) {
  const int w = model_.intrinsics().width_px, h = model_.intrinsics().height_px;
  double hx = 0.0, hy = 0.0;
  frustum(model_, &hx, &hy);
  Vec3 corner[8];
  for (int k = 0; k < 8; ++k)
    corner[k] = model_.to_camera(pose, {k & 1 ? slab.x1 : slab.x0, k & 2 ? slab.y1 : slab.y0, k & 4 ? z1 : z0});
  static const int kFaces[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
  double u_min = 1e30, u_max = -1e30, v_min = 1e30, v_max = -1e30;
  constexpr int kSamples = 8;
  for (const auto& face : kFaces) {
    const std::vector<Vec3> poly =
        clip_to_view({corner[face[0]], corner[face[1]], corner[face[2]], corner[face[3]]}, hx, hy);
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec3& a = poly[i];
      const Vec3& b = poly[(i + 1) % poly.size()];
      for (int k = 0; k < kSamples; ++k) {
        const double f = static_cast<double>(k) / kSamples;
        const Vec3 p{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), a.z + f * (b.z - a.z)};
        double u = 0.0, v = 0.0;
        model_.distort(p.x / p.z, p.y / p.z, &u, &v);
        u_min = std::min(u_min, u), u_max = std::max(u_max, u);
        v_min = std::min(v_min, v), v_max = std::max(v_max, v);
      }
    }
  }
  if (u_min > u_max) {
    *u0 = *v0 = 1, *u1 = *v1 = 0;
    return;
  }
  *u0 = std::max(0, static_cast<int>(std::floor(u_min)) - 2);
  *u1 = std::min(w - 1, static_cast<int>(std::ceil(u_max)) + 2);
  *v0 = std::max(0, static_cast<int>(std::floor(v_min)) - 2);
  *v1 = std::min(h - 1, static_cast<int>(std::ceil(v_max)) + 2);
}

}  // namespace

void CameraRenderer::render_clean(const World& world, const Pose& pose, const Checkerboard* board,
                                  std::vector<Rgb>* out) const {
  FrameScene scene;
  scene.world = &world;
  scene.pose = pose;
  scene.board = board;
  render_clean(scene, out);
}

void CameraRenderer::render_clean(const FrameScene& frame, std::vector<Rgb>* out, std::vector<float>* depth) const {
  const World& world = *frame.world;
  const Pose& pose = frame.pose;
  Scene sc;
  sc.o = model_.centre(pose);
  sc.c = std::cos(pose.theta_rad);
  sc.s = std::sin(pose.theta_rad);
  sc.look = &world.look();
  sc.items = frame.items.empty() ? nullptr : &frame.items;
  sc.pixel_rad = 1.0 / model_.intrinsics().fx;
  const bool glossy = sc.look->floor.gloss > 0.0;
  if (sc.look->lit())
    sc.lighting = std::make_unique<Lighting>(*sc.look, world.boxes(), pose, params::body::footprint_radius_m);
  const Vec3& o = sc.o;
  const double c = sc.c, s = sc.s;
  // Boxes in front of the lens and within range (a map's wall grid can hold many); with a glossy
  // floor also those whose reflection may be in view.
  for (const Box& b : world.boxes()) {
    const double x0 = b.cx_m - b.hx_m, x1 = b.cx_m + b.hx_m, y0 = b.cy_m - b.hy_m, y1 = b.cy_m + b.hy_m;
    const double ahead = std::max({(x0 - o.x) * c + (y0 - o.y) * s, (x1 - o.x) * c + (y0 - o.y) * s,
                                   (x0 - o.x) * c + (y1 - o.y) * s, (x1 - o.x) * c + (y1 - o.y) * s});
    if (ahead <= 0.0 || box_distance(b, o.x, o.y).dist_m > kMaxRangeM || b.height_m <= 0.0) continue;
    const bool painted = b.wall_paint || (b.kind == BoxKind::kWall && sc.look->walls.painted);
    const uint32_t paint = painted ? sc.look->walls.colour : b.colour_rgb;
    Slab slab{x0, x1, y0, y1, b.height_m, b.colour_rgb, rgb_of(b.colour_rgb, kShadeTop),
              rgb_of(b.colour_rgb, kShadeFaceX), rgb_of(b.colour_rgb, kShadeFaceY)};
    slab.painted = painted;
    slab.paint = paint;
    pixel_bounds(model_, pose, slab, 0.0, slab.h, &slab.u0, &slab.u1, &slab.v0, &slab.v1);
    if (glossy) pixel_bounds(model_, pose, slab, -slab.h, 0.0, &slab.ru0, &slab.ru1, &slab.rv0, &slab.rv1);
    if ((slab.u0 <= slab.u1 && slab.v0 <= slab.v1) || (glossy && slab.ru0 <= slab.ru1 && slab.rv0 <= slab.rv1))
      sc.slabs.push_back(slab);
  }
  sc.markers = markers_ahead(markers_, sc.o, sc.c, sc.s);
  if (frame.board) {
    sc.board = frame.board;
    frame.board->axes(&sc.bx, &sc.by, &sc.bn);
    sc.b0 = frame.board->corner(0, 0);
  }

  const std::vector<Vec3>& rays = model_.rays_base();
  const std::vector<Vec3>& subrays = model_.subrays_base();
  const int w = model_.intrinsics().width_px, h = model_.intrinsics().height_px;
  std::vector<uint32_t> surface(rays.size());
  out->resize(rays.size());
  if (depth) depth->resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit hit = trace(sc, rays[i], static_cast<int>(i % static_cast<size_t>(w)), static_cast<int>(i / static_cast<size_t>(w)));
    (*out)[i] = hit.colour;
    surface[i] = hit.surface;
    if (depth) (*depth)[i] = static_cast<float>(std::min(hit.t, kMaxRangeM));
  }
  // Anti-aliasing where surfaces meet (a box's outline, the board's squares, a shadow's edge):
  // those pixels are the mean of four rays, as a sensor pixel integrates its area; edges then land
  // at sub-pixel places (what corner detection and calibration rely on). Elsewhere one ray is enough.
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
  FrameScene scene;
  scene.world = &world;
  scene.pose = pose;
  scene.board = board;
  render(scene, exposure, noise_sigma, seed, frame, rgb);
}

void CameraRenderer::render(const FrameScene& scene, double gain, double noise_sigma, uint64_t seed, uint64_t frame,
                            std::vector<uint8_t>* rgb) const {
  const CameraLook& look = scene.world->look().camera;
  const bool blur = look.shutter_ms > 0.0 && (scene.twist.v_mps != 0.0 || scene.twist.omega_radps != 0.0);
  std::vector<Rgb> clean;
  std::vector<float> depth;
  render_clean(scene, &clean, blur ? &depth : nullptr);
  if (blur) motion_blur(model_, scene.pose, scene.twist, look.shutter_ms / 1000.0, depth, &clean);
  Rng rng(seed, static_cast<uint64_t>(params::sim::camera::seed_stream) + frame);
  expose(clean, model_, look, gain, noise_sigma, &rng, rgb);
}

}  // namespace cart2d
