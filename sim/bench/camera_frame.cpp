// The simulated camera's cost per frame: ray casting with the camera's effects (render) and JPEG
// encoding (libjpeg-turbo), in the square arena with a few boxes and the checkerboard at QVGA and
// VGA (today's look), then at QVGA in each room file given (docs/examples/*.json: their boxes and
// look, the cart driving and turning: motion blur and auto-exposure at work). Prints a table of
// CPU milliseconds of this thread (steadier than the wall clock on a busy machine) and JPEG
// sizes; not a test. --save DIR writes each room's first and middle frames there as JPEG.
//
//   build/sim/sim_camera_bench [frames] [--save DIR] [room.json ...]
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "robot_params.hpp"
#include "sim_camera.hpp"
#include "world_change.hpp"

namespace cart2d {
namespace {

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) / 1e6;
}

struct Row {
  std::vector<double> render, encode;
  size_t bytes = 0;
};

void print(const char* name, int width, int height, Row& r) {
  std::sort(r.render.begin(), r.render.end());
  std::sort(r.encode.begin(), r.encode.end());
  const size_t n = r.render.size();
  std::printf("%-10s %4d x %-4d  render median %6.2f ms  p90 %6.2f ms   jpeg median %5.2f ms   %6.0f B/frame\n", name,
              width, height, r.render[n / 2], r.render[n * 9 / 10], r.encode[n / 2],
              static_cast<double>(r.bytes) / static_cast<double>(n));
}

void save(const std::string& dir, const std::string& name, uint64_t k, const std::string& jpeg) {
  std::ofstream(dir + "/" + name + "-" + std::to_string(k) + ".jpg", std::ios::binary) << jpeg;
}

// Frames along a path: forwards at 0.3 m/s turning at 0.6 rad/s (a cart on its way), from (0, 0).
void run(const char* name, const World& world, int width, int height, int frames, bool board,
         const std::string& save_dir) {
  CameraSettings s = CameraSettings::from_params();
  s.width_px = width;
  s.height_px = height;
  SimCamera cam(16e6, 1, s);
  if (board) {
    json::Value b;
    std::string error;
    json::parse(R"({"cols":9,"rows":6,"square_m":0.03,"x":0.5,"y":-0.075,"z":0})", &b, &error);
    cam.set_target(b);
  }
  Row row;
  const Twist twist{0.3, 0.6};
  for (int k = 0; k < frames; ++k) {
    CameraFrame f;
    std::string error;
    const double t = 0.1 * (k % 30);
    const Pose pose{0.2 * t, 0.05 * t, 0.3 * t};
    const double t0 = cpu_ms();
    if (!cam.capture(static_cast<uint64_t>(k), world, pose, &f, &error, board ? Twist{} : twist)) {
      std::fprintf(stderr, "%s\n", error.c_str());
      std::exit(1);
    }
    const double t1 = cpu_ms();
    row.render.push_back((t1 - t0) - cam.last_encode_ms());  // the encode's share in wall ms: near enough
    row.encode.push_back(cam.last_encode_ms());
    row.bytes += f.jpeg.size();
    if (!save_dir.empty() && (k == 0 || k == frames / 2)) save(save_dir, name, static_cast<uint64_t>(k), f.jpeg);
  }
  print(name, width, height, row);
}

// A room file: its boxes inside the square arena, and its look.
bool load_room(const std::string& path, World* world) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  json::Value msg;
  std::string error;
  if (!in || !json::parse(text.str(), &msg, &error)) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(), in ? error.c_str() : "cannot be read");
    return false;
  }
  WorldChange change;
  const json::Value* boxes = msg.find("boxes");
  json::Value boxes_msg;
  boxes_msg.type = json::Value::Type::kObject;
  if (boxes) boxes_msg.object.push_back({"add", *boxes});
  if (std::string e = parse_world_change("boxes", boxes_msg, ArenaParams{}, &change); !e.empty()) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(), e.c_str());
    return false;
  }
  apply_world_change(change, world);
  Look look;
  if (const json::Value* l = msg.find("look")) {
    if (std::string e = parse_look(*l, &look); !e.empty()) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), e.c_str());
      return false;
    }
  }
  world->set_look(look);
  return true;
}

std::string stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  return name.substr(0, name.find('.'));
}

}  // namespace
}  // namespace cart2d

int main(int argc, char** argv) {
  using namespace cart2d;
  int frames = 100;
  std::string save_dir;
  std::vector<std::string> rooms;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--save" && i + 1 < argc) save_dir = argv[++i];
    else if (!a.empty() && a.find_first_not_of("0123456789") == std::string::npos) frames = std::atoi(a.c_str());
    else rooms.push_back(a);
  }
  std::printf("simulated camera, %d frames each, quality %ld, CPU ms of one thread\n", frames,
              static_cast<long>(params::sim::camera::jpeg_quality));
  World plain{ArenaParams{}};
  const double boxes[][2] = {{0.6, 0.2}, {1.0, -0.3}, {1.4, 0.5}, {0.9, 0.9}, {1.6, 1.2}};
  for (const auto& p : boxes) {
    Box b;
    b.cx_m = p[0];
    b.cy_m = p[1];
    b.hx_m = b.hy_m = 0.1;
    b.height_m = 0.3;
    b.colour_rgb = 0xb8742f;
    plain.add(b);
  }
  std::printf("today's look: 5 boxes + arena walls + checkerboard, standing still\n");
  run("plain", plain, 320, 240, frames, true, "");
  run("plain", plain, 640, 480, frames, true, "");
  if (!rooms.empty()) std::printf("rooms (their boxes in the arena, driving at 0.3 m/s and turning at 0.6 rad/s)\n");
  for (const std::string& path : rooms) {
    World world{ArenaParams{}};
    if (!load_room(path, &world)) return 2;
    run(stem(path).c_str(), world, 320, 240, frames, false, save_dir);
  }
  return 0;
}
