#include "options.hpp"

#include <cerrno>   // errno
#include <cmath>    // std::isfinite
#include <cstdio>   // snprintf
#include <cstdlib>  // strtod, strtoull
#include <cstring>  // strcmp

namespace cart2d {

// A default for the help text (%g: six significant digits, so a float from robot.toml prints as written).
static std::string shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string usage() {
  const Options defaults;
  return "usage: cart2d-sim --firmware FILE [options]\n"
         "       cart2d-sim --check-firmware FILE\n"
         "  --check-firmware FILE check an Intel HEX as the firmware update does (strict records, what\n"
         "                        simavr reads, below the bootloader, the vector table); one JSON line\n"
         "  --firmware FILE       ATmega328P firmware: ELF or Intel HEX (required)\n"
         "  --bootloader FILE     a bootloader (Intel HEX in 0x7E00-0x7FFF, e.g. Optiboot) with BOOTRST:\n"
         "                        every reset starts it; avrdude -c arduino flashes through the pty\n"
         "  --speed F|max         simulated seconds per wall second (default 1 = real time)\n"
         "  --seed N              seed of every random fault (default 0)\n"
         "  --eeprom FILE         EEPROM image kept across runs\n"
         "                        (default $XDG_DATA_HOME/cart2d/sim-eeprom.bin)\n"
         "  --truth-hz HZ         ground-truth messages per simulated second (default " +
         shortest(defaults.truth_hz) + ")\n"
         "  --start X,Y,THETA     initial pose in m, m, rad (default 0,0,0)\n"
         "  --arena-margin M      walls this far outside the node grid (default " +
         shortest(defaults.arena_margin_m) + " m)\n"
         "  --control-port P      TCP port of the side channel on 127.0.0.1 (default: any free)\n"
         "  --paused              start paused (for runs driven to exact simulated times)\n"
         "  --pty-link PATH       also make PATH a symlink to the pty (a stable port name)\n"
         "  --exit-with-parent    stop when stdin (a pipe from the launcher) closes: the launcher died\n"
         "  --grid NODES,STEP     the square node grid the walls surround (default 10,0.2)\n"
         "  --host-baud B         the host's (USB adapter's) baud rate (default 115200)\n"
         "  --usb-latency MS[,MS] USB delay host->MCU[,MCU->host] in simulated ms (default 0)\n"
         "  --ftdi-latency-timer MS  hold MCU->host bytes until 62 or the timer expires (FTDI: 16)\n"
         "  --no-auto-reset       opening the port does not reset the MCU (DTR reset defeated)\n"
         "  --verbose | --quiet   more / less logging on stderr\n";
}

static bool parse_double(const char* s, double* out) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s, &end);
  if (errno || end == s || *end || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool parse_options(int argc, char** argv, Options* opts, bool* help, std::string* error) {
  *help = false;
  for (int i = 1; i < argc; ++i) {
    const char* arg = argv[i];
    auto value = [&](const char** out) {
      if (i + 1 >= argc) {
        *error = std::string(arg) + " needs a value";
        return false;
      }
      *out = argv[++i];
      return true;
    };
    const char* v = nullptr;
    if (!std::strcmp(arg, "--help") || !std::strcmp(arg, "-h")) {
      *help = true;
      return true;
    } else if (!std::strcmp(arg, "--verbose") || !std::strcmp(arg, "-v")) {
      opts->verbose = true;
    } else if (!std::strcmp(arg, "--pty-link")) {
      if (!value(&v)) return false;
      opts->pty_link = v;
    } else if (!std::strcmp(arg, "--grid")) {
      if (!value(&v)) return false;
      const std::string s = v;
      const size_t comma = s.find(',');
      double nodes = 0.0;
      if (comma == std::string::npos || !parse_double(s.substr(0, comma).c_str(), &nodes) ||
          !parse_double(s.substr(comma + 1).c_str(), &opts->grid_step_m) || nodes < 2 || nodes > 1000 ||
          nodes != std::floor(nodes) || opts->grid_step_m <= 0.0 || opts->grid_step_m > 10.0) {
        *error = "--grid takes NODES,STEP: 2 to 1000 nodes per side, a step in (0, 10] m";
        return false;
      }
      opts->grid_nodes = static_cast<int>(nodes);
    } else if (!std::strcmp(arg, "--host-baud")) {
      if (!value(&v)) return false;
      if (!parse_double(v, &opts->host_baud) || opts->host_baud < 300.0 || opts->host_baud > 4e6) {
        *error = "--host-baud takes a baud rate in [300, 4000000]";
        return false;
      }
    } else if (!std::strcmp(arg, "--usb-latency")) {
      if (!value(&v)) return false;
      const std::string s = v;
      const size_t comma = s.find(',');
      const bool ok = comma == std::string::npos
                          ? parse_double(v, &opts->usb_to_mcu_ms)
                          : parse_double(s.substr(0, comma).c_str(), &opts->usb_to_mcu_ms) &&
                                parse_double(s.substr(comma + 1).c_str(), &opts->usb_to_host_ms);
      if (comma == std::string::npos) opts->usb_to_host_ms = opts->usb_to_mcu_ms;
      if (!ok || opts->usb_to_mcu_ms < 0 || opts->usb_to_mcu_ms > 1000 || opts->usb_to_host_ms < 0 ||
          opts->usb_to_host_ms > 1000) {
        *error = "--usb-latency takes MS or TO_MCU_MS,TO_HOST_MS in [0, 1000]";
        return false;
      }
    } else if (!std::strcmp(arg, "--ftdi-latency-timer")) {
      if (!value(&v)) return false;
      if (!parse_double(v, &opts->ftdi_latency_timer_ms) || opts->ftdi_latency_timer_ms < 0 ||
          opts->ftdi_latency_timer_ms > 255) {
        *error = "--ftdi-latency-timer takes MS in [0, 255] (0 = off)";
        return false;
      }
    } else if (!std::strcmp(arg, "--no-auto-reset")) {
      opts->auto_reset = false;
    } else if (!std::strcmp(arg, "--exit-with-parent")) {
      opts->exit_with_parent = true;
    } else if (!std::strcmp(arg, "--paused")) {
      opts->start_paused = true;
    } else if (!std::strcmp(arg, "--quiet") || !std::strcmp(arg, "-q")) {
      opts->quiet = true;
    } else if (!std::strcmp(arg, "--check-firmware")) {
      if (!value(&v)) return false;
      opts->check_firmware = v;
    } else if (!std::strcmp(arg, "--bootloader")) {
      if (!value(&v)) return false;
      opts->bootloader = v;
    } else if (!std::strcmp(arg, "--firmware")) {
      if (!value(&v)) return false;
      opts->firmware = v;
    } else if (!std::strcmp(arg, "--speed")) {
      if (!value(&v)) return false;
      if (!std::strcmp(v, "max")) {
        opts->speed = 0.0;
      } else if (!parse_double(v, &opts->speed) || opts->speed <= 0.0) {
        *error = "--speed takes a positive factor or 'max'";
        return false;
      }
    } else if (!std::strcmp(arg, "--seed")) {
      if (!value(&v)) return false;
      char* end = nullptr;
      errno = 0;
      opts->seed = std::strtoull(v, &end, 0);
      if (errno || end == v || *end) {
        *error = "--seed takes an unsigned integer";
        return false;
      }
    } else if (!std::strcmp(arg, "--eeprom")) {
      if (!value(&v)) return false;
      opts->eeprom = v;
    } else if (!std::strcmp(arg, "--truth-hz")) {
      if (!value(&v)) return false;
      if (!parse_double(v, &opts->truth_hz) || opts->truth_hz < 0.0 || opts->truth_hz > 4000.0) {
        *error = "--truth-hz takes a rate in [0, 4000]";
        return false;
      }
    } else if (!std::strcmp(arg, "--start")) {
      if (!value(&v)) return false;
      const std::string s = v;
      const size_t a = s.find(','), b = s.find(',', a == std::string::npos ? a : a + 1);
      if (a == std::string::npos || b == std::string::npos ||
          !parse_double(s.substr(0, a).c_str(), &opts->start.x_m) ||
          !parse_double(s.substr(a + 1, b - a - 1).c_str(), &opts->start.y_m) ||
          !parse_double(s.substr(b + 1).c_str(), &opts->start.theta_rad)) {
        *error = "--start takes x,y,theta (m, m, rad)";
        return false;
      }
    } else if (!std::strcmp(arg, "--arena-margin")) {
      if (!value(&v)) return false;
      if (!parse_double(v, &opts->arena_margin_m) || opts->arena_margin_m < 0.0 || opts->arena_margin_m > 100.0) {
        *error = "--arena-margin takes a distance in [0, 100] m";
        return false;
      }
    } else if (!std::strcmp(arg, "--control-port")) {
      if (!value(&v)) return false;
      double port = 0;
      if (!parse_double(v, &port) || port < 0 || port > 65535 || port != static_cast<int>(port)) {
        *error = "--control-port takes a port number";
        return false;
      }
      opts->control_port = static_cast<int>(port);
    } else {
      *error = std::string("unknown option ") + arg;
      return false;
    }
  }
  if (opts->firmware.empty() && opts->check_firmware.empty()) {
    *error = "--firmware is required";
    return false;
  }
  return true;
}

}  // namespace cart2d
