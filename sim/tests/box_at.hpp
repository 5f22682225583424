// A box for the tests: centre and size in metres, as a mission's "world" gives them.
#pragma once

#include <string>

#include "box.hpp"

namespace cart2d {

inline Box box_at(double cx, double cy, double sx, double sy, const std::string& id = "") {
  Box b;
  b.cx_m = cx;
  b.cy_m = cy;
  b.hx_m = sx / 2;
  b.hy_m = sy / 2;
  b.id = id;
  return b;
}

}  // namespace cart2d
