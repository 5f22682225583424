// The physics step's cost against the size of the world: CPU time per step of Cart::step
// (dynamics, contact probes through the broad phase, switches) plus ContactMonitor::update, as the
// rig runs them, while the cart drives a 1.6 m square, with 0, 100, 5000 and 50 000 boxes scattered 0.25 m or more from its
// route in a 22 m arena (so many are near it, none touched). Prints a table; not a test.
//
//   build/sim/sim_world_bench
#include <sys/resource.h>  // getrusage

#include <cmath>
#include <cstdio>
#include <vector>

#include "cart.hpp"
#include "rng.hpp"

namespace cart2d {
namespace {

constexpr double kH = 0.00025;  // the rig's physics step (s)

double cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay;
  const double t = std::fmax(0.0, std::fmin(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)));
  return std::hypot(px - ax - t * dx, py - ay - t * dy);
}

World scattered(int count) {
  const double route[5][2] = {{0, 0}, {1.6, 0}, {1.6, 1.6}, {0, 1.6}, {0, 0}};
  World w;
  w.add_boundary(-10, -10, 12, 12);
  Rng rng(1);
  int placed = 0;
  while (placed < count) {
    Box b;
    b.hx_m = 0.05 + 0.1 * rng.uniform();
    b.hy_m = 0.05 + 0.1 * rng.uniform();
    b.cx_m = -9.5 + 21 * rng.uniform();
    b.cy_m = -9.5 + 21 * rng.uniform();
    double near = 1e9;
    for (int k = 0; k < 4; ++k)
      near = std::fmin(near, segment_distance(b.cx_m, b.cy_m, route[k][0], route[k][1], route[k + 1][0], route[k + 1][1]));
    if (near - std::hypot(b.hx_m, b.hy_m) < 0.25) continue;
    w.add(b);
    ++placed;
  }
  return w;
}

// Drives the square: straight at 40 % duty along each side (steered back onto its line) until
// past the corner, then a quarter turn on the spot, four times. Returns CPU microseconds per step and the steps taken.
void drive(World& world, double* step_us, long* steps, long* contacts) {
  Cart cart{CartParams{}};
  cart.place({0.0, 0.0, 0.0});
  cart.sense(world);
  ContactMonitor monitor;
  const double corners[4][2] = {{1.6, 0}, {1.6, 1.6}, {0, 1.6}, {0, 0}};
  long n = 0;
  const double t0 = cpu_s();
  for (int side = 0; side < 4; ++side) {
    const double heading = side * 1.5707963267948966;
    auto progress = [&] {
      return (cart.pose().x_m - corners[side][0]) * std::cos(heading) + (cart.pose().y_m - corners[side][1]) * std::sin(heading);
    };
    auto step = [&](double dl, double dr) {
      cart.step(kH, dl, dr, world);
      monitor.update(n * kH, world, cart.pose(), cart.params().geometry, cart.probes());
      ++n;
    };
    // Lateral offset from the side's line (+ = to its left): a P law on it and the heading keeps
    // the cart on the route.
    auto offset = [&] {
      return -(cart.pose().x_m - corners[side][0]) * std::sin(heading) + (cart.pose().y_m - corners[side][1]) * std::cos(heading);
    };
    for (int i = 0; i < 40000 && progress() < 0.0; ++i) {
      const double steer = 0.5 * wrap_angle(heading - cart.pose().theta_rad) - 2.0 * offset();
      step(0.4 - steer, 0.4 + steer);
    }
    for (int i = 0; i < 2000; ++i) step(0.0, 0.0);  // stop
    const double target = heading + 1.5707963267948966;
    for (int i = 0; i < 40000 && wrap_angle(target - cart.pose().theta_rad) > 0.01; ++i) step(-0.4, 0.4);
    for (int i = 0; i < 2000; ++i) step(0.0, 0.0);
  }
  *step_us = 1e6 * (cpu_s() - t0) / static_cast<double>(n);
  *steps = n;
  *contacts = monitor.box_contacts() + monitor.wall_contacts();
}

}  // namespace
}  // namespace cart2d

int main() {
  using namespace cart2d;
  std::printf("| boxes | CPU per physics step, us (best of 5) | steps | contacts |\n|---|---|---|---|\n");
  for (int count : {0, 100, 5000, 50000}) {
    World world = scattered(count);
    double best = 1e9, step_us = 0;
    long steps = 0, contacts = 0;
    drive(world, &step_us, &steps, &contacts);  // warm-up (and the broad phase's build)
    for (int run = 0; run < 5; ++run) {
      drive(world, &step_us, &steps, &contacts);
      best = std::fmin(best, step_us);
    }
    std::printf("| %d | %.3f | %ld | %ld |\n", count, best, steps, contacts);
    std::fflush(stdout);
  }
  return 0;
}
