#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "world.hpp"

namespace cart2d {
namespace {

TEST(World, WallsLieTheMarginOutsideTheGrid) {
  World w(ArenaParams{0.2, 10, 0.25});
  EXPECT_DOUBLE_EQ(w.arena().x_min(), -0.25);
  EXPECT_NEAR(w.arena().x_max(), 2.05, 1e-12);
  EXPECT_NEAR(w.arena().y_max(), 2.05, 1e-12);
  ASSERT_EQ(w.count(BoxKind::kWall), 4u);
  EXPECT_EQ(w.count(BoxKind::kBox), 0u);
  // Each wall's inner face is where the arena says.
  double west = 1e9, east = -1e9, south = 1e9, north = -1e9;
  for (const Box& b : w.boxes()) {
    if (b.cx_m + b.hx_m < 0.9) west = std::min(west, b.cx_m + b.hx_m);
    if (b.cx_m - b.hx_m > 0.9) east = std::max(east, b.cx_m - b.hx_m);
    if (b.cy_m + b.hy_m < 0.9) south = std::min(south, b.cy_m + b.hy_m);
    if (b.cy_m - b.hy_m > 0.9) north = std::max(north, b.cy_m - b.hy_m);
  }
  EXPECT_NEAR(west, -0.25, 1e-12);
  EXPECT_NEAR(east, 2.05, 1e-12);
  EXPECT_NEAR(south, -0.25, 1e-12);
  EXPECT_NEAR(north, 2.05, 1e-12);
}

// Gap changes over a small move against jv (straight) and jw (turn), for every probe the two poses
// share (the same feature against the same rectangle).
void expect_rates_match(const World& w, const Pose& p, size_t min_probes) {
  const RobotGeometry g;
  std::vector<ContactProbe> base, moved;
  w.probes(p, g, &base, 10.0);
  ASSERT_GE(base.size(), min_probes);
  const double d = 1e-7;
  auto check = [&](const Pose& q, bool turn) {
    w.probes(q, g, &moved, 10.0);
    size_t matched = 0;
    for (const ContactProbe& a : base)
      for (const ContactProbe& b : moved)
        if (a.feature == b.feature && a.box == b.box && std::fabs(a.lateral_m - b.lateral_m) < 1e-5 &&
            std::fabs(a.gap_m - b.gap_m) < 1e-4) {
          EXPECT_NEAR((b.gap_m - a.gap_m) / d, turn ? a.jw : a.jv, 1e-5) << "feature " << a.feature << " box " << a.box;
          ++matched;
        }
    EXPECT_EQ(matched, base.size());
  };
  check({p.x_m + d * std::cos(p.theta_rad), p.y_m + d * std::sin(p.theta_rad), p.theta_rad}, false);
  check({p.x_m, p.y_m, p.theta_rad + d}, true);
}

TEST(World, ProbeGapsAndTheirRatesAgreeWithFiniteDifferences) {
  World w(ArenaParams{0.2, 10, 0.25});
  expect_rates_match(w, {1.3, 0.7, 0.4}, 12);  // 3 features × 4 walls
}

TEST(World, SwitchGapAtTheEastWall) {
  World w(ArenaParams{0.2, 10, 0.25});
  const RobotGeometry g;
  std::vector<ContactProbe> probes;
  w.probes({1.86, 0.9, 0.0}, g, &probes);
  double left = 1e9;
  for (const ContactProbe& p : probes)
    if (p.feature == ContactProbe::kSwitchLeft) left = std::min(left, p.gap_m);
  EXPECT_NEAR(left, 2.05 - 1.86 - g.bumper_x_m, 1e-12);
}

TEST(World, DiscOverlapsAnObstacleCell) {
  World w(ArenaParams{0.2, 10, 0.25});
  const Obstacle o{1.0, 1.0, 0.1};
  EXPECT_TRUE(w.disc_overlaps(o, 1.0, 0.75, 0.17));   // 0.15 below the cell's edge
  EXPECT_FALSE(w.disc_overlaps(o, 1.0, 0.72, 0.17));  // 0.18 below
  EXPECT_FALSE(w.disc_overlaps(o, 0.75, 0.75, 0.17)); // corner distance 0.212
}

TEST(ContactMonitor, CountsObstacleOnsetsSeparatelyFromWallContacts) {
  World w(ArenaParams{0.2, 10, 0.25});
  w.set_obstacles({{1.0, 0.0, 0.1}, {1.4, 0.0, 0.1}});
  const RobotGeometry g;
  ContactMonitor m;
  std::vector<ContactProbe> probes;
  double t = 0;
  for (double x = 0.3; x <= 1.7; x += 0.001) {  // drive along y = 0 through both cells
    const Pose p{x, 0.0, 0.0};
    w.probes(p, g, &probes);
    m.update(t += 0.01, w, p, g, probes);
  }
  EXPECT_EQ(m.collisions(), 2);
  EXPECT_GT(m.first_collision_t(), 0.0);
  EXPECT_EQ(m.wall_contacts(), 0);  // y = 0 is 0.25 from the south wall: disc gap 0.08
  EXPECT_EQ(m.take_events().size(), 2u);
  EXPECT_TRUE(m.take_events().empty());
}

}  // namespace
}  // namespace cart2d
