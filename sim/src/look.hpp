// How the world looks to the camera (issue 24): the floor's material, the walls' paint and
// skirting boards, the lights, and what the camera itself does to the picture (vignetting, uneven
// light, auto-exposure, motion blur, the OV2640's noise). A world message's "look" (sim/README.md,
// "The look"); without one every member keeps its default, which draws today's picture: a grey
// floor with a faint 2 cm texture, boxes shaded by a fixed light from above, no effects.
// Plain data: the physics never reads it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "json.hpp"

namespace cart2d {

struct FloorLook {
  // kDefault: today's grey floor (CameraRenderer::kFloorColour); the others are procedural.
  enum class Material : uint8_t { kDefault, kPlain, kTiles, kPlanks, kCarpet };
  Material material = Material::kDefault;
  uint32_t colour = 0xa8a8a8;  // the tiles', planks' or carpet's base colour
  uint32_t accent = 0x808080;  // grout, the seams between planks, the carpet's pattern
  double size_m = 0.3;         // a tile's side, a plank's width, the carpet pattern's period
  double length_m = 1.2;       // a plank's length
  double line_m = 0.004;       // grout or seam width
  double variation = 0.06;     // each tile or plank's brightness differs by up to ± this
  double gloss = 0.0;          // 0 matt ... 1 mirror: reflects walls, boxes and lights
};

struct WallLook {
  bool painted = false;          // false: each wall its own colour (World::kWallColour by default)
  uint32_t colour = 0xd8d8d8;
  double skirting_m = 0.0;       // a skirting board this high along the foot of every wall
  uint32_t skirting_colour = 0xffffff;
};

// A lamp: a point of light with a radius (soft shadow edges), at (x, y, z) in the world.
struct LightLook {
  double x_m = 0.0, y_m = 0.0, z_m = 2.4;
  double power = 0.7;   // brightness straight under it, at its height (a fraction of full white)
  double radius_m = 0.1;
};

struct CameraLook {
  double vignetting = 0.0;      // corners darker by this fraction (cos⁴-like fall-off)
  double uneven = 0.0;          // ± this fraction of slow light variation across the room
  bool auto_exposure = false;   // the gain follows the picture's mean towards ae_target...
  double ae_target = 110.0;     // ...8-bit levels
  double ae_rate = 0.3;         // the fraction of the way it moves per frame (it lags the view)
  double shutter_ms = 0.0;      // exposure time: motion blur from the cart's motion while open
  bool sensor_noise = false;    // the OV2640's: shot noise, row banding, more in red and blue
};

struct Look {
  FloorLook floor;
  WallLook walls;
  std::vector<LightLook> lights;  // none: today's fixed shading, no shadows
  double ambient = 0.45;          // light that reaches everywhere (with lights)
  double cart_height_m = 0.3;     // the cart's body, for its own shadow
  uint32_t ceiling = 0x4f5d6b;    // what a glossy floor reflects where no wall is
  CameraLook camera;

  bool lit() const { return !lights.empty(); }
};

// A world message's "look" object into *out (defaults for whatever it leaves out); "" or why not.
std::string parse_look(const json::Value& v, Look* out);

}  // namespace cart2d
