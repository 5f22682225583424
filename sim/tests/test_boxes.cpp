// Boxes and map walls: the point–rectangle distance, the cart's probes against rectangles (gaps and
// their rates, by hand and by finite differences), the broad phase against brute force, and the
// occupancy grid's decoding and merging.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "box_at.hpp"
#include "box_grid.hpp"
#include "occupancy.hpp"
#include "rng.hpp"
#include "world.hpp"

namespace cart2d {
namespace {

TEST(BoxDistance, HandComputedCases) {
  const Box b = box_at(1.0, 1.0, 1.0, 0.5);  // x in [0.5, 1.5], y in [0.75, 1.25]
  BoxDistance d = box_distance(b, 2.0, 1.1);  // beside the east face
  EXPECT_NEAR(d.dist_m, 0.5, 1e-15);
  EXPECT_EQ(d.nx, 1.0);
  EXPECT_EQ(d.ny, 0.0);
  d = box_distance(b, 2.0, 2.0);  // beyond the north-east corner (1.5, 1.25): (0.5, 0.75) away
  EXPECT_NEAR(d.dist_m, std::sqrt(0.25 + 0.5625), 1e-15);
  EXPECT_NEAR(d.nx, 0.5 / std::sqrt(0.8125), 1e-15);
  EXPECT_NEAR(d.ny, 0.75 / std::sqrt(0.8125), 1e-15);
  d = box_distance(b, 0.2, 0.5);  // beyond the south-west corner (0.5, 0.75): (−0.3, −0.25)
  EXPECT_NEAR(d.dist_m, std::hypot(0.3, 0.25), 1e-15);
  EXPECT_NEAR(d.nx, -0.3 / std::hypot(0.3, 0.25), 1e-15);
  EXPECT_NEAR(d.ny, -0.25 / std::hypot(0.3, 0.25), 1e-15);
  d = box_distance(b, 1.4, 1.0);  // inside, 0.1 from the east face, 0.25 from north and south
  EXPECT_NEAR(d.dist_m, -0.1, 1e-15);
  EXPECT_EQ(d.nx, 1.0);
  d = box_distance(b, 1.0, 0.8);  // inside, 0.05 from the south face
  EXPECT_NEAR(d.dist_m, -0.05, 1e-15);
  EXPECT_EQ(d.nx, 0.0);
  EXPECT_EQ(d.ny, -1.0);
}

TEST(BoxDistance, GradientAgreesWithFiniteDifferences) {
  const Box b = box_at(-0.3, 0.7, 0.4, 1.2);
  Rng rng(7);
  const double h = 1e-7;
  for (int k = 0; k < 2000; ++k) {
    const double x = -1.5 + 2.4 * rng.uniform(), y = -0.5 + 2.4 * rng.uniform();
    const BoxDistance d = box_distance(b, x, y);
    // Away from the ridges inside (where the nearest face changes) the distance is smooth.
    const double dx = std::fabs(x - b.cx_m) - b.hx_m, dy = std::fabs(y - b.cy_m) - b.hy_m;
    if (dx < 0 && dy < 0 && std::fabs(dx - dy) < 1e-5) continue;
    if (std::fabs(x - b.cx_m) < 1e-5 || std::fabs(y - b.cy_m) < 1e-5) continue;
    EXPECT_NEAR((box_distance(b, x + h, y).dist_m - d.dist_m) / h, d.nx, 1e-5);
    EXPECT_NEAR((box_distance(b, x, y + h).dist_m - d.dist_m) / h, d.ny, 1e-5);
  }
}

// A cart at the origin heading +x; a box ahead. Gaps and rates by hand.
TEST(BoxProbes, DiscAndSwitchesAgainstAFaceByHand) {
  World w;
  w.add(box_at(0.5, 0.0, 0.2, 1.0));  // west face at x = 0.4
  const RobotGeometry g{0.17, 0.17, 0.10};  // r, bumper, switches (robot.toml's, exact in double)
  std::vector<ContactProbe> probes;
  w.probes({0.0, 0.0, 0.0}, g, &probes, 1.0);
  ASSERT_EQ(probes.size(), 3u);  // the box's corners are beside the bumper: no bumper probe
  for (const ContactProbe& p : probes) {
    EXPECT_NEAR(p.gap_m, p.feature == ContactProbe::kDisc ? 0.4 - 0.17 : 0.4 - 0.17, 1e-15);
    EXPECT_NEAR(p.jv, -1.0, 1e-15);  // closing at v
  }
  // The left switch's rate under a turn: its point (0.17, 0.1) moves at ω·(−0.1, 0.17); the gap
  // to the west face (normal −x) closes at −(−0.1)·ω = +0.1·ω.
  for (const ContactProbe& p : probes) {
    if (p.feature == ContactProbe::kSwitchLeft) {
      EXPECT_NEAR(p.jw, 0.1, 1e-15);
    }
    if (p.feature == ContactProbe::kSwitchRight) {
      EXPECT_NEAR(p.jw, -0.1, 1e-15);
    }
    if (p.feature == ContactProbe::kDisc) {
      EXPECT_EQ(p.jw, 0.0);
    }
  }
}

TEST(BoxProbes, BumperAgainstACornerByHand) {
  World w;
  // A box whose south-west corner is at (0.2, 0.05): ahead of the bumper, between the switches.
  w.add(box_at(0.45, 0.3, 0.5, 0.5));
  const RobotGeometry g{0.17, 0.17, 0.10};
  std::vector<ContactProbe> probes;
  w.probes({0.0, 0.0, 0.0}, g, &probes, 1.0);
  const auto bumper = std::find_if(probes.begin(), probes.end(),
                                   [](const ContactProbe& p) { return p.feature == ContactProbe::kBumper; });
  ASSERT_NE(bumper, probes.end());
  EXPECT_NEAR(bumper->gap_m, 0.2 - 0.17, 1e-15);
  EXPECT_EQ(bumper->jv, -1.0);
  EXPECT_NEAR(bumper->jw, 0.05, 1e-15);  // d/dt x_b = −v + ω·y_b
  EXPECT_NEAR(bumper->lateral_m, 0.05, 1e-15);
  // The left switch at (0.17, 0.1) is 0.03 from the west face x = 0.2; the disc's nearest point of
  // the box is its corner, hypot(0.2, 0.05) − 0.17 away.
  for (const ContactProbe& p : probes) {
    if (p.feature == ContactProbe::kSwitchLeft) {
      EXPECT_NEAR(p.gap_m, 0.03, 1e-15);
    }
    if (p.feature == ContactProbe::kDisc) {
      EXPECT_NEAR(p.gap_m, std::hypot(0.2, 0.05) - 0.17, 1e-15);
    }
  }
}

// Every probe's (jv, jw) against finite differences of its gap, over many poses near boxes.
TEST(BoxProbes, RatesAgreeWithFiniteDifferences) {
  World w;
  w.add(box_at(1.0, 1.0, 0.3, 0.2));
  w.add(box_at(1.5, 0.6, 0.05, 0.8));
  const RobotGeometry g;
  Rng rng(11);
  const double d = 1e-7;
  int checked = 0;
  for (int k = 0; k < 400; ++k) {
    const Pose p{0.4 + 1.6 * rng.uniform(), 0.2 + 1.4 * rng.uniform(), -3.1 + 6.2 * rng.uniform()};
    std::vector<ContactProbe> base, moved;
    w.probes(p, g, &base, 0.3);
    for (int turn = 0; turn < 2; ++turn) {
      const Pose q = turn ? Pose{p.x_m, p.y_m, p.theta_rad + d}
                          : Pose{p.x_m + d * std::cos(p.theta_rad), p.y_m + d * std::sin(p.theta_rad), p.theta_rad};
      w.probes(q, g, &moved, 0.3);
      for (const ContactProbe& a : base) {
        for (const ContactProbe& b : moved) {
          if (a.feature != b.feature || a.box != b.box || std::fabs(a.lateral_m - b.lateral_m) > 1e-5 ||
              std::fabs(a.gap_m - b.gap_m) > 1e-4)
            continue;
          const double rate = (b.gap_m - a.gap_m) / d;
          EXPECT_NEAR(rate, turn ? a.jw : a.jv, 1e-5) << "feature " << a.feature << " at " << p.x_m << ", " << p.y_m;
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 200);
}

TEST(BoxProbes, FootprintGapAndOverlap) {
  World w;
  w.add(box_at(1.0, 0.0, 0.2, 0.2, "crate"));  // west face at x = 0.9
  const RobotGeometry g{0.17, 0.17, 0.10};
  EXPECT_NEAR(w.footprint_gap_m({0.5, 0.0, 0.0}, g, w.boxes()[0]), 0.9 - 0.5 - 0.17, 1e-15);
  EXPECT_EQ(w.overlapping({0.731, 0.0, 0.0}, g), 0);  // the bumper 1 mm inside
  EXPECT_EQ(w.overlapping({0.73, 0.0, 0.0}, g), -1);  // touching is not overlapping
  EXPECT_EQ(w.overlapping({0.72, 0.0, 0.0}, g), -1);
  // Behind it, facing away: the disc alone reaches it (east face at 1.1).
  EXPECT_EQ(w.overlapping({1.27, 0.0, 0.0}, g), -1);
  EXPECT_EQ(w.overlapping({1.26, 0.0, 0.0}, g), 0);
  // Passing its corner (0.9, −0.1): the bumper's end (the left switch at 0.197 m) reaches where the
  // disc does not (0.184 m from the centre to the corner).
  EXPECT_GT(box_distance(w.boxes()[0], 0.74, -0.19).dist_m, g.footprint_radius_m);
  EXPECT_EQ(w.overlapping({0.74, -0.19, 0.0}, g), 0);
  EXPECT_EQ(w.overlapping({0.74, -0.30, 0.0}, g), -1);
}

// -- broad phase -------------------------------------------------------------------------------

TEST(BoxGrid, QueriesFindWhatBruteForceFinds) {
  Rng rng(3);
  std::vector<Aabb> items;
  for (int k = 0; k < 3000; ++k) {
    const double x = 40 * rng.uniform(), y = 30 * rng.uniform(), sx = 0.05 + 0.6 * rng.uniform(),
                 sy = 0.05 + 0.6 * rng.uniform();
    items.push_back({x, y, x + sx, y + sy});
  }
  items.push_back({-1, -1, 41, 0});  // a long wall: on the list every query visits
  BoxGrid grid;
  grid.build(items);
  for (int q = 0; q < 500; ++q) {
    const double x = -2 + 44 * rng.uniform(), y = -2 + 34 * rng.uniform();
    const Aabb box{x - 0.25, y - 0.25, x + 0.25, y + 0.25};
    std::vector<uint32_t> found;
    grid.query(box, &found);
    std::set<uint32_t> unique(found.begin(), found.end());
    EXPECT_EQ(unique.size(), found.size()) << "reported twice";
    for (size_t k = 0; k < items.size(); ++k) {
      const Aabb& a = items[k];
      const bool overlaps = a.x0 <= box.x1 && a.x1 >= box.x0 && a.y0 <= box.y1 && a.y1 >= box.y0;
      if (overlaps) {
        EXPECT_TRUE(unique.count(static_cast<uint32_t>(k))) << "missed item " << k;
      }
    }
  }
}

// Thousands of boxes: a probe tests only those near the cart, and finds every one within reach.
TEST(BoxGrid, ProbesVisitOnlyNearbyBoxesAmongThousands) {
  World w(ArenaParams{0.2, 101, 0.25});  // a 20 m square
  Rng rng(5);
  for (int k = 0; k < 5000; ++k) w.add(box_at(20 * rng.uniform(), 20 * rng.uniform(), 0.1, 0.1));
  const RobotGeometry g;
  std::vector<ContactProbe> probes;
  size_t most = 0;
  for (int q = 0; q < 2000; ++q) {
    const Pose p{20 * rng.uniform(), 20 * rng.uniform(), 6.28 * rng.uniform()};
    w.probes(p, g, &probes);
    most = std::max(most, w.last_candidates());
    std::set<uint32_t> probed;
    for (const ContactProbe& c : probes) probed.insert(c.box);
    for (size_t k = 0; k < w.boxes().size(); ++k) {
      const double gap = w.footprint_gap_m(p, g, w.boxes()[k]);
      if (gap <= 0.02) {
        EXPECT_TRUE(probed.count(static_cast<uint32_t>(k))) << "box " << k << " gap " << gap;
      }
    }
  }
  EXPECT_LT(most, 40u);  // ~12.5 boxes per m², a query square of 0.5 m and the four walls
}

// -- occupancy grids ---------------------------------------------------------------------------

TEST(Occupancy, RunsAndBitmapDecodeTheSameCells) {
  OccupancyGrid a{4, 3, {}}, b{4, 3, {}};
  std::string error;
  // Row 0: . # # .   row 1: . . . #   row 2: # # # #
  ASSERT_TRUE(decode_runs({1, 2, 4, 5}, &a, &error)) << error;
  // Bits LSB first: cells 0-7 = 0,1,1,0,0,0,0,1 → 0b10000110 = 0x86; cells 8-11 = 1,1,1,1 → 0x0F.
  ASSERT_TRUE(decode_bitmap("hg8=", &b, &error)) << error;
  const std::vector<uint8_t> expected = {0, 1, 1, 0, 0, 0, 0, 1, 1, 1, 1, 1};
  EXPECT_EQ(a.occupied, expected);
  EXPECT_EQ(b.occupied, expected);
  ASSERT_TRUE(decode_bitmap("hg8", &b, &error)) << error;  // padding optional
  EXPECT_EQ(b.occupied, expected);
}

TEST(Occupancy, MalformedEncodingsAreRefused) {
  OccupancyGrid g{4, 3, {}};
  std::string error;
  EXPECT_FALSE(decode_runs({1, 2, 4}, &g, &error));  // 7 of 12 cells
  EXPECT_NE(error.find("cover 7 cells"), std::string::npos) << error;
  EXPECT_FALSE(decode_runs({1, 2, 4, 6}, &g, &error));  // 13
  EXPECT_FALSE(decode_runs({1.5, 10.5}, &g, &error));
  EXPECT_FALSE(decode_runs({-1, 13}, &g, &error));
  EXPECT_FALSE(decode_bitmap("hg8*", &g, &error));
  EXPECT_FALSE(decode_bitmap("hg8PAA==", &g, &error));  // 4 bytes for 12 cells
}

TEST(Occupancy, MergedRectanglesCoverExactlyTheOccupiedCells) {
  Rng rng(9);
  for (int trial = 0; trial < 50; ++trial) {
    OccupancyGrid g{1 + static_cast<int>(rng.uniform() * 40), 1 + static_cast<int>(rng.uniform() * 40), {}};
    const double density = rng.uniform();
    g.occupied.resize(static_cast<size_t>(g.width) * g.height);
    for (auto& c : g.occupied) c = rng.uniform() < density;
    std::vector<int> cover(g.occupied.size(), 0);
    for (const CellRect& r : merge_cells(g))
      for (int j = r.j; j < r.j + r.h; ++j)
        for (int i = r.i; i < r.i + r.w; ++i) ++cover[static_cast<size_t>(j) * g.width + i];
    for (size_t c = 0; c < cover.size(); ++c) ASSERT_EQ(cover[c], g.occupied[c] ? 1 : 0) << "cell " << c;
  }
}

TEST(Occupancy, ALineIsOneRectangleAndARoomFour) {
  OccupancyGrid line{10, 3, std::vector<uint8_t>(30, 0)};
  for (int i = 0; i < 10; ++i) line.occupied[10 + i] = 1;
  ASSERT_EQ(merge_cells(line).size(), 1u);
  EXPECT_EQ(merge_cells(line)[0].w, 10);
  OccupancyGrid room{8, 6, std::vector<uint8_t>(48, 0)};
  for (int i = 0; i < 8; ++i) room.occupied[i] = room.occupied[40 + i] = 1;
  for (int j = 0; j < 6; ++j) room.occupied[j * 8] = room.occupied[j * 8 + 7] = 1;
  EXPECT_EQ(merge_cells(room).size(), 4u);
}

TEST(Occupancy, WallGridPlacesCellsFromTheOrigin) {
  OccupancyGrid g{4, 2, {0, 0, 0, 1, 0, 0, 0, 0}};  // cell (3, 0)
  World w;
  w.add_wall_grid(-1.0, 2.0, 0.05, g);
  ASSERT_EQ(w.boxes().size(), 1u);
  const Box& b = w.boxes()[0];
  EXPECT_NEAR(b.cx_m, -1.0 + 3.5 * 0.05, 1e-15);
  EXPECT_NEAR(b.cy_m, 2.0 + 0.5 * 0.05, 1e-15);
  EXPECT_NEAR(b.hx_m, 0.025, 1e-15);
  EXPECT_EQ(b.kind, BoxKind::kWall);
}

}  // namespace
}  // namespace cart2d
