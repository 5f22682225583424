#include <gtest/gtest.h>

#include <cmath>

#include "world.hpp"

namespace cart2d {
namespace {

TEST(World, WallsLieTheMarginOutsideTheGrid) {
  World w(ArenaParams{0.2, 10, 0.25});
  EXPECT_DOUBLE_EQ(w.x_min(), -0.25);
  EXPECT_NEAR(w.x_max(), 2.05, 1e-12);
  EXPECT_NEAR(w.y_max(), 2.05, 1e-12);
}

TEST(World, ProbeGapsAndTheirRatesAgreeWithFiniteDifferences) {
  World w(ArenaParams{0.2, 10, 0.25});
  const RobotGeometry g;
  const Pose p{1.3, 0.7, 0.4};
  std::vector<WallProbe> base, moved;
  w.probes(p, g, &base);
  ASSERT_EQ(base.size(), 12u);
  const double d = 1e-6;
  // Advance by v·d (straight) and by ω·d (turn) and compare the gap changes with jv, jw.
  w.probes({p.x_m + d * std::cos(p.theta_rad), p.y_m + d * std::sin(p.theta_rad), p.theta_rad}, g, &moved);
  for (size_t i = 0; i < base.size(); ++i) EXPECT_NEAR((moved[i].gap_m - base[i].gap_m) / d, base[i].jv, 1e-6);
  w.probes({p.x_m, p.y_m, p.theta_rad + d}, g, &moved);
  for (size_t i = 0; i < base.size(); ++i) EXPECT_NEAR((moved[i].gap_m - base[i].gap_m) / d, base[i].jw, 1e-6);
}

TEST(World, SwitchGapAtTheEastWall) {
  World w(ArenaParams{0.2, 10, 0.25});
  const RobotGeometry g;
  EXPECT_NEAR(w.switch_gap_m({1.0, 0.9, 0.0}, g, true), 2.05 - 1.0 - g.bumper_x_m, 1e-12);
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
  std::vector<WallProbe> probes;
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
