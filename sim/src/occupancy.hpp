// An occupancy grid's occupied cells as the few rectangles a contact model can use: decoding the
// side channel's encodings (run lengths, a base64 bitmap) and merging cells into rectangles.
//
// Cells are stored row-major from the grid's origin, as in ROS's nav_msgs/OccupancyGrid: cell
// (i, j) is column i (along x) of row j (along y), index i + j·width, row 0 at the lowest y.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cart2d {

struct OccupancyGrid {
  int width = 0, height = 0;  // cells along x, along y
  std::vector<uint8_t> occupied;  // width·height, 1 = occupied
};

// A rectangle of cells: columns [i, i + w), rows [j, j + h).
struct CellRect {
  int i = 0, j = 0, w = 0, h = 0;
};

// Runs alternately free and occupied, starting with free (a leading 0 when the first cell is
// occupied), summing to width·height. False with a reason on malformed input.
bool decode_runs(const std::vector<double>& runs, OccupancyGrid* grid, std::string* error);
// ceil(width·height / 8) bytes in base64 (RFC 4648 §4, padding optional); cell k is bit k mod 8
// (least significant first) of byte k / 8. False with a reason on malformed input.
bool decode_bitmap(const std::string& base64, OccupancyGrid* grid, std::string* error);

// Covers exactly the occupied cells with disjoint rectangles, greedily: in row-major order, each
// cell not yet covered starts a rectangle that grows along its row as far as the cells are
// occupied and uncovered, then row by row upwards while the whole span is. A wall drawn as a
// line of cells becomes one rectangle; a room's outline four.
std::vector<CellRect> merge_cells(const OccupancyGrid& grid);

}  // namespace cart2d
