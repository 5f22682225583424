// The broad phase: a uniform grid of square cells over the world, each listing the rectangles
// that overlap it, so that a query near the cart visits a handful of rectangles whatever their
// number (Ericson, "Real-Time Collision Detection", 2005, §7.1, uniform grids; the cells stored
// in one array with per-cell offsets, "compressed sparse row", as in §7.1.3's static grids).
//
// Rectangles that would cover more than kMaxCellsPerItem cells (an arena's boundary, a huge
// floor) are kept on a short list that every query visits instead.
#pragma once

#include <cstddef>  // size_t
#include <cstdint>
#include <vector>

namespace cart2d {

struct Aabb {
  double x0, y0, x1, y1;  // x0 ≤ x1, y0 ≤ y1 (m)
};

class BoxGrid {
 public:
  static constexpr double kCellM = 0.5;              // cell side, unless the world is too large
  static constexpr int64_t kMaxCells = 1 << 20;      // cells in all (the side grows instead)
  static constexpr int64_t kMaxCellsPerItem = 256;   // larger items go on the always-visited list

  // Rebuilds the grid for these items (their indices are what queries report).
  void build(const std::vector<Aabb>& items);
  // Appends to *out, once each, the index of every item whose cells overlap the query box.
  void query(const Aabb& q, std::vector<uint32_t>* out) const;
  size_t cells() const { return static_cast<size_t>(nx_) * static_cast<size_t>(ny_); }
  double cell_m() const { return cell_m_; }

 private:
  void cell_range(const Aabb& a, int* i0, int* j0, int* i1, int* j1) const;

  double ox_ = 0.0, oy_ = 0.0, cell_m_ = kCellM;
  int nx_ = 0, ny_ = 0;
  std::vector<uint32_t> start_;  // per cell: first entry in items_ (one more at the end)
  std::vector<uint32_t> items_;
  std::vector<uint32_t> large_;  // visited by every query
  mutable std::vector<uint32_t> stamp_;  // per item: the query that last reported it
  mutable uint32_t epoch_ = 0;
};

}  // namespace cart2d
