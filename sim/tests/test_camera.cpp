// The simulated camera: its projection against OpenCV's, the rendered picture against the world
// (a box, the floor, the checkerboard appear where the model puts them), the frame schedule in
// simulated time, and determinism for a seed.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "box_at.hpp"
#include "camera_clock.hpp"
#include "camera_model.hpp"
#include "camera_render.hpp"
#include "sim_camera.hpp"
#include "test_camera.hpp"

namespace cart2d {
namespace {

constexpr double kPi = kCameraTestPi;
constexpr double kCpuHz = kCameraTestCpuHz;

Rgb pixel(const std::vector<Rgb>& img, const CameraModel& m, double u, double v) {
  const int iu = static_cast<int>(std::lround(u)), iv = static_cast<int>(std::lround(v));
  EXPECT_TRUE(iu >= 0 && iu < m.intrinsics().width_px && iv >= 0 && iv < m.intrinsics().height_px) << u << "," << v;
  return img[static_cast<size_t>(iv) * static_cast<size_t>(m.intrinsics().width_px) + static_cast<size_t>(iu)];
}

bool is_floor(const Rgb& c) {
  const int base = CameraRenderer::kFloorColour & 0xff, d = CameraRenderer::kFloorTextureLevels;
  return c.r == c.g && c.g == c.b && c.r >= base - d && c.r <= base + d;
}

TEST(CameraModel, ProjectsAsOpenCvDoes) {
  // Expected pixels from cv2.projectPoints (OpenCV 4.14) with K = [[fx,0,159.5],[0,fx,119.5],[0,0,1]],
  // fx = 160 / tan(27.5°) = 307.357, dist = (-0.12, 0.03, 0, 0, 0), and the camera's rotation
  // and centre (0.1, 0, 0.25) built from the mount by hand: an independent implementation.
  const CameraModel m = test_model();
  EXPECT_NEAR(m.intrinsics().fx, 307.3571, 1e-3);
  struct Case {
    Vec3 p;
    double u, v;
  };
  const Case cases[] = {
      {{0.1 + 0.25 / std::tan(25.0 * kPi / 180.0), 0, 0}, 159.5, 119.5},  // the optical axis meets the floor
      {{0.6361, -0.2, 0}, 262.035207, 119.505792},
      {{1.1, 0.15, 0.1}, 112.573331, 29.816224},
      {{2.0, 0.5, 0.0}, 77.096345, 24.505438},
      {{0.4, -0.3, 0.0}, 386.778123, 195.101392},  // outside the image: the model still projects it
  };
  for (const Case& c : cases) {
    double u = 0, v = 0;
    ASSERT_TRUE(m.project(Pose{}, c.p, &u, &v));
    EXPECT_NEAR(u, c.u, 1e-3);
    EXPECT_NEAR(v, c.v, 1e-3);
  }
  // The same points seen by a cart at (1, 2) heading +y (rotated by hand).
  const Pose turned{1.0, 2.0, kPi / 2};
  double u = 0, v = 0;
  ASSERT_TRUE(m.project(turned, {0.85, 3.1, 0.1}, &u, &v));
  EXPECT_NEAR(u, 112.573331, 1e-3);
  EXPECT_NEAR(v, 29.816224, 1e-3);
  EXPECT_FALSE(m.project(Pose{}, {-1.0, 0.0, 0.0}, &u, &v));  // behind the lens
}

TEST(CameraModel, UndistortInvertsDistortAcrossTheImage) {
  const CameraModel m = test_model();
  for (double u : {0.0, 40.0, 159.5, 250.0, 319.0}) {
    for (double v : {0.0, 60.0, 119.5, 239.0}) {
      double x = 0, y = 0, u2 = 0, v2 = 0;
      m.undistort(u, v, &x, &y);
      m.distort(x, y, &u2, &v2);
      EXPECT_NEAR(u2, u, 1e-9);
      EXPECT_NEAR(v2, v, 1e-9);
    }
  }
  // Barrel distortion (k1 < 0): a corner pixel's ray lies farther out than the pinhole's.
  double x = 0, y = 0;
  m.undistort(0, 0, &x, &y);
  EXPECT_LT(x, (0 - 159.5) / m.intrinsics().fx - 0.01);
}

TEST(CameraRender, BoxAppearsAtItsProjectedPixels) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World world;  // an endless floor
  Box b = box_at(1.2, 0.0, 0.2, 0.3);
  b.height_m = 0.1;
  b.colour_rgb = 0xc03020;
  world.add(b);
  std::vector<Rgb> img;
  r.render_clean(world, Pose{}, nullptr, &img);

  auto at = [&](Vec3 p, double du = 0, double dv = 0) {
    double u = 0, v = 0;
    EXPECT_TRUE(m.project(Pose{}, p, &u, &v));
    return pixel(img, m, u + du, v + dv);
  };
  // The front face (normal −x) is lit at 0.8: (0xc0, 0x30, 0x20) · 0.8.
  const Rgb face = at({1.1, 0.0, 0.05});
  EXPECT_EQ(face.r, 154);
  EXPECT_EQ(face.g, 38);
  EXPECT_EQ(face.b, 26);
  // Its edges, 2 px in and out: bottom (floor in front), top (floor behind), left and right.
  for (double d : {-2.0, 2.0}) {
    const bool inside_below = d < 0;
    EXPECT_EQ(at({1.1, 0.0, 0.0}, 0, d).r == 154, inside_below) << d;
    EXPECT_EQ(is_floor(at({1.1, 0.0, 0.0}, 0, d)), !inside_below) << d;
    EXPECT_EQ(at({1.1, 0.0, 0.1}, 0, d).r == 154, !inside_below) << d;
    // The box's left edge (y = +0.15) is on the image's left: inside is +u.
    EXPECT_EQ(at({1.1, 0.15, 0.05}, d, 0).r == 154, !inside_below) << d;
    EXPECT_EQ(at({1.1, -0.15, 0.05}, d, 0).r == 154, inside_below) << d;
  }
  // Beside it, the floor.
  EXPECT_TRUE(is_floor(at({1.1, 0.4, 0.0})));
  EXPECT_TRUE(is_floor(at({1.1, -0.4, 0.0})));
  // Seen from a cart turned away, the box is gone from those pixels.
  std::vector<Rgb> away;
  r.render_clean(world, Pose{0, 0, kPi}, nullptr, &away);
  double u = 0, v = 0;
  m.project(Pose{}, {1.1, 0.0, 0.05}, &u, &v);
  EXPECT_TRUE(is_floor(pixel(away, m, u, v)));
}

TEST(CameraRender, FloorNearAndFarAndTheHorizon) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World world;
  // Two strips of dark tape on the floor across the view, near (0.6 m) and far (3 m).
  for (double x : {0.6, 3.0}) {
    Box tape = box_at(x, 0.0, x < 1 ? 0.05 : 0.2, 2.0);  // several pixels tall at either distance
    tape.height_m = 1e-4;
    tape.colour_rgb = 0x202020;
    world.add(tape);
  }
  std::vector<Rgb> img;
  r.render_clean(world, Pose{}, nullptr, &img);
  for (double x : {0.6, 3.0}) {
    double u = 0, v = 0, u_near = 0, v_near = 0, u_far = 0, v_far = 0;
    m.project(Pose{}, {x, 0, 0}, &u, &v);
    const double beside = x < 1 ? 0.1 : 0.25;  // past the tape's edge, clear of anti-aliasing
    m.project(Pose{}, {x - beside, 0, 0}, &u_near, &v_near);
    m.project(Pose{}, {x + beside, 0, 0}, &u_far, &v_far);
    EXPECT_EQ(pixel(img, m, u, v).r, 0x20) << x;
    EXPECT_TRUE(is_floor(pixel(img, m, u_near, v_near))) << x;
    EXPECT_TRUE(is_floor(pixel(img, m, u_far, v_far))) << x;
    EXPECT_GT(v_near, v_far);  // nearer is lower in the image
  }
  // At 25° pitch the top edge looks 1.5° down: floor (9.5 m away) to the top of the image.
  double u = 0, v = 0;
  m.project(Pose{}, {1e4, 0, 0.25}, &u, &v);
  EXPECT_LT(v, 0);
  EXPECT_TRUE(is_floor(pixel(img, m, 159.5, 0)));
  // Pitched 10°, the horizon of the endless floor (a point far ahead at the lens height) is in view.
  CameraMount level = m.mount();
  level.pitch_rad = 10.0 * kPi / 180.0;
  const CameraModel lm(level, m.intrinsics());
  const CameraRenderer lr(lm);
  std::vector<Rgb> limg;
  lr.render_clean(World(), Pose{}, nullptr, &limg);
  lm.project(Pose{}, {1e4, 0, 0.25}, &u, &v);
  ASSERT_GT(v, 3);
  EXPECT_EQ(pixel(limg, lm, u, v - 2).r, (CameraRenderer::kBackgroundColour >> 16) & 0xff);
  EXPECT_TRUE(is_floor(pixel(limg, lm, u, v + 2)));
}

TEST(CameraRender, CheckerboardSquaresLieAroundTheModelsCorners) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  Checkerboard board;  // 9 × 6 inner corners of 3 cm, lying on the floor in front of the cart
  board.x_m = 0.45;
  board.y_m = -0.075;
  board.z_m = 0.0;
  std::vector<Rgb> img;
  r.render_clean(World(), Pose{}, &board, &img);
  const Rgb dark{0x1e, 0x1e, 0x1e}, light{0xeb, 0xeb, 0xeb};
  int checked = 0;
  for (int i = 0; i < board.cols; ++i) {
    for (int j = 0; j < board.rows; ++j) {
      // Around inner corner (i, j): the four squares touching it, sampled a fifth of a square
      // from the corner (a few pixels). The square at (−1, −1) is black: parity even is dark.
      for (int di : {-1, 0}) {
        for (int dj : {-1, 0}) {
          double u = 0, v = 0;
          ASSERT_TRUE(m.project(Pose{}, board.corner(i + (di + 0.5) * 0.4, j + (dj + 0.5) * 0.4), &u, &v));
          const bool expect_dark = ((i + di) + (j + dj)) % 2 == 0;
          const Rgb c = pixel(img, m, u, v);
          EXPECT_EQ(c.r, expect_dark ? dark.r : light.r) << i << "," << j << " " << di << dj;
          ++checked;
        }
      }
    }
  }
  EXPECT_EQ(checked, 9 * 6 * 4);
  // The white margin one square wide, beyond the first row of squares.
  double u = 0, v = 0;
  m.project(Pose{}, board.corner(-1.5, 2.5), &u, &v);
  EXPECT_EQ(pixel(img, m, u, v).r, light.r);
  m.project(Pose{}, board.corner(-2.5, 2.5), &u, &v);
  EXPECT_TRUE(is_floor(pixel(img, m, u, v)));
}

TEST(CameraRender, StandingBoardFacesTheCamera) {
  // roll = −90°, yaw = +90°: the board's columns run along world +y, its rows downwards, and it
  // faces −x (sim/README.md's example for a board held up in front of the cart).
  Checkerboard board;
  board.roll_rad = -kPi / 2;
  board.yaw_rad = kPi / 2;
  Vec3 ex, ey, n;
  board.axes(&ex, &ey, &n);
  EXPECT_NEAR(ex.y, 1.0, 1e-12);
  EXPECT_NEAR(ey.z, -1.0, 1e-12);
  EXPECT_NEAR(n.x, -1.0, 1e-12);
}

TEST(CameraClock, FramesAreStampedAtKOverFpsAndReleasedAfterTheLatency) {
  CameraSettings s = CameraSettings::from_params();
  s.width_px = 64;
  s.height_px = 48;
  s.fps = 15.0;
  s.latency_ms = 60.0;
  SimCamera cam(kCpuHz, 7, s);
  World world;
  const uint64_t step = 4000;  // the rig's physics step
  const uint64_t on_cycle = 5'000'000;  // turned on at 0.3125 s: the first frame is k = 5 (0.3333 s)
  cam.set_on(true, on_cycle);
  std::vector<std::pair<CameraFrame, uint64_t>> got;
  for (uint64_t end = on_cycle + step; end <= 32'000'000; end += step) {
    std::vector<CameraFrame> ready;
    cam.step(end, world, Pose{}, &ready);
    for (auto& f : ready) got.emplace_back(std::move(f), end);
  }
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.front().first.seq, 5u);
  for (size_t i = 0; i < got.size(); ++i) {
    const CameraFrame& f = got[i].first;
    EXPECT_EQ(f.seq, 5u + i);
    EXPECT_DOUBLE_EQ(f.t_s, static_cast<double>(f.seq) / 15.0);
    // Released at the first physics step reaching t_k + 60 ms, not before.
    const double release_s = f.t_s + 0.060;
    EXPECT_GE(static_cast<double>(got[i].second), release_s * kCpuHz - 1e-6);
    EXPECT_LT(static_cast<double>(got[i].second) - step, release_s * kCpuHz);
    EXPECT_FALSE(f.jpeg.empty());
  }
  // Up to 2 s: frames 5..29 released (29/15 + 0.06 = 1.993 s), frame 30 still in flight.
  EXPECT_EQ(got.back().first.seq, 29u);
}

TEST(CameraClock, FirstFrameFromACycle) {
  const CameraClock clock(15.0, 0.06, kCpuHz);
  EXPECT_EQ(clock.first_frame_from(0), 0u);
  EXPECT_EQ(clock.first_frame_from(1), 1u);
  EXPECT_EQ(clock.capture_cycle(15), 16'000'000u);  // exactly 1 s: no rounding up
  EXPECT_EQ(clock.first_frame_from(16'000'000), 15u);
  EXPECT_EQ(clock.first_frame_from(16'000'001), 16u);
}

TEST(SimCamera, AFrameShowsThePoseAtItsCaptureNotAtItsRelease) {
  CameraSettings s = CameraSettings::from_params();
  s.latency_ms = 100.0;
  s.noise_sigma = 0.0;
  SimCamera scheduled(kCpuHz, 1, s), direct(kCpuHz, 1, s);
  World world;
  Box b = box_at(1.2, 0.0, 0.2, 0.3);
  world.add(b);
  scheduled.set_on(true, 0);
  std::vector<CameraFrame> ready;
  scheduled.step(4000, world, Pose{}, &ready);  // frame 0 captured facing the box
  EXPECT_TRUE(ready.empty());
  for (uint64_t end = 8000; ready.empty() && end < 4'000'000; end += 4000)
    scheduled.step(end, world, Pose{0, 0, kPi}, &ready);  // turned away meanwhile
  ASSERT_FALSE(ready.empty());
  EXPECT_EQ(ready[0].seq, 0u);
  CameraFrame facing, away;
  std::string error;
  ASSERT_TRUE(direct.capture(0, world, Pose{}, &facing, &error));
  ASSERT_TRUE(direct.capture(0, world, Pose{0, 0, kPi}, &away, &error));
  EXPECT_EQ(ready[0].jpeg, facing.jpeg);
  EXPECT_NE(ready[0].jpeg, away.jpeg);
}

TEST(SimCamera, DeterministicForASeedAndAFrameNumber) {
  World world;
  world.add(box_at(1.0, 0.2, 0.2, 0.2));
  SimCamera a(kCpuHz, 42), b(kCpuHz, 42), c(kCpuHz, 43);
  CameraFrame fa, fb, fc, fa_next;
  std::string error;
  ASSERT_TRUE(a.capture(10, world, Pose{}, &fa, &error));
  ASSERT_TRUE(b.capture(10, world, Pose{}, &fb, &error));
  ASSERT_TRUE(c.capture(10, world, Pose{}, &fc, &error));
  ASSERT_TRUE(a.capture(11, world, Pose{}, &fa_next, &error));
  EXPECT_EQ(fa.jpeg, fb.jpeg);
  EXPECT_NE(fa.jpeg, fc.jpeg);       // another seed, other noise
  EXPECT_NE(fa.jpeg, fa_next.jpeg);  // each frame its own noise
  EXPECT_EQ(fa.jpeg.substr(0, 2), std::string("\xff\xd8"));  // a JPEG's SOI marker
}

TEST(SimCamera, NoiseHasTheSetSigmaAndExposureScales) {
  const CameraModel m = test_model();
  const CameraRenderer r(m);
  World world;
  std::vector<Rgb> clean;
  r.render_clean(world, Pose{}, nullptr, &clean);
  std::vector<uint8_t> noisy, bright;
  r.render(world, Pose{}, nullptr, 1.0, 4.0, 3, 0, &noisy);
  r.render(world, Pose{}, nullptr, 1.2, 0.0, 3, 0, &bright);
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < clean.size(); ++i) {
    const double d = noisy[3 * i] - static_cast<double>(clean[i].r);
    sum += d;
    sum2 += d * d;
  }
  const double n = static_cast<double>(clean.size());
  EXPECT_NEAR(sum / n, 0.0, 0.05);
  EXPECT_NEAR(std::sqrt(sum2 / n - (sum / n) * (sum / n)), 4.0, 0.1);  // rounding adds 1/12 to the variance
  EXPECT_EQ(bright[3 * 200 * 320 + 3 * 160], static_cast<uint8_t>(std::lround(clean[200 * 320 + 160].r * 1.2)));
}

TEST(SimCamera, ConfigureRejectsBadSettingsWhole) {
  SimCamera cam(kCpuHz, 1);
  json::Value msg;
  std::string error;
  ASSERT_TRUE(json::parse(R"({"fps":30,"k1":5})", &msg, &error));
  EXPECT_FALSE(cam.configure(msg, 0).empty());
  EXPECT_EQ(cam.settings().fps, CameraSettings::from_params().fps);
  ASSERT_TRUE(json::parse(R"({"fps":30,"width":160,"height":120})", &msg, &error));
  EXPECT_EQ(cam.configure(msg, 0), "");
  EXPECT_EQ(cam.model().intrinsics().width_px, 160);
  ASSERT_TRUE(json::parse(R"({"cols":9,"rows":6,"square_m":0.03,"x":1,"y":0,"z":0.2,"roll":0,"pitch":0,"yaw":0})", &msg,
                          &error));
  EXPECT_EQ(cam.set_target(msg), "");
  ASSERT_NE(cam.board(), nullptr);
  EXPECT_EQ(cam.board()->cols, 9);
  ASSERT_TRUE(json::parse("null", &msg, &error));
  EXPECT_EQ(cam.set_target(msg), "");
  EXPECT_EQ(cam.board(), nullptr);
}

}  // namespace
}  // namespace cart2d
