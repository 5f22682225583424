#include "camera_light.hpp"

#include <algorithm>
#include <cmath>

#include "camera_materials.hpp"  // slow_field

namespace cart2d {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kCartSides = 8;  // the cart's body as an octagon
constexpr double kMinSoftM = 0.004;
constexpr double kWrap = 0.6;

double cross(double ox, double oy, double ax, double ay, double bx, double by) {
  return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox);
}

// Andrew's monotone chain: the convex hull of n points (x, y pairs), counter-clockwise.
std::vector<double> convex_hull(std::vector<std::pair<double, double>> p) {
  std::sort(p.begin(), p.end());
  std::vector<std::pair<double, double>> h(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2].first, h[k - 2].second, h[k - 1].first, h[k - 1].second, p[i].first, p[i].second) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2].first, h[k - 2].second, h[k - 1].first, h[k - 1].second, p[i - 1].first, p[i - 1].second) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k > 1 ? k - 1 : k);
  std::vector<double> out;
  for (const auto& q : h) out.push_back(q.first), out.push_back(q.second);
  return out;
}

}  // namespace

Lighting::Lighting(const Look& look, const std::vector<Box>& boxes, const Pose& cart, double cart_radius_m)
    : look_(look), shadows_(look.lights.size()) {
  for (size_t l = 0; l < look.lights.size(); ++l) {
    for (const Box& b : boxes) {
      if (b.height_m <= 0.0) continue;
      const double foot[8] = {b.cx_m - b.hx_m, b.cy_m - b.hy_m, b.cx_m + b.hx_m, b.cy_m - b.hy_m,
                              b.cx_m + b.hx_m, b.cy_m + b.hy_m, b.cx_m - b.hx_m, b.cy_m + b.hy_m};
      add_caster(l, foot, 4, b.height_m);
    }
    if (look.cart_height_m > 0.0 && cart_radius_m > 0.0) {
      double foot[2 * kCartSides];
      for (int k = 0; k < kCartSides; ++k) {
        const double a = cart.theta_rad + 2 * kPi * (k + 0.5) / kCartSides;
        foot[2 * k] = cart.x_m + cart_radius_m * std::cos(a);
        foot[2 * k + 1] = cart.y_m + cart_radius_m * std::sin(a);
      }
      add_caster(l, foot, kCartSides, look.cart_height_m);
    }
  }
}

void Lighting::add_caster(size_t light, const double* foot_xy, size_t corners, double height_m) {
  const LightLook& L = look_.lights[light];
  if (height_m >= L.z_m - 0.05) return;  // as high as the lamp: its shadow has no end (not a room's case)
  const double k = L.z_m / (L.z_m - height_m);  // the top's corners pushed away from under the lamp
  std::vector<std::pair<double, double>> pts;
  for (size_t c = 0; c < corners; ++c) {
    const double x = foot_xy[2 * c], y = foot_xy[2 * c + 1];
    pts.push_back({x, y});
    pts.push_back({L.x_m + (x - L.x_m) * k, L.y_m + (y - L.y_m) * k});
  }
  Shadow s;
  s.hull = convex_hull(pts);
  s.soft_m = std::max(kMinSoftM, 2.0 * L.radius_m * height_m / (L.z_m - height_m));
  s.x0 = s.y0 = 1e30;
  s.x1 = s.y1 = -1e30;
  for (size_t i = 0; i < s.hull.size(); i += 2) {
    s.x0 = std::min(s.x0, s.hull[i]), s.x1 = std::max(s.x1, s.hull[i]);
    s.y0 = std::min(s.y0, s.hull[i + 1]), s.y1 = std::max(s.y1, s.hull[i + 1]);
  }
  const size_t n = s.hull.size();
  for (size_t i = 0; i < n; i += 2) {
    const double ax = s.hull[i], ay = s.hull[i + 1], ex = s.hull[(i + 2) % n] - ax, ey = s.hull[(i + 3) % n] - ay;
    const double len = std::hypot(ex, ey);
    if (len < 1e-12) continue;
    s.edges.insert(s.edges.end(), {ax, ay, ey / len, -ex / len});
  }
  const double pad = s.soft_m / 2;
  s.x0 -= pad, s.y0 -= pad, s.x1 += pad, s.y1 += pad;
  shadows_[light].push_back(std::move(s));
}

double Lighting::uneven(double x_m, double y_m) const {
  return look_.camera.uneven > 0.0 ? 1.0 + look_.camera.uneven * slow_field(x_m, y_m) : 1.0;
}

double Lighting::floor(double x_m, double y_m, uint32_t* shadow_bits) const {
  double light = look_.ambient;
  *shadow_bits = 0;
  for (size_t l = 0; l < look_.lights.size(); ++l) {
    const LightLook& L = look_.lights[l];
    double covered = 0.0;  // the deepest of the shadows here
    for (const Shadow& s : shadows_[l]) {
      if (x_m < s.x0 || x_m > s.x1 || y_m < s.y0 || y_m > s.y1) continue;
      // Signed distance to a convex polygon (< 0 inside): the largest over its edges' lines.
      double sd = -1e30;
      for (size_t i = 0; i < s.edges.size(); i += 4)
        sd = std::max(sd, (x_m - s.edges[i]) * s.edges[i + 2] + (y_m - s.edges[i + 1]) * s.edges[i + 3]);
      covered = std::max(covered, std::clamp(0.5 - sd / s.soft_m, 0.0, 1.0));
    }
    if (covered > 0.5) *shadow_bits |= 1u << l;
    const double dx = x_m - L.x_m, dy = y_m - L.y_m;
    const double d2 = dx * dx + dy * dy + L.z_m * L.z_m;
    const double cos_h = L.z_m / std::sqrt(d2);  // (H / d)³: inverse square times the cosine
    light += L.power * cos_h * cos_h * cos_h * (1.0 - covered);
  }
  return light * uneven(x_m, y_m);
}

double Lighting::surface(const Vec3& p, const Vec3& n) const {
  double light = look_.ambient;
  for (const LightLook& L : look_.lights) {
    const double dx = L.x_m - p.x, dy = L.y_m - p.y, dz = L.z_m - p.z;
    const double d2 = dx * dx + dy * dy + dz * dz, d = std::sqrt(d2);
    // Wrapped Lambert: light the room's other surfaces bounce reaches faces turned partly away
    // (a wall under a ceiling lamp is not half as bright as the floor).
    const double lambert = std::max(0.0, ((n.x * dx + n.y * dy + n.z * dz) / d + kWrap) / (1.0 + kWrap));
    light += L.power * lambert * (L.z_m * L.z_m) / d2;
  }
  return light * uneven(p.x, p.y);
}

double Lighting::highlight(const Vec3& p, const Vec3& d, double gloss) const {
  // The mirrored ray from p (d with z flipped) against each lamp's direction: a lamp's image is a
  // small bright blob whose size grows as the floor is rougher (less gloss).
  const double spread = 0.02 + 0.1 * (1.0 - gloss);
  double add = 0.0;
  for (const LightLook& L : look_.lights) {
    const double lx = L.x_m - p.x, ly = L.y_m - p.y, lz = L.z_m - p.z;
    const double ln = std::sqrt(lx * lx + ly * ly + lz * lz);
    // 1 − cos a ≈ a² / 2 for the small angles that count: a Gaussian in the angle.
    const double one_minus_cos = 1.0 - (d.x * lx + d.y * ly - d.z * lz) / ln;
    if (one_minus_cos > 12.0 * spread * spread) continue;  // beyond ~5 spreads: nothing
    add += L.power * std::exp(-one_minus_cos / (spread * spread)) * 3.0;
  }
  return add * gloss;
}

}  // namespace cart2d
