// A permanent-magnet DC gearmotor driven by an LMD18200 H-bridge, every quantity referred to the
// output shaft (gear ratio folded in; see [motor] in config/robot.toml).
//
// Model (e.g. Franklin, Powell & Emami-Naeini, "Feedback Control of Dynamic Systems", §2.3, DC motor):
//   v = R·i + L·di/dt + k·ω        (armature circuit; k = back-EMF constant = torque constant in SI)
//   τ = k·i − b·ω − τc·sgn(ω)      (shaft torque after viscous and Coulomb friction)
// The electrical time constant L/R (≈ 0.4 ms for such motors) is much shorter than the
// mechanical one (≈ 0.1 s) and the 20 µs PWM period is shorter still, so L is neglected:
// i = (v − k·ω)/R with v the mean terminal voltage over a PWM period.
#pragma once

#include "robot_params.hpp"  // params::motor

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct MotorParams {
  double battery_v = params::motor::battery_v;
  double resistance_ohm = params::motor::resistance_ohm;
  double torque_constant_nm_per_a = params::motor::torque_constant_nm_per_a;  // = back-EMF constant, V·s/rad
  double viscous_friction_nms = params::motor::viscous_friction_nms;          // N·m·s/rad
  double coulomb_friction_nm = params::motor::coulomb_friction_nm;            // N·m
  double inertia_kgm2 = params::motor::inertia_kgm2;                          // rotor·N² + gears + wheel
  double current_limit_a = params::motor::current_limit_a;
};

// Mean terminal voltage for a signed duty in [−1, 1] (sign = DIRECTION pin: + forward).
// LMD18200 datasheet, "sign/magnitude PWM": while PWM is low the bridge shorts the motor through
// its two high-side switches (brake), so the terminals average V_batt·duty, not an open circuit.
double terminal_voltage_v(const MotorParams& p, double signed_duty);

// Armature current at a terminal voltage and shaft speed, clamped at the bridge's current limit.
double current_a(const MotorParams& p, double voltage_v, double speed_radps);

// The motor torque as a linear function of the shaft speed over one physics step:
// τ_motor(ω) = drive_nm − damping_nms·ω, Coulomb friction excluded (the body solves it exactly).
// Below the current limit drive = k·v/R and damping = k²/R + b (back-EMF acts as a damper);
// at the limit the current is constant: drive = k·i_max·sgn, damping = b.
struct TorqueLaw {
  double drive_nm = 0.0;
  double damping_nms = 0.0;
};
TorqueLaw torque_law(const MotorParams& p, double voltage_v, double speed_radps);

// Steady speed at a terminal voltage against a load torque that opposes the motion
// (k·(v − k·ω)/R = b·ω + τc + load), rad/s; 0 if the motor cannot turn.
double steady_speed_radps(const MotorParams& p, double voltage_v, double load_nm = 0.0);

}  // namespace cart2d
