// The world's look on the simulated camera (issue 24): the look parsed and refused as the side
// channel says, the default look drawing today's picture, a lamp's shadow behind a box, thin legs
// and a low step where the model projects them, a glossy floor mirroring a box, vignetting,
// motion blur, auto-exposure, JPEG quality, and determinism for a seed with every effect on.
#include <gtest/gtest.h>

#include <cmath>

#include "box_at.hpp"
#include "camera_model.hpp"
#include "camera_render.hpp"
#include "look.hpp"
#include "sim_camera.hpp"
#include "test_camera.hpp"

namespace cart2d {
namespace {

constexpr double kPi = kCameraTestPi;
constexpr double kCpuHz = kCameraTestCpuHz;

Look look_of(const char* text) {
  json::Value v;
  std::string error;
  EXPECT_TRUE(json::parse(text, &v, &error)) << error;
  Look look;
  EXPECT_EQ(parse_look(v, &look), "") << text;
  return look;
}

struct Px {
  int u, v;
};

// Where the model sees a world point (asserted inside the picture).
Px project(const CameraModel& m, const Vec3& p) {
  double u = 0, v = 0;
  EXPECT_TRUE(m.project(Pose{}, p, &u, &v));
  const Px px{static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v))};
  EXPECT_TRUE(px.u >= 2 && px.u < 318 && px.v >= 2 && px.v < 238) << u << ", " << v;
  return px;
}

const Rgb& at(const std::vector<Rgb>& img, Px p) { return img[static_cast<size_t>(p.v) * 320 + static_cast<size_t>(p.u)]; }
double level(const Rgb& c) { return (c.r + c.g + c.b) / 3.0; }
bool same(const Rgb& a, const Rgb& b) { return a.r == b.r && a.g == b.g && a.b == b.b; }

Box leg(double x, double y, double height, uint32_t colour) {
  Box b = box_at(x, y, 0.025, 0.025);
  b.height_m = height;
  b.colour_rgb = colour;
  return b;
}

TEST(Look, ParsedWithDefaultsAndRefusedWithASentence) {
  const Look tiles = look_of(R"({"floor":{"material":"tiles","colour":"#e0e0d0"},"lights":[{"x":1,"y":2}]})");
  EXPECT_EQ(tiles.floor.material, FloorLook::Material::kTiles);
  EXPECT_EQ(tiles.floor.colour, 0xe0e0d0u);
  ASSERT_EQ(tiles.lights.size(), 1u);
  EXPECT_EQ(tiles.lights[0].z_m, LightLook{}.z_m);
  EXPECT_GT(look_of(R"({"floor":{"material":"glossy"}})").floor.gloss, 0.0);
  const struct {
    const char* text;
    const char* says;
  } bad[] = {
      {R"({"floor":{"material":"marble"}})", "look.floor.material must be"},
      {R"({"floor":{"grout":"#ffffff"}})", "unknown key \"grout\" in look.floor"},
      {R"({"lights":[{"x":1}]})", "look.lights[0] needs x and y"},
      {R"({"camera":{"vignetting":2}})", "look.camera.vignetting must be a number in [0, 0.9]"},
      {R"({"walls":{"colour":"white"}})", "look.walls.colour must be \"#rrggbb\""},
      {R"([1])", "look must be an object"},
  };
  for (const auto& b : bad) {
    json::Value v;
    std::string error;
    ASSERT_TRUE(json::parse(b.text, &v, &error));
    Look look = tiles;
    const std::string said = parse_look(v, &look);
    EXPECT_NE(said.find(b.says), std::string::npos) << said;
  }
}

TEST(Look, AnEmptyLookDrawsTodaysPicture) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World today{ArenaParams{}}, empty{ArenaParams{}};
  for (World* w : {&today, &empty}) w->add(box_at(0.8, 0.1, 0.2, 0.2));
  empty.set_look(look_of("{}"));
  std::vector<uint8_t> a, b;
  r.render(today, Pose{0.3, 0.2, 0.4}, nullptr, 1.0, 2.0, 7, 3, &a);
  r.render(empty, Pose{0.3, 0.2, 0.4}, nullptr, 1.0, 2.0, 7, 3, &b);
  EXPECT_EQ(a, b);
}

TEST(Look, ALampsShadowDarkensTheFloorBehindABox) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  // A lamp up and to the left (+y) of a low box: its shadow falls to the right (−y) of the box.
  const Look lamp = look_of(R"({"floor":{"material":"plain","variation":0},"ambient":0.4,"cart_height":0,
                                "lights":[{"x":1.0,"y":0.5,"z":1.0,"power":0.8,"radius":0.02}]})");
  World with_box, bare;
  with_box.set_look(lamp);
  bare.set_look(lamp);
  Box b = box_at(1.0, 0.0, 0.1, 0.1);
  b.height_m = 0.15;
  with_box.add(b);
  std::vector<Rgb> shaded, open;
  r.render_clean(with_box, Pose{}, nullptr, &shaded);
  r.render_clean(bare, Pose{}, nullptr, &open);
  // The top's far edge lands at y = 0.5 − 0.55 / 0.85 = −0.147: the floor at y = −0.1 is in shadow.
  const Px behind = project(m, {1.0, -0.1, 0.0});
  EXPECT_LT(level(at(shaded, behind)), 0.75 * level(at(open, behind)));
  // On the lamp's side and beyond the shadow's end the floor is as lit as without the box.
  for (const Vec3& p : {Vec3{1.0, 0.15, 0.0}, Vec3{1.0, -0.25, 0.0}}) EXPECT_TRUE(same(at(shaded, project(m, p)), at(open, project(m, p))));
}

TEST(Look, ThinLegsAndALowStepAppearAtTheirProjectedColumns) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  const Look tiles = look_of(R"({"floor":{"material":"tiles","colour":"#b0b0b0","accent":"#909090"}})");
  World room, bare;
  room.set_look(tiles);
  bare.set_look(tiles);
  room.add(leg(1.0, 0.1, 0.45, 0xa8a8a8));  // a grey leg on a grey floor, 2.5 cm across
  Box step = box_at(0.9, -0.3, 0.2, 0.3);   // a step the floor's colour, 5 cm high
  step.height_m = 0.05;
  step.colour_rgb = 0xb0b0b0;
  room.add(step);
  std::vector<Rgb> with, without;
  r.render_clean(room, Pose{}, nullptr, &with);
  r.render_clean(bare, Pose{}, nullptr, &without);
  // The leg's two sides (the camera looks at its −x face) at 10 cm up.
  const Px left = project(m, {0.9875, 0.1125, 0.1}), right = project(m, {0.9875, 0.0875, 0.1});
  ASSERT_GE(right.u - left.u, 4);  // about 8 px at this distance
  for (int u = left.u + 1; u <= right.u - 1; ++u) EXPECT_FALSE(same(at(with, {u, left.v}), at(without, {u, left.v}))) << u;
  for (int u : {left.u - 2, right.u + 2}) EXPECT_TRUE(same(at(with, {u, left.v}), at(without, {u, left.v}))) << u;
  // The step's front face (x = 0.8), between its foot and its top edge, and the floor in front.
  const Px face = project(m, {0.8, -0.3, 0.025}), foot = project(m, {0.8, -0.3, 0.0});
  EXPECT_FALSE(same(at(with, face), at(without, face)));
  EXPECT_TRUE(same(at(with, {foot.u, foot.v + 2}), at(without, {foot.u, foot.v + 2})));
}

TEST(Look, AGlossyFloorMirrorsABoxBelowIt) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World matt, glossy;
  matt.set_look(look_of(R"({"floor":{"material":"plain","colour":"#a0a0a0","variation":0}})"));
  glossy.set_look(look_of(R"({"floor":{"material":"plain","colour":"#a0a0a0","variation":0,"gloss":0.5}})"));
  Box red = box_at(1.2, 0.0, 0.2, 0.3);
  red.height_m = 0.3;
  red.colour_rgb = 0xc03020;
  matt.add(red);
  glossy.add(red);
  std::vector<Rgb> a, b;
  r.render_clean(matt, Pose{}, nullptr, &a);
  r.render_clean(glossy, Pose{}, nullptr, &b);
  const Px foot = project(m, {1.1, 0.0, 0.0});
  const Px below{foot.u, foot.v + 4};  // the floor just in front of the box: its reflection
  EXPECT_EQ(at(a, below).r, at(a, below).g);
  EXPECT_GT(at(b, below).r, at(b, below).g + 20);
}

TEST(Look, VignettingDarkensTheCorners) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World plain, vignetted;
  plain.set_look(look_of(R"({"floor":{"material":"plain","variation":0}})"));
  vignetted.set_look(look_of(R"({"floor":{"material":"plain","variation":0},"camera":{"vignetting":0.4}})"));
  std::vector<uint8_t> a, b;
  r.render(plain, Pose{}, nullptr, 1.0, 0.0, 1, 0, &a);
  r.render(vignetted, Pose{}, nullptr, 1.0, 0.0, 1, 0, &b);
  const size_t corner = 3 * (239 * 320 + 0), centre = 3 * (120 * 320 + 160);
  EXPECT_LT(b[corner], 0.7 * a[corner]);
  EXPECT_NEAR(b[centre], a[centre], 1);
}

TEST(Look, MotionBlurSmearsEdgesWhileTurning) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World world;
  world.set_look(look_of(R"({"floor":{"material":"plain","variation":0},"camera":{"shutter_ms":40}})"));
  for (int k = 0; k < 5; ++k) world.add(leg(1.0, -0.3 + 0.15 * k, 0.45, 0x202020));
  FrameScene still;
  still.world = &world;
  FrameScene turning = still;
  turning.twist = {0.0, 1.0};
  std::vector<uint8_t> a, b;
  r.render(still, 1.0, 0.0, 1, 0, &a);
  r.render(turning, 1.0, 0.0, 1, 0, &b);
  // The sum of horizontal steps along a row through the legs: smaller once smeared.
  const Px row = project(m, {1.0, 0.0, 0.05});
  auto steps = [&](const std::vector<uint8_t>& img) {
    double sum = 0;
    for (int u = 1; u < 320; ++u) sum += std::abs(img[3 * (row.v * 320 + u)] - img[3 * (row.v * 320 + u - 1)]);
    return sum;
  };
  EXPECT_LT(steps(b), 0.8 * steps(a));
}

TEST(SimCameraLook, AutoExposureFollowsTheViewWithALag) {
  World bright, dark;
  bright.set_look(look_of(R"({"floor":{"material":"plain","colour":"#f0f0f0"},"camera":{"auto_exposure":true,"ae_target":110}})"));
  dark.set_look(look_of(R"({"floor":{"material":"plain","colour":"#303030"},"camera":{"auto_exposure":true,"ae_target":110}})"));
  SimCamera cam(kCpuHz, 1);
  CameraFrame f;
  std::string error;
  ASSERT_TRUE(cam.capture(0, bright, Pose{}, &f, &error));
  const double after_one = cam.auto_exposure_gain();
  EXPECT_LT(after_one, 1.0);  // it turned down for a bright view...
  for (uint64_t k = 1; k < 20; ++k) ASSERT_TRUE(cam.capture(k, bright, Pose{}, &f, &error));
  EXPECT_LT(cam.auto_exposure_gain(), after_one);  // ...not all at once
  EXPECT_NEAR(cam.auto_exposure_gain(), 110.0 / 0xf0, 0.05);
  ASSERT_TRUE(cam.capture(20, dark, Pose{}, &f, &error));
  const double turned = cam.auto_exposure_gain();
  for (uint64_t k = 21; k < 40; ++k) ASSERT_TRUE(cam.capture(k, dark, Pose{}, &f, &error));
  EXPECT_GT(turned, 110.0 / 0xf0);
  EXPECT_GT(cam.auto_exposure_gain(), turned);
  EXPECT_NEAR(cam.auto_exposure_gain(), 110.0 / 0x30, 0.25);
}

World kitchen() {
  World world{ArenaParams{}};
  world.set_look(look_of(R"({"floor":{"material":"tiles","colour":"#e4e0d6","accent":"#b5ae9f","gloss":0.15},
      "walls":{"colour":"#ebe8e1","skirting":0.07},"lights":[{"x":0.9,"y":0.9,"power":0.7}],
      "camera":{"vignetting":0.35,"uneven":0.15,"auto_exposure":true,"shutter_ms":30,"sensor_noise":true}})"));
  world.add(leg(1.0, 0.1, 0.45, 0x8f9297));
  world.add(leg(1.3, -0.2, 0.45, 0x8f9297));
  return world;
}

TEST(SimCameraLook, DeterministicForASeedWithEveryEffectOn) {
  const World world = kitchen();
  SimCamera a(kCpuHz, 42), b(kCpuHz, 42), c(kCpuHz, 43);
  CameraFrame fa, fb, fc;
  std::string error;
  const Pose pose{0.2, 0.1, 0.3};
  const Twist twist{0.3, 0.6};
  for (uint64_t k = 0; k < 3; ++k) {
    ASSERT_TRUE(a.capture(k, world, pose, &fa, &error, twist));
    ASSERT_TRUE(b.capture(k, world, pose, &fb, &error, twist));
    ASSERT_TRUE(c.capture(k, world, pose, &fc, &error, twist));
    EXPECT_EQ(fa.jpeg, fb.jpeg) << k;
    EXPECT_NE(fa.jpeg, fc.jpeg) << k;  // another seed, other noise
  }
}

TEST(SimCameraLook, JpegQualitySetsTheSize) {
  const World world = kitchen();
  SimCamera cam(kCpuHz, 1);
  json::Value msg;
  std::string error;
  size_t sizes[2] = {0, 0};
  const char* settings[2] = {R"({"jpeg_quality":40})", R"({"jpeg_quality":95})"};
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(json::parse(settings[k], &msg, &error));
    ASSERT_EQ(cam.configure(msg, 0), "");
    CameraFrame f;
    ASSERT_TRUE(cam.capture(0, world, Pose{}, &f, &error));
    sizes[k] = f.jpeg.size();
  }
  EXPECT_GT(sizes[1], 2 * sizes[0]);
}

}  // namespace
}  // namespace cart2d
