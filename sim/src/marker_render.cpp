#include "marker_render.hpp"

#include <cmath>

namespace cart2d {

namespace {

constexpr uint32_t kSurfaceMarker = 1u << 29;  // | marker index << 1 | white

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

bool read_vec(const json::Value& m, const char* key, Vec3* out) {
  const json::Value* v = m.find(key);
  if (!v || !v->is_array() || v->array.size() != 3) return false;
  double xyz[3];
  for (int k = 0; k < 3; ++k) {
    const json::Value& e = v->array[static_cast<size_t>(k)];
    if (!e.is_number() || !std::isfinite(e.number) || std::fabs(e.number) > 1e4) return false;
    xyz[k] = e.number;
  }
  *out = {xyz[0], xyz[1], xyz[2]};
  return true;
}

std::string parse_one(const json::Value& m, Marker* out) {
  if (!m.is_object()) return "each marker must be an object";
  const json::Value *id = m.find("id"), *size = m.find("size_m"), *cells = m.find("cells"), *bits = m.find("bits");
  if (!id || !id->is_number() || id->number < 0 || id->number > 1e6) return "a marker needs id (a number)";
  if (!size || !size->is_number() || !(size->number > 0.0 && size->number <= 10.0))
    return "a marker needs size_m in (0, 10]";
  if (!cells || !cells->is_number() || cells->number < 3 || cells->number > 64 ||
      cells->number != std::floor(cells->number))
    return "a marker needs cells, a whole number in [3, 64]";
  Marker mk;
  mk.id = static_cast<int>(id->number);
  mk.size_m = size->number;
  mk.cells = static_cast<int>(cells->number);
  if (!read_vec(m, "centre", &mk.centre) || !read_vec(m, "x_axis", &mk.ex) || !read_vec(m, "y_axis", &mk.ey))
    return "a marker needs centre, x_axis and y_axis, each [x, y, z] in m";
  const double nx = std::sqrt(dot(mk.ex, mk.ex)), ny = std::sqrt(dot(mk.ey, mk.ey));
  if (nx < 1e-9 || ny < 1e-9 || std::fabs(dot(mk.ex, mk.ey)) > 1e-6 * nx * ny)
    return "a marker's x_axis and y_axis must be perpendicular, not zero";
  mk.ex = {mk.ex.x / nx, mk.ex.y / nx, mk.ex.z / nx};
  mk.ey = {mk.ey.x / ny, mk.ey.y / ny, mk.ey.z / ny};
  mk.ez = cross(mk.ex, mk.ey);
  const size_t n = static_cast<size_t>(mk.cells) * static_cast<size_t>(mk.cells);
  if (!bits || !bits->is_string() || bits->string.size() != n)
    return "a marker needs bits, a string of cells × cells 0s and 1s";
  mk.white.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const char b = bits->string[i];
    if (b != '0' && b != '1') return "a marker's bits are 0s and 1s only";
    mk.white[i] = b == '1';
  }
  *out = mk;
  return "";
}

}  // namespace

std::string parse_markers(const json::Value& list, std::vector<Marker>* out) {
  if (!list.is_array()) return "markers must be an array (empty to remove them)";
  if (list.array.size() > 1000) return "at most 1000 markers";
  std::vector<Marker> markers;
  for (const json::Value& m : list.array) {
    Marker mk;
    if (std::string error = parse_one(m, &mk); !error.empty()) return error;
    markers.push_back(std::move(mk));
  }
  *out = std::move(markers);
  return "";
}

std::vector<const Marker*> markers_ahead(const std::vector<Marker>* markers, const Vec3& lens, double c, double s) {
  std::vector<const Marker*> out;
  if (!markers) return out;
  for (const Marker& m : *markers) {
    const Vec3 to{m.centre.x - lens.x, m.centre.y - lens.y, m.centre.z - lens.z};
    const double reach = m.size_m;  // the sheet's half-diagonal, with its margin, is below this
    if (to.x * c + to.y * s < -reach) continue;  // behind the lens
    if (dot(to, m.ez) > 0.0) continue;           // seen from behind
    out.push_back(&m);
  }
  return out;
}

bool hit_markers(const std::vector<const Marker*>& markers, const Vec3& o, const Vec3& d, uint32_t dark,
                 uint32_t light, double* best, uint32_t* colour_rgb, uint32_t* surface) {
  bool any = false;
  for (size_t k = 0; k < markers.size(); ++k) {
    const Marker& m = *markers[k];
    const double denom = dot(m.ez, d);
    if (denom > -1e-12) continue;  // parallel, or from behind
    const Vec3 to{m.centre.x - o.x, m.centre.y - o.y, m.centre.z - o.z};
    const double t = dot(m.ez, to) / denom;
    if (t <= 0.0 || t > *best * (1.0 + 1e-9)) continue;
    const Vec3 p{o.x + t * d.x - m.centre.x, o.y + t * d.y - m.centre.y, o.z + t * d.z - m.centre.z};
    // In cells from the bitmap's top-left corner: column along x, row down from the top (y up).
    const double cell = m.size_m / m.cells;
    const double col = dot(p, m.ex) / cell + m.cells / 2.0, row = m.cells / 2.0 - dot(p, m.ey) / cell;
    if (col < -1.0 || col >= m.cells + 1.0 || row < -1.0 || row >= m.cells + 1.0) continue;  // the margin is 1 cell
    bool white = true;
    if (col >= 0.0 && col < m.cells && row >= 0.0 && row < m.cells)
      white = m.white[static_cast<size_t>(row) * static_cast<size_t>(m.cells) + static_cast<size_t>(col)] != 0;
    *best = t;
    *colour_rgb = white ? light : dark;
    *surface = kSurfaceMarker | (static_cast<uint32_t>(k) << 1) | (white ? 1u : 0u);
    any = true;
  }
  return any;
}

}  // namespace cart2d
