#include "occupancy.hpp"

#include <cmath>  // std::floor

namespace cart2d {

static size_t cell_count(const OccupancyGrid& g) {
  return static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
}

bool decode_runs(const std::vector<double>& runs, OccupancyGrid* grid, std::string* error) {
  const size_t n = cell_count(*grid);
  grid->occupied.assign(n, 0);
  size_t at = 0;
  for (size_t k = 0; k < runs.size(); ++k) {
    const double r = runs[k];
    if (!(r >= 0.0) || r != std::floor(r) || r > static_cast<double>(n - at)) {
      *error = "run " + std::to_string(k) + " is not a whole number of cells within the grid";
      return false;
    }
    const size_t len = static_cast<size_t>(r);
    if (k % 2 == 1)
      for (size_t c = at; c < at + len; ++c) grid->occupied[c] = 1;
    at += len;
  }
  if (at != n) {
    *error = "the runs cover " + std::to_string(at) + " cells, the grid has " + std::to_string(n);
    return false;
  }
  return true;
}

static int base64_value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

bool decode_bitmap(const std::string& base64, OccupancyGrid* grid, std::string* error) {
  std::string text = base64;
  while (!text.empty() && text.back() == '=') text.pop_back();
  std::vector<uint8_t> bytes;
  bytes.reserve(text.size() * 3 / 4);
  uint32_t acc = 0;
  int bits = 0;
  for (char c : text) {
    const int v = base64_value(c);
    if (v < 0) {
      *error = "bits: not base64";
      return false;
    }
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bytes.push_back(static_cast<uint8_t>(acc >> bits));
      acc &= (1u << bits) - 1;
    }
  }
  const size_t n = cell_count(*grid);
  if (bytes.size() != (n + 7) / 8) {
    *error = "bits: " + std::to_string(bytes.size()) + " bytes, the grid needs " + std::to_string((n + 7) / 8);
    return false;
  }
  grid->occupied.assign(n, 0);
  for (size_t c = 0; c < n; ++c) grid->occupied[c] = (bytes[c / 8] >> (c % 8)) & 1u;
  return true;
}

std::vector<CellRect> merge_cells(const OccupancyGrid& grid) {
  const int w = grid.width, h = grid.height;
  std::vector<uint8_t> covered(cell_count(grid), 0);
  auto free_cell = [&](int i, int j) {
    const size_t c = static_cast<size_t>(j) * w + i;
    return grid.occupied[c] && !covered[c];
  };
  std::vector<CellRect> out;
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      if (!free_cell(i, j)) continue;
      int i1 = i + 1;
      while (i1 < w && free_cell(i1, j)) ++i1;
      int j1 = j + 1;
      for (; j1 < h; ++j1) {
        bool whole = true;
        for (int k = i; k < i1 && whole; ++k) whole = free_cell(k, j1);
        if (!whole) break;
      }
      for (int jj = j; jj < j1; ++jj)
        for (int k = i; k < i1; ++k) covered[static_cast<size_t>(jj) * w + k] = 1;
      out.push_back({i, j, i1 - i, j1 - j});
      i = i1 - 1;
    }
  }
  return out;
}

}  // namespace cart2d
