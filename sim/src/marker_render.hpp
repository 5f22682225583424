// Fiducial markers (AprilTag 36h11, docs/localisation.md) in the camera's picture: flat printed
// squares on a wall or the floor, each cell black or white as the gateway's OpenCV drew it
// (cv2.aruco.generateImageMarker), with a one-cell white margin around the black border.
// camera_render.cpp casts each ray against them (hit_markers) after the world's boxes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "camera_model.hpp"  // Vec3
#include "json.hpp"

namespace cart2d {

struct Marker {
  int id = 0;
  Vec3 centre;          // the black square's centre in the world
  Vec3 ex, ey, ez;      // the marker's x (right), y (up, towards row 0) and normal (out of the paper)
  double size_m = 0.1;  // the black square's side
  int cells = 8;        // cells per side of the bitmap (black border included)
  std::vector<uint8_t> white;  // cells × cells, row 0 the top, 1 white
};

// {"markers":[{"id","size_m","centre":[x,y,z],"x_axis":[..],"y_axis":[..],"cells":N,"bits":"0110.."}]}
// into *out (all or nothing); "" or why not.
std::string parse_markers(const json::Value& list, std::vector<Marker>* out);

// The markers whose sheet faces the lens and lies ahead of it (per frame: few rays need testing).
std::vector<const Marker*> markers_ahead(const std::vector<Marker>* markers, const Vec3& lens, double c, double s);

// If the ray o + t·d meets a marker's sheet no farther than *best (a tie with the wall or floor it
// lies on goes to the marker), sets *best, the cell's colour (dark or light) and a surface id; true if so.
bool hit_markers(const std::vector<const Marker*>& markers, const Vec3& o, const Vec3& d, uint32_t dark,
                 uint32_t light, double* best, uint32_t* colour_rgb, uint32_t* surface);

}  // namespace cart2d
