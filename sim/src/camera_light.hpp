// The look's lights on the camera's picture (issue 24): each lamp lights the floor by the inverse
// square of its distance and the cosine of its angle (Lambert), plus the ambient light; every box,
// wall and the cart's own body cast a soft-edged shadow on the floor. A shadow is the convex hull
// of the caster's foot and of its top projected from the lamp onto the floor (exact for a point
// lamp and a box; the lamp's radius softens the edge in proportion to the caster's height).
// Built once per frame; then each floor pixel tests the casters whose shadow's bounds hold it.
#pragma once

#include <cstdint>
#include <vector>

#include "body.hpp"  // Pose
#include "box.hpp"
#include "camera_model.hpp"  // Vec3
#include "look.hpp"

namespace cart2d {

class Lighting {
 public:
  // The world's boxes and walls and the cart (a disc of cart_radius_m at `cart`) as casters.
  Lighting(const Look& look, const std::vector<Box>& boxes, const Pose& cart, double cart_radius_m);

  // Light on the floor at (x, y), 1 = a lamp of power 1 straight overhead; *shadow_bits: bit k set
  // when lamp k's shadow covers the point more than half (an edge for anti-aliasing).
  double floor(double x_m, double y_m, uint32_t* shadow_bits) const;
  // Light on a surface at p facing n (a unit normal): lamps by Lambert, no cast shadows.
  double surface(const Vec3& p, const Vec3& n) const;
  // How much the lamps' own images add where a glossy floor at p mirrors the view ray d (unit).
  double highlight(const Vec3& p, const Vec3& d, double gloss) const;

 private:
  struct Shadow {
    double x0, y0, x1, y1;  // bounds, widened by half the soft edge
    double soft_m;
    std::vector<double> hull;   // x, y pairs, counter-clockwise
    std::vector<double> edges;  // per edge: a point (x, y) and the outward unit normal (nx, ny)
  };
  double uneven(double x_m, double y_m) const;
  void add_caster(size_t light, const double* foot_xy, size_t corners, double height_m);

  const Look& look_;
  std::vector<std::vector<Shadow>> shadows_;  // per lamp
};

}  // namespace cart2d
