// Planar dynamics of the differential-drive cart: rigid body on two driven wheels that roll
// without lateral slip (non-holonomic), with the centre of mass on the wheel axis.
//
// Generalised velocities u = (v, ω); wheel speeds q̇ = (ω_L, ω_R) = T·u with
// T = (1/r)·[[1, −B/2], [1, B/2]] (B = traction track, r = traction radius). The equations of
// motion are those of Dhaouadi & Abu Hatab, "Dynamic Modelling of Differential-Drive Mobile Robots
// using Lagrange and Newton-Euler Methodologies: A Unified Framework", Adv. Robot. Autom. 2(2), 2013,
// eqs. (32)-(33) with d = 0, plus each wheel's reflected drivetrain inertia J:
//   (m + 2J/r²)·v̇            = (τ_L + τ_R)/r
//   (I + J·B²/(2r²))·ω̇       = (B/2r)·(τ_R − τ_L)
// τ_i = motor torque − Coulomb friction. The step is implicit in the speed-proportional torques
// (back-EMF, viscous) and solves Coulomb friction exactly as a complementarity problem (stick or
// slide, Stewart & Trinkle, IJNME 39, 1996), so a stalled wheel stays put without chattering.
// Wall contacts then act as inelastic velocity constraints J·u ≥ b, solved as the projection of
// u onto the feasible set in the metric of the mass matrix (the impulse an inelastic contact
// applies, see Stewart & Trinkle again).
#pragma once

#include <vector>

#include "motor.hpp"         // TorqueLaw
#include "robot_params.hpp"  // params::traction, params::motor

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct BodyParams {
  double mass_kg = params::traction::mass_kg;
  double yaw_inertia_kgm2 = params::traction::inertia_kgm2;
  double wheel_radius_m = params::traction::radius_m;
  double track_m = params::traction::track_m;
  double wheel_inertia_kgm2 = params::motor::inertia_kgm2;     // per wheel, about its axle: motor rotor·N² + gears + wheel
  double wheel_coulomb_nm = params::motor::coulomb_friction_nm;  // per wheel, at the axle
};

struct Pose {
  double x_m = 0.0;
  double y_m = 0.0;
  double theta_rad = 0.0;
};

struct Twist {
  double v_mps = 0.0;
  double omega_radps = 0.0;
};

// jv·v + jw·ω ≥ min_rate: a contact whose gap may close no faster than min_rate allows.
struct VelocityConstraint {
  double jv = 0.0;
  double jw = 0.0;
  double min_rate = 0.0;
};

// One implicit step of the two-wheel drivetrain in wheel coordinates, exposed for tests:
// (Mq + h·C)·q1 = Mq·q0 + h·(drive + f), f_i ∈ [−tc, tc] Coulomb friction (complementary to q1_i).
// mq is the 2×2 wheel-space mass matrix (row-major), c the per-wheel damping.
void solve_wheel_step(const double mq[4], const double c[2], const double q0[2], const double drive[2],
                      double coulomb_nm, double h, double q1[2]);

// Closest velocity to `free` (metric diag(m_v, m_w)) satisfying every constraint.
Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<VelocityConstraint>& constraints);

// Wraps an angle into (−π, π].
double wrap_angle(double a);

class Body {
 public:
  explicit Body(const BodyParams& p);

  // Puts the cart at a pose, at rest.
  void place(const Pose& pose);
  // Advances by h seconds under the two motors' torque laws and the active contacts.
  void step(double h, const TorqueLaw& left, const TorqueLaw& right, const std::vector<VelocityConstraint>& contacts);
  // Moves with a prescribed twist, ignoring forces (scripted motion for tests).
  void advance_kinematic(double h, const Twist& twist);

  const Pose& pose() const { return pose_; }
  const Twist& twist() const { return twist_; }
  double wheel_speed_l_radps() const;
  double wheel_speed_r_radps() const;
  // Generalised masses along v and ω (the mass matrix is diagonal for d = 0).
  double mass_v() const { return m_v_; }
  double mass_w() const { return m_w_; }
  const BodyParams& params() const { return p_; }

 private:
  void integrate_pose(double h);

  BodyParams p_;
  double m_v_, m_w_;
  double mq_[4];
  Pose pose_;
  Twist twist_;
};

}  // namespace cart2d
