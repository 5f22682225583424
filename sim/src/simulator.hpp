// The cart2d-sim application: a Rig run against the wall clock, its UART on a pseudo-terminal,
// ground truth and control on the side channel, and the EEPROM kept in a file.
#pragma once

#include <cstdint>

#include <csignal>
#include <memory>
#include <string>
#include <vector>

#include "control_channel.hpp"
#include "eeprom_store.hpp"
#include "hold.hpp"
#include "json.hpp"
#include "options.hpp"
#include "pacer.hpp"
#include "rig.hpp"
#include "sim_camera.hpp"
#include "world_change.hpp"

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
  std::string cmd_reset(const json::Value& msg, std::string* extra);
  void reset_now(ResetCause cause, double off_s);
  void apply_due_resets();
  uint64_t next_reset_cycle() const;
  std::string resets_json() const;
  std::string eeprom_ops_json() const;
  std::string cmd_profile(const json::Value& msg, std::string* extra);
  std::string cmd_run(const json::Value& msg);
  std::string cmd_hold(const json::Value& msg, std::string* extra);
  void run_slice(uint64_t slice);
  // The host wrote to the MCU: a hold lets the firmware answer (hold.hpp).
  void note_host_request();
  // Where a hold stops simulated time from now (Hold::kNone: nowhere).
  uint64_t hold_stop() const;
  // Whether simulated time stands at the hold now; counts the wall time it waits there.
  bool at_hold(double wall_s);
  std::string hold_json() const;
  uint64_t cycles_of(double seconds) const;
  static bool parent_gone();
  // world_commands.cpp
  std::string cmd_world_change(const std::string& type, const json::Value& msg, std::string* extra);
  void apply_change(const std::string& type, const WorldChange& change);
  void apply_due_changes();
  uint64_t next_change_cycle() const;
  std::string world_json() const;
  std::string world_counts_json() const;
  // "" if the cart's footprint at this pose overlaps nothing, else what it overlaps.
  std::string footprint_overlap(const Pose& pose) const;
  std::string cmd_speed(const json::Value& msg);
  std::string cmd_truth_rate(int client, const json::Value& msg);
  std::string cmd_link(const json::Value& msg, std::string* extra);
  std::string link_json() const;
  std::string stats_json() const;

  // truth.cpp
  std::string truth_json() const;

  // camera_commands.cpp
  std::string cmd_camera(int client, const json::Value& msg, std::string* extra);
  std::string cmd_look(const json::Value& msg);
  std::string cmd_target(const json::Value& msg);
  std::string cmd_markers(const json::Value& msg);  // marker_commands.cpp
  void camera_step(uint64_t end_cycle);

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
  Hold hold_;  // a "hold" message's: simulated time waits there (a lockstep with a consumer)
  bool quit_ = false;
  struct ScheduledChange {
    uint64_t cycle;  // the first cycle it applies at
    std::string type;
    WorldChange change;
  };
  std::vector<ScheduledChange> scheduled_;
  struct ScheduledReset {
    uint64_t cycle;  // the cycle it happens at
    ResetCause cause;
    double off_s;
  };
  std::vector<ScheduledReset> scheduled_resets_;  // in order of cycle, then of arrival
  std::unique_ptr<SimCamera> camera_;  // made once the MCU's clock is known  // in order of cycle, then of arrival
  bool mcu_dead_reported_ = false;
  bool auto_reset_ = true;  // --no-auto-reset, or the "link" message
  std::string firmware_path_;
  double wall_start_s_ = 0.0;
  double next_eeprom_check_s_ = 0.0;
};

}  // namespace cart2d
