// The side channel's world messages, parsed and applied (sim/README.md, "The world").
#include <gtest/gtest.h>

#include "world_change.hpp"

namespace cart2d {
namespace {

json::Value parse(const std::string& text) {
  json::Value v;
  std::string error;
  EXPECT_TRUE(json::parse(text, &v, &error)) << error;
  return v;
}

// Parses and applies; returns the parser's error ("" when applied).
std::string change(World* world, const std::string& type, const std::string& text, WorldChange* out = nullptr) {
  WorldChange c;
  const std::string error = parse_world_change(type, parse(text), world->arena(), &c);
  if (error.empty()) apply_world_change(c, world);
  if (out) *out = c;
  return error;
}

TEST(WorldChange, AWorldFromAMapWithItsBoundaryAndBoxes) {
  World w(ArenaParams{});
  // 4 × 3 cells of 0.5 m from (−1, −1); row 0: . # # .  row 1: . . . .  row 2: # . . #
  ASSERT_EQ(change(&w, "world",
                   R"({"walls":{"origin":[-1,-1],"resolution":0.5,"width":4,"height":3,"rle":[1,2,5,1,2,1]},)"
                   R"("boxes":[{"x":0.5,"y":0.25,"sx":0.2,"sy":0.4,"height":0.8,"colour":"#ff8000","id":"a"},)"
                   R"({"x":0,"y":0,"sx":1,"sy":1,"id":7}]})"),
            "");
  EXPECT_EQ(w.count(BoxKind::kWall), 3u + 4u);  // the map's runs, and a boundary around the map
  ASSERT_EQ(w.count(BoxKind::kBox), 2u);
  const Box& a = w.boxes()[7];
  EXPECT_EQ(a.id, "a");
  EXPECT_EQ(a.colour_rgb, 0xff8000u);
  EXPECT_EQ(a.height_m, 0.8);
  EXPECT_EQ(a.hx_m, 0.1);
  EXPECT_EQ(w.boxes()[8].id, "7");
  EXPECT_EQ(w.boxes()[8].height_m, World::kBoxHeightM);
  // The boundary's inner faces are the map's edges: x in [−1, 1], y in [−1, 0.5].
  const RobotGeometry g;
  EXPECT_EQ(w.overlapping({-0.8, -0.3, 3.14159}, g), -1);
  EXPECT_NE(w.overlapping({-0.9, -0.3, 3.14159}, g), -1);  // the bumper crosses x = −1
  EXPECT_NE(w.overlapping({-0.6, 0.1, 0.0}, g), -1);  // on cell (0, 2)
}

TEST(WorldChange, BoundaryChoices) {
  World w;
  ASSERT_EQ(change(&w, "world", R"({"boundary":[-2,-1,3,4]})"), "");
  EXPECT_EQ(w.count(BoxKind::kWall), 4u);
  EXPECT_EQ(w.overlapping({2.82, 1.0, 0.0}, RobotGeometry{}), -1);
  EXPECT_NE(w.overlapping({2.84, 1.0, 0.0}, RobotGeometry{}), -1);  // the bumper 1 cm beyond x = 3
  ASSERT_EQ(change(&w, "world", R"({"walls":{"origin":[0,0],"resolution":1,"width":2,"height":1,"bits":"AA=="},"boundary":false})"), "");
  EXPECT_EQ(w.count(BoxKind::kWall), 0u);
  ASSERT_EQ(change(&w, "world", "{}"), "");  // an endless empty floor
  EXPECT_TRUE(w.boxes().empty());
}

TEST(WorldChange, BadMessagesAreRefusedAndChangeNothing) {
  World w(ArenaParams{});
  const uint64_t version = w.version();
  const char* bad[][2] = {
      {"world", R"({"boundary":true})"},
      {"world", R"({"boundary":[0,0,0,1]})"},
      {"world", R"({"walls":{"origin":[0,0],"resolution":0.1,"width":2,"height":2}})"},
      {"world", R"({"walls":{"origin":[0,0],"resolution":0.1,"width":2,"height":2,"rle":[4],"bits":"AA=="}})"},
      {"world", R"({"walls":{"origin":[0,0],"resolution":0.1,"width":2,"height":2,"rle":[3]}})"},
      {"world", R"({"walls":{"origin":[0,0],"resolution":0,"width":2,"height":2,"rle":[4]}})"},
      {"world", R"({"walls":{"origin":[0,0],"resolution":0.1,"width":1e5,"height":1e5,"rle":[1e10]}})"},
      {"world", R"({"boxes":[{"x":0,"y":0,"sx":0,"sy":1}]})"},
      {"world", R"({"boxes":[{"x":0,"y":0,"sx":1,"sy":1,"colour":"red"}]})"},
      {"world", R"({"boxes":[{"x":0,"y":0,"sx":1,"sy":1,"id":""}]})"},
      {"world", R"({"at":-1})"},
      {"boxes", R"({"boxes":[]})"},
      {"boxes", R"({"remove":[null]})"},
      {"obstacles", R"({})"},
      {"obstacles", R"({"add":[[0,0,0]]})"},
      {"obstacles", R"({"add":[[0,0]],"physical":1})"},
  };
  for (const auto& m : bad) EXPECT_NE(change(&w, m[0], m[1]), "") << m[1];
  EXPECT_EQ(w.version(), version);
  EXPECT_EQ(w.count(BoxKind::kWall), 4u);
}

TEST(WorldChange, BoxesAreAddedReplacedByIdAndRemoved) {
  World w(ArenaParams{});
  ASSERT_EQ(change(&w, "boxes", R"({"add":[{"x":1,"y":1,"sx":0.2,"sy":0.2,"id":"a"},{"x":0.4,"y":1,"sx":0.2,"sy":0.2}]})"), "");
  EXPECT_EQ(w.count(BoxKind::kBox), 2u);
  ASSERT_EQ(change(&w, "boxes", R"({"add":[{"x":1.5,"y":1,"sx":0.2,"sy":0.2,"id":"a"}]})"), "");
  ASSERT_EQ(w.count(BoxKind::kBox), 2u);  // "a" moved, not doubled
  EXPECT_EQ(w.boxes().back().cx_m, 1.5);
  ASSERT_EQ(change(&w, "boxes", R"({"remove":["a","nobody"]})"), "");
  EXPECT_EQ(w.count(BoxKind::kBox), 1u);
  ASSERT_EQ(change(&w, "boxes", R"({"add":[{"x":0.2,"y":1,"sx":0.2,"sy":0.2,"id":"d"},{"x":0.6,"y":1,"sx":0.2,"sy":0.2,"id":"d"}]})"), "");
  ASSERT_EQ(w.count(BoxKind::kBox), 2u);  // of two with one id, the last
  EXPECT_EQ(w.boxes().back().cx_m, 0.6);
  ASSERT_EQ(change(&w, "boxes", R"({"clear":true})"), "");
  EXPECT_EQ(w.count(BoxKind::kBox), 0u);
  EXPECT_EQ(w.count(BoxKind::kWall), 4u);  // walls stay
}

TEST(WorldChange, PhysicalObstaclesHaveBoxTwinsThatGoWithThem) {
  World w(ArenaParams{});
  WorldChange c;
  ASSERT_EQ(change(&w, "obstacles", R"({"add":[[1.0,0.6],[1.2,0.6]],"physical":true,"at":2.5})", &c), "");
  EXPECT_EQ(c.at_s, 2.5);  // the caller schedules; applied here at once
  ASSERT_EQ(w.obstacles().size(), 2u);
  ASSERT_EQ(w.count(BoxKind::kBox), 2u);
  const Box& twin = w.boxes()[4];
  EXPECT_TRUE(twin.obstacle_twin);
  EXPECT_EQ(twin.id, "obstacle@1,0.6");
  EXPECT_NEAR(twin.hx_m, 0.1, 1e-8);  // one cell of the default grid (0.2 m)
  ASSERT_EQ(change(&w, "obstacles", R"({"add":[[0.4,0.4],[0.4,0.4]]})"), "");  // virtual only, once
  EXPECT_EQ(w.obstacles().size(), 3u);
  ASSERT_EQ(change(&w, "obstacles", R"({"add":[[1.2,0.6]]})"), "");  // no longer physical
  EXPECT_EQ(w.obstacles().size(), 3u);
  EXPECT_EQ(w.count(BoxKind::kBox), 1u);
  ASSERT_EQ(change(&w, "obstacles", R"({"add":[[1.2,0.6]],"physical":true})"), "");
  EXPECT_EQ(w.count(BoxKind::kBox), 2u);
  EXPECT_EQ(w.count(BoxKind::kBox), 2u);
  ASSERT_EQ(change(&w, "obstacles", R"({"remove":[[1.0,0.6]]})"), "");
  EXPECT_EQ(w.obstacles().size(), 2u);
  EXPECT_EQ(w.count(BoxKind::kBox), 1u);
  ASSERT_EQ(change(&w, "obstacles", R"({"cells":[[0,0]]})"), "");  // a new set: old twins gone
  EXPECT_EQ(w.obstacles().size(), 1u);
  EXPECT_EQ(w.count(BoxKind::kBox), 0u);
  ASSERT_EQ(change(&w, "boxes", R"({"add":[{"x":3,"y":3,"sx":1,"sy":1,"id":"mine"}]})"), "");
  ASSERT_EQ(change(&w, "obstacles", R"({"points":[[0.2,0.2]],"physical":true})"), "");
  EXPECT_EQ(w.count(BoxKind::kBox), 2u);  // other boxes are not the obstacles' business
}

}  // namespace
}  // namespace cart2d
