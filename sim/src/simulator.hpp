// The cart2d-sim application: a Rig run against the wall clock, its UART on a pseudo-terminal,
// ground truth and control on the side channel, and the EEPROM kept in a file.
#pragma once

#include <cstdint>

#include <csignal>
#include <string>

#include "control_channel.hpp"
#include "eeprom_store.hpp"
#include "json.hpp"
#include "options.hpp"
#include "pacer.hpp"
#include "rig.hpp"

namespace cart2d {

class Simulator {
 public:
  explicit Simulator(const Options& opts);

  bool init(std::string* error);
  // The single line printed on stdout once everything listens.
  std::string ready_line() const;
  // Runs until a quit message or *stop becomes non-zero (signal); returns the exit status.
  int run(volatile std::sig_atomic_t* stop);

 private:
  // commands.cpp
  void handle_line(int client, const std::string& line);
  std::string dispatch(int client, const std::string& type, const json::Value& msg, std::string* extra);
  std::string cmd_place(const json::Value& msg);
  std::string cmd_reset(const json::Value& msg);
  std::string resets_json() const;
  std::string eeprom_ops_json() const;
  std::string cmd_profile(const json::Value& msg, std::string* extra);
  std::string cmd_run(const json::Value& msg);
  void run_slice(uint64_t slice);
  static bool parent_gone();
  std::string cmd_obstacles(const json::Value& msg);
  std::string cmd_speed(const json::Value& msg);
  std::string cmd_truth_rate(int client, const json::Value& msg);
  std::string cmd_link(const json::Value& msg, std::string* extra);
  std::string link_json() const;
  std::string stats_json() const;

  // truth.cpp
  std::string truth_json() const;

  void on_physics_step(uint64_t end_cycle);
  // The host opening or closing the serial port; an open pulses DTR, which resets a Nano.
  void serve_host_port();
  void dtr_reset();
  void publish_events();
  void save_eeprom(const char* why);
  void wait_for_io(double timeout_s);

  Options opts_;
  Rig rig_;
  ControlChannel control_;
  EepromStore eeprom_;
  Pacer pacer_;
  bool paused_ = false;
  uint64_t pause_at_cycle_ = UINT64_MAX;  // set by a "run" message
  bool quit_ = false;
  bool mcu_dead_reported_ = false;
  bool auto_reset_ = true;  // --no-auto-reset, or the "link" message
  std::string firmware_path_;
  double wall_start_s_ = 0.0;
  double next_eeprom_check_s_ = 0.0;
};

}  // namespace cart2d
