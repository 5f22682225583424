#include "camera_materials.hpp"

#include <algorithm>
#include <cmath>

namespace cart2d {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A deterministic hash of two cell indices and a salt to [0, 1).
double hash01(int64_t i, int64_t j, uint64_t salt) {
  uint64_t h = static_cast<uint64_t>(i) * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^
               salt * 0x165667B19E3779F9ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

// Value noise: hashes on a unit grid, smoothly interpolated; in [0, 1).
double value_noise(double x, double y, uint64_t salt) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3 - 2 * tx);
  ty = ty * ty * (3 - 2 * ty);
  const double a = hash01(ix, iy, salt), b = hash01(ix + 1, iy, salt);
  const double c = hash01(ix, iy + 1, salt), d = hash01(ix + 1, iy + 1, salt);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// How much of the window [x − w/2, x + w/2] falls on lines of width `line` at the start of every
// period `p` (an exact box filter: F counts line length up to x).
double line_cover(double x, double p, double line, double w) {
  if (line <= 0.0) return 0.0;
  auto F = [p, line](double t) {
    const double n = std::floor(t / p);
    return n * line + std::min(t - n * p, line);
  };
  w = std::max(w, 1e-5);
  return std::clamp((F(x + w / 2) - F(x - w / 2)) / w, 0.0, 1.0);
}

Colour mix(const Colour& a, const Colour& b, double t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

Colour scaled(const Colour& c, double k) { return {c.r * k, c.g * k, c.b * k}; }

// Fine detail fades as a pixel covers more of its period (a distant pattern averages out).
double detail(double period_m, double footprint_m) { return std::clamp(1.0 - footprint_m / period_m, 0.0, 1.0); }

Colour tiles(const FloorLook& f, double x, double y, double fp) {
  const double s = f.size_m;
  const auto i = static_cast<int64_t>(std::floor(x / s)), j = static_cast<int64_t>(std::floor(y / s));
  const double tone = 1.0 + f.variation * (2 * hash01(i, j, 1) - 1) * detail(s, fp);
  const double speck = 1.0 + 0.03 * (2 * value_noise(x / 0.01, y / 0.01, 2) - 1) * detail(0.02, fp);
  const Colour tile = scaled(colour_of(f.colour), tone * speck);
  const double gx = line_cover(x + f.line_m / 2, s, f.line_m, fp), gy = line_cover(y + f.line_m / 2, s, f.line_m, fp);
  const double grout = gx + gy - gx * gy;
  return mix(tile, colour_of(f.accent), grout);
}

Colour planks(const FloorLook& f, double x, double y, double fp) {
  // Planks run along x, `size` wide and `length` long, each row's joints offset by a hashed amount.
  const double wdt = f.size_m, len = f.length_m;
  const auto row = static_cast<int64_t>(std::floor(y / wdt));
  const double shift = hash01(row, 0, 3) * len;
  const auto col = static_cast<int64_t>(std::floor((x + shift) / len));
  const double tone = 1.0 + f.variation * (2 * hash01(col, row, 4) - 1) * detail(wdt, fp);
  // Grain: stripes along the plank, wavering, fading with distance.
  const double waver = 0.004 * std::sin(x * 7.0 + hash01(col, row, 5) * 6.0);
  const double grain = std::sin((y + waver) * 2 * kPi / 0.006 + 3.0 * value_noise(x / 0.15, y / 0.02, 6));
  const double streak = 0.06 * grain * detail(0.012, fp) + 0.05 * (2 * value_noise(x / 0.3, y / 0.01, 7) - 1) * detail(0.02, fp);
  const Colour wood = scaled(colour_of(f.colour), tone * (1.0 + streak));
  const double seam_y = line_cover(y + f.line_m / 2, wdt, f.line_m, fp);
  const double seam_x = line_cover(x + shift + f.line_m / 2, len, f.line_m, fp);
  return mix(wood, colour_of(f.accent), seam_y + seam_x - seam_y * seam_x);
}

Colour carpet(const FloorLook& f, double x, double y, double fp) {
  // A repeating pattern of diamonds and bands in the accent colour over fibre noise.
  const double p = f.size_m;
  const double u = x / p, v = y / p;
  const double du = std::fabs(u - std::floor(u) - 0.5), dv = std::fabs(v - std::floor(v) - 0.5);
  const double diamond = std::clamp((0.32 - (du + dv)) / std::max(0.02, fp / p), 0.0, 1.0);
  const double band = std::clamp((0.04 - std::fabs(u - std::round(u))) / std::max(0.02, fp / p), 0.0, 1.0);
  const double pattern = std::max(diamond, band) * detail(p / 4, fp);
  const double fibre = 1.0 + f.variation * 2 * (2 * value_noise(x / 0.004, y / 0.004, 8) - 1) * detail(0.008, fp) +
                       0.04 * (2 * value_noise(x / 0.08, y / 0.08, 9) - 1);
  const Colour base = scaled(colour_of(f.colour), fibre);
  // Far away the pattern averages with the base (its area fraction, about a fifth).
  const double far = 0.2 * (1.0 - detail(p / 4, fp));
  return mix(base, scaled(colour_of(f.accent), fibre), pattern + far);
}

Colour plain(const FloorLook& f, double x, double y, double fp) {
  const double speck = 1.0 + f.variation * (2 * value_noise(x / 0.02, y / 0.02, 10) - 1) * detail(0.04, fp);
  return scaled(colour_of(f.colour), speck);
}

}  // namespace

Colour colour_of(uint32_t rgb) {
  return {static_cast<double>((rgb >> 16) & 0xff), static_cast<double>((rgb >> 8) & 0xff), static_cast<double>(rgb & 0xff)};
}

Colour floor_albedo(const FloorLook& floor, double x_m, double y_m, double footprint_m) {
  switch (floor.material) {
    case FloorLook::Material::kTiles: return tiles(floor, x_m, y_m, footprint_m);
    case FloorLook::Material::kPlanks: return planks(floor, x_m, y_m, footprint_m);
    case FloorLook::Material::kCarpet: return carpet(floor, x_m, y_m, footprint_m);
    default: return plain(floor, x_m, y_m, footprint_m);
  }
}

double slow_field(double x_m, double y_m) {
  return (value_noise(x_m / 1.5, y_m / 1.5, 11) + 0.5 * value_noise(x_m / 0.7, y_m / 0.7, 12)) / 0.75 - 1.0;
}

}  // namespace cart2d
