// Procedural surfaces for the camera (issue 24): the floor's tiles with grout, wood planks,
// patterned carpet; the walls' skirting boards; the slow unevenness of a room's light. Each is a
// function of the world point only (the same in every frame) and of the pixel's footprint on the
// floor, so that fine lines are averaged over a pixel as a sensor does instead of aliasing.
#pragma once

#include <cstdint>

#include "look.hpp"

namespace cart2d {

// Linear colour in 8-bit levels (may exceed 255 before the exposure).
struct Colour {
  double r = 0.0, g = 0.0, b = 0.0;
};

Colour colour_of(uint32_t rgb);

// The floor's colour at (x, y) for a pixel covering about footprint_m of floor.
Colour floor_albedo(const FloorLook& floor, double x_m, double y_m, double footprint_m);

// A smooth field in [-1, 1] over the floor with features about a metre and a half across (the
// uneven light of a room: windows, lamps out of view, reflections).
double slow_field(double x_m, double y_m);

}  // namespace cart2d
