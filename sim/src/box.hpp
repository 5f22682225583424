// Axis-aligned rectangles of the simulated world (walls and boxes) and the distances the contact
// model needs: a point's signed distance to a rectangle and its gradient, from which each cart
// feature's gap and its rate per unit (v, ω) follow (world.cpp).
//
// Signed distance of a point p to the rectangle [c − h, c + h] (Ericson, "Real-Time Collision
// Detection", 2005, §5.1.3, "closest point on an AABB", with the inside case added): with
// d = |p − c| − h per axis,
//   outside (some d > 0): dist = ‖max(d, 0)‖, gradient = sign(p − c)·max(d, 0) / dist
//                         (the face normal beside a face, the direction from the corner at a corner);
//   inside  (d ≤ 0):      dist = max(dx, dy) ≤ 0, gradient = the normal of the nearer face.
#pragma once

#include <cstdint>
#include <string>

namespace cart2d {

// What a rectangle is, for the contact statistics: the arena's walls (a boundary, a map's occupied
// cells) or a box standing on the floor.
enum class BoxKind : uint8_t { kWall, kBox };

struct Box {
  double cx_m = 0.0, cy_m = 0.0;  // centre
  double hx_m = 0.0, hy_m = 0.0;  // half the size along x and y (> 0)
  double height_m = 0.0;          // for the camera (issue 14); the physics is planar
  uint32_t colour_rgb = 0;        // 0xRRGGBB, for the camera
  bool wall_paint = false;        // drawn in the look's wall paint, skirting and all (a room's inner walls)
  BoxKind kind = BoxKind::kBox;
  std::string id;                 // the caller's name for it ("" if none)
  bool obstacle_twin = false;     // made physical from a virtual obstacle (removed with it)
  uint64_t serial = 0;            // unique within a World, kept across changes (contact tracking)
  bool solid = true;              // false while it overlaps the cart it appeared under
};

// A point on a rectangle's boundary as seen from a query point.
struct BoxDistance {
  double dist_m = 0.0;    // signed: < 0 inside
  double nx = 0.0, ny = 0.0;  // unit gradient of dist_m with respect to the query point
};

BoxDistance box_distance(const Box& b, double px_m, double py_m);

// True if the point is farther than reach_m from the rectangle along x or along y: then it is
// farther than reach_m, and box_distance need not be computed.
bool box_beyond(const Box& b, double px_m, double py_m, double reach_m);

// "#rrggbb" → 0xRRGGBB; false if malformed.
bool parse_colour(const std::string& text, uint32_t* rgb);
std::string colour_text(uint32_t rgb);

}  // namespace cart2d
