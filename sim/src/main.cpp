// cart2d-sim: runs the cart2d firmware (ELF or Intel HEX) in simavr, coupled to a physical model
// of the cart.
// See sim/README.md.
#include <csignal>  // sigaction
#include <cstdio>   // printf, fflush

#include "firmware_file.hpp"  // check_firmware_command
#include "log.hpp"
#include "options.hpp"
#include "simulator.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;

void on_signal(int) { g_stop = 1; }

}  // namespace

int main(int argc, char** argv) {
  cart2d::Options opts;
  bool help = false;
  std::string error;
  if (!cart2d::parse_options(argc, argv, &opts, &help, &error)) {
    std::fprintf(stderr, "cart2d-sim: %s\n%s", error.c_str(), cart2d::usage().c_str());
    return 2;
  }
  if (help) {
    std::fputs(cart2d::usage().c_str(), stdout);
    return 0;
  }
  if (!opts.check_firmware.empty()) return cart2d::check_firmware_command(opts.check_firmware);
  if (opts.verbose) cart2d::set_log_level(cart2d::LogLevel::kDebug);
  if (opts.quiet) cart2d::set_log_level(cart2d::LogLevel::kWarn);

  struct sigaction sa = {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  cart2d::Simulator sim(opts);
  if (!sim.init(&error)) {
    LOG_ERROR("%s", error.c_str());
    return 1;
  }
  std::printf("%s\n", sim.ready_line().c_str());
  std::fflush(stdout);
  return sim.run(&g_stop);
}
