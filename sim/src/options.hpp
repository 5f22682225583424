// Command line of cart2d-sim.
#pragma once

#include <cstdint>
#include <string>

#include "body.hpp"          // Pose
#include "robot_params.hpp"  // params::sim defaults

namespace cart2d {

struct Options {
  std::string firmware;
  std::string bootloader;      // --bootloader FILE: Optiboot in the boot section, BOOTRST programmed
  std::string check_firmware;  // --check-firmware FILE: check an uploaded HEX, print a JSON line, exit
  double speed = 1.0;  // ≤ 0: as fast as possible
  uint64_t seed = 0;
  std::string eeprom;  // empty: EepromStore::default_path()
  double truth_hz = params::sim::truth_hz;
  Pose start;
  double arena_margin_m = params::sim::arena_margin_m;
  int control_port = 0;  // 0: ephemeral
  bool verbose = false;
  bool quiet = false;
  bool start_paused = false;  // hold the MCU until a resume or run message
  std::string pty_link;       // a symlink to (re)point at the pty: a stable name across restarts
  bool exit_with_parent = false;  // stop when the launching process dies
  int grid_nodes = static_cast<int>(params::sim::grid_nodes);  // the square arena's node grid
  double grid_step_m = params::sim::grid_step_m;
  // The host's end of the serial line (usb_serial.hpp) and the Nano's DTR auto-reset.
  double host_baud = 115200.0;
  double usb_to_mcu_ms = 0.0, usb_to_host_ms = 0.0;  // USB delay each way
  double ftdi_latency_timer_ms = 0.0;                // > 0: FTDI packet/latency-timer mode
  bool auto_reset = true;                            // a host opening the port resets the MCU
};

// Fills *opts (pre-set with defaults) from argv. False with a message on a bad command line;
// *help is set when --help was asked for.
bool parse_options(int argc, char** argv, Options* opts, bool* help, std::string* error);
std::string usage();

}  // namespace cart2d
