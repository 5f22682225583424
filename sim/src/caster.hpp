// The passive swivel caster: the cart's third support point, behind the axle on the centre line.
//
// Layout (body frame, x forward from the axle centre, y left): swivel axis S = (x_S, 0); the wheel
// trails the axis by t, so its floor contact is P = S − t·e_c with e_c = (cos φ, sin φ) the
// direction the caster wheel rolls forwards and φ the swivel angle (0: trailing straight behind
// while the cart drives forwards; ±π: trailing while it backs up). n_c = (−sin φ, cos φ).
//
// Kinematics of a towed wheel with trail (the swivelling wheel of Pacejka's shimmy analysis,
// "Tire and Vehicle Dynamics", 3rd ed. 2012, ch. 6, here with a laterally rigid tyre): the contact moves at
//   V_P = V_S − t·(ω + φ̇)·n_c,    V_S = (v, ω·x_S)
// so its rolling speed is V_r = V_S·e_c and its sideways speed e − t·φ̇ with e = V_S·n_c − t·ω.
//
// Forces on the floor contact (what the body feels, at P):
// - rolling resistance F_r = c_rr·N along −e_c (Coulomb-like: it also holds a caster at rest),
//   Gillespie, "Fundamentals of Vehicle Dynamics" (SAE 1992), ch. 4 (road loads): F = c_rr·N;
// - a sideways force F_l along n_c. The caster's fork and wheel are light, so its moment about the
//   swivel axis balances: t·F_l equals the swivel bearing's dry friction τ_s. Hence the caster,
//   while misaligned with the motion of its contact (e ≠ 0), swings at φ̇ = e/t and drags the body
//   sideways with F_l = τ_s/t; if the floor cannot give that much (μ_c·N < τ_s/t: a stiff swivel)
//   it stays put and scrubs sideways with F_l = μ_c·N. Either way |F_l| ≤ F_max = min(τ_s/t, μ_c·N),
//   reached while e ≠ 0 and complementary to it: one Coulomb row on e. Aligned (e = 0), it can hold
//   up to F_max, like a fixed wheel.
#pragma once

#include "robot_params.hpp"  // params::caster

namespace cart2d {

// Defaults: the robot (config/robot.toml, [caster]).
struct CasterParams {
  double swivel_x_m = params::caster::swivel_x_m;
  double trail_m = params::caster::trail_m;
  double rolling_resistance = params::caster::rolling_resistance;        // c_rr, rolling force / load
  double swivel_friction_arm_m = params::caster::swivel_friction_arm_m;  // τ_s / N
  double lateral_friction = params::caster::lateral_friction;            // μ_c
  double initial_angle_rad = params::caster::initial_angle_rad;
};

// Body-frame Jacobians of the caster's two rows over (v, ω) at swivel angle φ.
struct CasterJacobians {
  double roll_v, roll_w;  // V_r = roll_v·v + roll_w·ω
  double side_v, side_w;  // e   = side_v·v + side_w·ω (sideways speed of the contact, swivel held)
};
CasterJacobians caster_jacobians(const CasterParams& p, double angle_rad);
CasterJacobians caster_jacobians(const CasterParams& p, double cos_angle, double sin_angle);

// Floor contact point P in the body frame.
double caster_contact_x_m(const CasterParams& p, double angle_rad);
double caster_contact_y_m(const CasterParams& p, double angle_rad);
double caster_contact_x_m(const CasterParams& p, double cos_angle, double sin_angle);
double caster_contact_y_m(const CasterParams& p, double cos_angle, double sin_angle);

// Largest rolling resistance and sideways force at caster load N (newtons).
double caster_rolling_limit_n(const CasterParams& p, double load_n);
double caster_side_limit_n(const CasterParams& p, double load_n);

// The swivel rate given the sideways speed e the body gives the contact with the swivel held, m/s:
// e/t if the swivel turns (it can, when τ_s/t ≤ μ_c·N), else 0 (the caster scrubs).
double caster_swivel_rate_radps(const CasterParams& p, double side_speed_mps);

// Static loads on the three supports: the two traction tyres (at y = ±track/2 on the axle) and the
// caster contact, from the weight at the centre of mass (com_x, 0): force and moment balance of a
// three-point support (equilibrium of a rigid body in three dimensions: e.g. Meriam & Kraige,
// "Engineering Mechanics: Statics", ch. 3). Dynamic load transfer (acceleration, pitch) is neglected (sim/README.md).
struct SupportLoads {
  double left_n = 0.0, right_n = 0.0, caster_n = 0.0;
};
SupportLoads support_loads(double weight_n, double com_x_m, double track_m, double caster_x_m, double caster_y_m);

}  // namespace cart2d
