#include "box_grid.hpp"

#include <algorithm>  // std::min, std::max, std::fill
#include <cmath>      // std::floor, std::ceil, std::sqrt

namespace cart2d {

void BoxGrid::cell_range(const Aabb& a, int* i0, int* j0, int* i1, int* j1) const {
  auto clamp_index = [](double v, int n) {
    if (!(v > 0.0)) return 0;  // NaN-safe
    if (v >= n - 1) return n - 1;
    return static_cast<int>(v);
  };
  *i0 = clamp_index(std::floor((a.x0 - ox_) / cell_m_), nx_);
  *i1 = clamp_index(std::floor((a.x1 - ox_) / cell_m_), nx_);
  *j0 = clamp_index(std::floor((a.y0 - oy_) / cell_m_), ny_);
  *j1 = clamp_index(std::floor((a.y1 - oy_) / cell_m_), ny_);
}

void BoxGrid::build(const std::vector<Aabb>& items) {
  start_.clear();
  items_.clear();
  large_.clear();
  stamp_.assign(items.size(), 0);
  epoch_ = 0;
  nx_ = ny_ = 0;
  if (items.empty()) return;
  double x0 = items[0].x0, y0 = items[0].y0, x1 = items[0].x1, y1 = items[0].y1;
  for (const Aabb& a : items) {
    x0 = std::min(x0, a.x0);
    y0 = std::min(y0, a.y0);
    x1 = std::max(x1, a.x1);
    y1 = std::max(y1, a.y1);
  }
  cell_m_ = kCellM;
  const double area_cells = (x1 - x0) * (y1 - y0) / (cell_m_ * cell_m_);
  if (area_cells > static_cast<double>(kMaxCells)) cell_m_ *= std::sqrt(area_cells / static_cast<double>(kMaxCells)) * 1.01;
  ox_ = x0;
  oy_ = y0;
  nx_ = std::max(1, static_cast<int>(std::ceil((x1 - x0) / cell_m_)));
  ny_ = std::max(1, static_cast<int>(std::ceil((y1 - y0) / cell_m_)));

  // Two passes: count per cell, then fill (counting sort into one array).
  std::vector<uint32_t> count(cells() + 1, 0);
  std::vector<char> is_large(items.size(), 0);
  for (size_t k = 0; k < items.size(); ++k) {
    int i0, j0, i1, j1;
    cell_range(items[k], &i0, &j0, &i1, &j1);
    if (static_cast<int64_t>(i1 - i0 + 1) * (j1 - j0 + 1) > kMaxCellsPerItem) {
      is_large[k] = 1;
      large_.push_back(static_cast<uint32_t>(k));
      continue;
    }
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) ++count[static_cast<size_t>(j) * nx_ + i];
  }
  start_.assign(cells() + 1, 0);
  for (size_t c = 0; c < cells(); ++c) start_[c + 1] = start_[c] + count[c];
  items_.resize(start_[cells()]);
  std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
  for (size_t k = 0; k < items.size(); ++k) {
    if (is_large[k]) continue;
    int i0, j0, i1, j1;
    cell_range(items[k], &i0, &j0, &i1, &j1);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) items_[fill[static_cast<size_t>(j) * nx_ + i]++] = static_cast<uint32_t>(k);
  }
}

void BoxGrid::query(const Aabb& q, std::vector<uint32_t>* out) const {
  if (nx_ == 0) return;
  if (++epoch_ == 0) {  // wrapped: forget every stamp
    std::fill(stamp_.begin(), stamp_.end(), 0);
    epoch_ = 1;
  }
  for (uint32_t k : large_) {
    stamp_[k] = epoch_;
    out->push_back(k);
  }
  int i0, j0, i1, j1;
  cell_range(q, &i0, &j0, &i1, &j1);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const size_t c = static_cast<size_t>(j) * nx_ + i;
      for (uint32_t e = start_[c]; e < start_[c + 1]; ++e) {
        const uint32_t k = items_[e];
        if (stamp_[k] == epoch_) continue;
        stamp_[k] = epoch_;
        out->push_back(k);
      }
    }
  }
}

}  // namespace cart2d
