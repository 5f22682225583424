#include "box.hpp"

#include <algorithm>  // std::max
#include <cmath>      // std::fabs, std::hypot
#include <cstdio>     // std::snprintf

namespace cart2d {

BoxDistance box_distance(const Box& b, double px_m, double py_m) {
  const double rx = px_m - b.cx_m, ry = py_m - b.cy_m;
  const double sx = rx >= 0.0 ? 1.0 : -1.0, sy = ry >= 0.0 ? 1.0 : -1.0;
  const double dx = std::fabs(rx) - b.hx_m, dy = std::fabs(ry) - b.hy_m;
  BoxDistance out;
  if (dx > 0.0 || dy > 0.0) {
    const double ox = std::max(dx, 0.0), oy = std::max(dy, 0.0);
    out.dist_m = std::hypot(ox, oy);
    out.nx = sx * ox / out.dist_m;
    out.ny = sy * oy / out.dist_m;
  } else if (dx > dy) {
    out.dist_m = dx;
    out.nx = sx;
  } else {
    out.dist_m = dy;
    out.ny = sy;
  }
  return out;
}

bool box_beyond(const Box& b, double px_m, double py_m, double reach_m) {
  return std::fabs(px_m - b.cx_m) - b.hx_m > reach_m || std::fabs(py_m - b.cy_m) - b.hy_m > reach_m;
}

bool parse_colour(const std::string& text, uint32_t* rgb) {
  if (text.size() != 7 || text[0] != '#') return false;
  uint32_t v = 0;
  for (size_t i = 1; i < 7; ++i) {
    const char c = text[i];
    int d = -1;
    if (c >= '0' && c <= '9') d = c - '0';
    else if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
    if (d < 0) return false;
    v = v * 16 + static_cast<uint32_t>(d);
  }
  *rgb = v;
  return true;
}

std::string colour_text(uint32_t rgb) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%06x", static_cast<unsigned>(rgb & 0xFFFFFFu));
  return buf;
}

}  // namespace cart2d
