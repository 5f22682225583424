// The cart's control state machine: one tick() per 8 ms control period turns encoder counts and
// switch states into motor commands, according to the current mode (proto::Mode). Every fault
// and every stop goes through safe_stop(): motors disabled, controllers reset.
#pragma once

#include <stdint.h>

#include "odometry.hpp"
#include "path.hpp"
#include "polar_controller.hpp"
#include "protocol_table.hpp"  // proto::Mode, proto::Flag
#include "reset_routine.hpp"
#include "settings.hpp"
#include "speed_controller.hpp"

namespace core {

constexpr float kTickPeriod_s = 1.0f / params::control::tick_hz;
// The position loop runs at 125 / 2 = 62.5 Hz, the wheel-speed loop and odometry at 125 Hz: the
// position loop's time constants (>= 0.25 s with the default gains) are ~30 of its periods,
// and its float work (~7000 cycles) every tick would take the tick over its CPU budget.
constexpr uint8_t kPositionDivider = 2;
constexpr float kCountsPerRev =
    static_cast<float>(params::encoders::pulses_per_rev * params::encoders::edges_per_pulse);

struct TickInput {
  int16_t counts_left = 0;   // encoder counts since the previous tick, positive = forwards
  int16_t counts_right = 0;
  bool switch_left = false;  // front switches, true = pressed
  bool switch_right = false;
};

struct MotorOutput {
  MotorCommand pwm;
  bool enabled = false;
};

class Cart {
 public:
  // The path (its waypoint window) is passed in rather than owned so that on the AVR it can sit
  // in .bss (zero-filled at start-up) instead of .data (its zero bytes copied from flash).
  constexpr Cart(const Settings& settings, Path& path) : settings_(settings), path_(path) {}

  MotorOutput tick(const TickInput& in);

  // Commands. Those returning uint8_t answer with a proto::Reason, 0 when accepted; a refused
  // command changes nothing.
  // A pose given by the host (SET_POSE, RESET) or the reset routine; clears POSE_RESTORED.
  void set_pose(const Pose& pose);
  // The pose kept in RAM across a reset (core/retained.hpp): flagged POSE_RESTORED.
  void restore_pose(const Pose& pose);
  void go_to(const Point& target);
  uint8_t begin_path(float count, const float* xy, uint8_t n);
  uint8_t append_path(float index, const float* xy, uint8_t n);
  void start();
  void stop() { safe_stop(0); }
  uint8_t drive(float v_mps, float omega_radps);
  void start_reset_routine();
  void set_settings_defaulted(bool defaulted);

  proto::Mode mode() const { return mode_; }
  // Whether the last tick ran the position loop (every kPositionDivider-th tick in PATH mode).
  bool position_loop_ran() const {
    return mode_ == proto::MODE_PATH && position_countdown_ == kPositionDivider - 1;
  }
  uint16_t flags() const;
  const Odometry& odometry() const { return odometry_; }
  const Path& path() const { return path_; }
  const WheelSpeeds& wheel_targets() const { return wheel_targets_; }
  const MotorOutput& output() const { return output_; }
  float v_ref_mps() const { return v_ref_mps_; }
  float omega_ref_radps() const { return omega_ref_radps_; }
  float distance_to_waypoint_m() const { return distance_to_waypoint_m_; }

 private:
  void enter(proto::Mode mode);
  void safe_stop(uint16_t reason_flag);
  bool follow_path(float& v_mps, float& omega_radps);
  void run_reset_routine(const TickInput& in);
  void drive_wheels(const WheelSpeeds& measured);
  const OdometryScale& scale();
  bool front_contact() const { return switch_left_ || switch_right_; }
  float setting(uint8_t id) const { return settings_.get(id); }

  const Settings& settings_;
  Odometry odometry_;
  OdometryScale scale_;
  float stop_horizon_m_ = 0.0f;      // MotionLimits::stop_horizon_m, refreshed with scale_
  float overshoot_radius_m_ = 0.0f;  // kOvershootPassFactor * tol_pass, refreshed with scale_
  uint8_t scale_version_ = 0;
  bool scale_valid_ = false;
  SpeedController speed_;
  Path& path_;
  ResetRoutine routine_;
  proto::Mode mode_ = proto::MODE_IDLE;
  uint16_t sticky_flags_ = 0;  // the outcome of the last motion, and kLastingFlags
  bool switch_left_ = false;
  bool switch_right_ = false;
  float manual_v_mps_ = 0.0f;
  float manual_omega_radps_ = 0.0f;
  uint16_t manual_ticks_left_ = 0;
  uint8_t stall_ticks_ = 0;
  uint8_t position_countdown_ = 0;  // ticks until the position loop runs again
  float path_v_mps_ = 0.0f;         // the position loop's last output
  float path_omega_radps_ = 0.0f;
  float v_ref_mps_ = 0.0f;       // after the acceleration limiter
  float omega_ref_radps_ = 0.0f;
  float distance_to_waypoint_m_ = 0.0f;
  bool stopping_ = false;  // PolarOutput::stopping of the last position loop
  WheelSpeeds wheel_targets_;
  MotorOutput output_;
};

}  // namespace core
