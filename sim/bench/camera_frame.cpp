// The simulated camera's cost per frame: ray casting (render) and JPEG encoding (libjpeg-turbo)
// at QVGA and VGA, in the square arena with a few boxes and the checkerboard. Prints a table of
// wall-clock milliseconds and JPEG sizes; not a test.
//
//   build/sim/sim_camera_bench [frames]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "robot_params.hpp"
#include "sim_camera.hpp"

namespace cart2d {
namespace {

void run(int width, int height, int frames) {
  World world{ArenaParams{}};
  const double boxes[][2] = {{0.6, 0.2}, {1.0, -0.3}, {1.4, 0.5}, {0.9, 0.9}, {1.6, 1.2}};
  for (const auto& p : boxes) {
    Box b;
    b.cx_m = p[0];
    b.cy_m = p[1];
    b.hx_m = b.hy_m = 0.1;
    b.height_m = 0.3;
    b.colour_rgb = 0xb8742f;
    world.add(b);
  }
  CameraSettings s = CameraSettings::from_params();
  s.width_px = width;
  s.height_px = height;
  SimCamera cam(16e6, 1, s);
  json::Value board;
  std::string error;
  json::parse(R"({"cols":9,"rows":6,"square_m":0.03,"x":0.5,"y":-0.075,"z":0})", &board, &error);
  cam.set_target(board);
  std::vector<double> render, encode, clean;
  CameraRenderer renderer(cam.model());
  std::vector<Rgb> scratch;
  size_t bytes = 0;
  for (int k = 0; k < frames; ++k) {
    CameraFrame f;
    const Pose pose{0.2 + 0.001 * k, 0.1, 0.3 * (k % 7) / 7.0};
    if (!cam.capture(static_cast<uint64_t>(k), world, pose, &f, &error)) {
      std::fprintf(stderr, "%s\n", error.c_str());
      std::exit(1);
    }
    render.push_back(cam.last_render_ms());
    const auto t0 = std::chrono::steady_clock::now();
    renderer.render_clean(world, pose, cam.board(), &scratch);
    clean.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    encode.push_back(cam.last_encode_ms());
    bytes += f.jpeg.size();
  }
  std::sort(render.begin(), render.end());
  std::sort(encode.begin(), encode.end());
  std::sort(clean.begin(), clean.end());
  std::printf("%4d x %-4d  render median %6.2f ms (rays %5.2f)  p90 %6.2f ms   jpeg median %5.2f ms  p90 %5.2f ms   %6.0f B/frame\n",
              width, height, render[render.size() / 2], clean[clean.size() / 2], render[render.size() * 9 / 10], encode[encode.size() / 2],
              encode[encode.size() * 9 / 10], static_cast<double>(bytes) / frames);
}

}  // namespace
}  // namespace cart2d

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 100;
  std::printf("simulated camera, %d frames each, quality %ld, 5 boxes + arena walls + checkerboard\n", frames,
              static_cast<long>(params::sim::camera::jpeg_quality));
  cart2d::run(320, 240, frames);
  cart2d::run(640, 480, frames);
  return 0;
}
