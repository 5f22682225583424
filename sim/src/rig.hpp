// The simulated robot, assembled: the firmware in simavr, the parts wired to its pins, and the
// physical cart in its arena, advanced together by ONE periodic cycle timer (the physics step).
// Everything here runs in simulated time only; the application around it (simulator.cpp) adds
// pacing, the pseudo-terminal and the side channel. Tests drive a Rig directly.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cart.hpp"
#include "cpu_meter.hpp"
#include "eeprom_part.hpp"
#include "encoder_part.hpp"
#include "faults.hpp"
#include "hbridge_part.hpp"
#include "mcu.hpp"
#include "measuring_wheels.hpp"
#include "pin_driver.hpp"
#include "robot_params.hpp"  // params::sim, params::control
#include "switch_part.hpp"
#include "uart_link.hpp"
#include "world.hpp"

namespace cart2d {

struct RigConfig {
  std::string firmware;
  std::string bootloader;  // Intel HEX for the boot section (Optiboot); empty: none, resets start at 0
  uint64_t seed = 0;
  Pose start;
  double arena_margin_m = params::sim::arena_margin_m;
  int grid_nodes = static_cast<int>(params::sim::grid_nodes);  // per side of the square arena
  double grid_step_m = params::sim::grid_step_m;
  bool open_pty = true;
};

class Rig {
 public:
  Rig();
  ~Rig();
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  bool init(const RigConfig& config, std::string* error);

  // Runs the MCU (and with it the physics) for n more cycles; false if the MCU has stopped.
  bool run_cycles(uint64_t n);
  double time_s() const { return mcu_.time_s(); }
  uint64_t cycle() const { return mcu_.cycle(); }

  // Resets the MCU (the cart coasts on, EEPROM kept): by default the reset button (or DTR);
  // kPowerOn / kBrownOut with the power off / the supply dipped for off_s first. Every reset,
  // the watchdog's too, re-arms the parts and is reported by take_reset_events().
  void reset_mcu(ResetCause cause = ResetCause::kExternal, double off_s = 0.0);
  struct ResetEvent {
    ResetCause cause;
    double t_s;  // when the reset began
  };
  std::vector<ResetEvent> take_reset_events() { return std::move(reset_events_); }
  // The firmware's main loop hangs at its next wake from sleep (see Mcu::request_hang).
  void inject_hang() { mcu_.request_hang(); }
  // Teleports the cart (at rest); the wheels do not turn, so no encoder edges.
  void place(const Pose& pose);
  // After any change to world()'s rectangles: those under the cart are deferred (World), the
  // switches and contacts re-measured.
  void world_changed();
  void set_faults(const Faults& faults);
  const Faults& faults() const { return faults_; }
  // Replaces the dynamics by a prescribed twist (tests); nullopt restores the dynamics.
  void set_scripted_twist(std::optional<Twist> twist) { scripted_ = twist; }

  // Called after every physics step with the cycle the step ended at.
  void set_step_hook(std::function<void(uint64_t)> hook) { step_hook_ = std::move(hook); }

  Mcu& mcu() { return mcu_; }
  const Mcu& mcu() const { return mcu_; }
  UartLink& uart() { return uart_; }
  const UartLink& uart() const { return uart_; }
  const Cart& cart() const { return *cart_; }
  World& world() { return world_; }
  const World& world() const { return world_; }
  ContactMonitor& contacts() { return contacts_; }
  const ContactMonitor& contacts() const { return contacts_; }
  const CpuMeter& cpu() const { return *cpu_; }
  CpuMeter& cpu() { return *cpu_; }
  const MotorDuties& duties() const { return duties_; }
  const EepromPart& eeprom() const { return *eeprom_; }
  const EncoderPart& encoder_left() const { return *enc_l_; }
  const EncoderPart& encoder_right() const { return *enc_r_; }
  double enc_dist_l_m() const { return enc_dist_l_m_; }
  double enc_dist_r_m() const { return enc_dist_r_m_; }
  uint64_t physics_steps() const { return physics_steps_; }
  uint64_t step_cycles() const { return step_cycles_; }
  double step_s() const { return step_s_; }

 private:
  static uint64_t physics_timer(avr_t* avr, uint64_t when, void* param);
  uint64_t physics_step(uint64_t when);
  void arm_physics();
  void after_mcu_reset(ResetCause cause);

  Mcu mcu_;
  World world_;
  std::unique_ptr<Cart> cart_;
  ContactMonitor contacts_;
  MeasuringWheelParams wheels_;
  Faults faults_;
  QuadratureFaults qfaults_;
  std::unique_ptr<PinDriver> pins_;
  std::unique_ptr<EepromPart> eeprom_;
  std::unique_ptr<HBridgePart> hbridge_;
  std::unique_ptr<SwitchPart> switches_;
  std::unique_ptr<EncoderPart> enc_l_, enc_r_;
  UartLink uart_;
  std::unique_ptr<CpuMeter> cpu_;
  MotorDuties duties_;
  std::optional<Twist> scripted_;
  std::function<void(uint64_t)> step_hook_;
  std::vector<ResetEvent> reset_events_;

  // The physics step: robot.toml's physics_step_s rounded to a whole number of CPU cycles.
  static constexpr uint64_t kStepCycles =
      static_cast<uint64_t>(static_cast<double>(params::sim::physics_step_s) * params::control::f_cpu_hz + 0.5);
  static_assert(kStepCycles > 0, "physics_step_s is shorter than half a CPU cycle");
  const double step_s_ = static_cast<double>(kStepCycles) / params::control::f_cpu_hz;  // exactly kStepCycles cycles
  const uint64_t step_cycles_ = kStepCycles;
  uint64_t next_step_cycle_ = 0;
  uint64_t physics_steps_ = 0;
  double enc_dist_l_m_ = 0.0, enc_dist_r_m_ = 0.0;
};

}  // namespace cart2d
