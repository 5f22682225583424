// Planar dynamics of the differential-drive cart: a rigid body on two traction wheels (no sideways
// slip: the tyres' lateral grip is taken as unlimited, see sim/README.md) and a trailing swivel
// caster, each wheel driven through a gearbox with backlash by its own DC motor.
//
// Velocities: the body twist u = (v, ω) at the axle centre, and each motor's speed ω_m (output
// shaft). With the centre of mass at (x_g, 0) on the centre line, the body's mass matrix is
// diag(m, I) (I about the axle centre) and the velocity-product terms are those of Dhaouadi & Abu
// Hatab, "Dynamic Modelling of Differential-Drive Mobile Robots using Lagrange and Newton-Euler
// Methodologies: A Unified Framework", Adv. Robot. Autom. 2(2), 2013, eqs. (32)-(33) with d = x_g:
//   m·v̇ = F_v + m·x_g·ω²          I·ω̇ = M − m·x_g·ω·v
// F_v and M are the generalised forces of the contacts: the two drive rows (drivetrain.hpp: tyre
// friction ≤ μ·N and backlash), the caster's rolling-resistance and sideways rows (caster.hpp) and
// the walls. Each step is the time-stepping scheme of Stewart & Trinkle (IJNME 39, 1996): velocity
// level, the contact impulses of the step unknown, implicit in the motors' back-EMF damping and
// exact in every dry-friction law, with the velocity-product terms explicit. The impulses form a
// (nonlinear, monotone) complementarity problem, solved by projected Gauss-Seidel over the rows
// (Cottle, Pang & Stone, "The Linear Complementarity Problem", 1992, ch. 5; Erleben, "Numerical
// methods for linear complementarity problems in physics-based animation", SIGGRAPH 2013 course),
// each row solved exactly given the others, warm-started with the previous step's impulses and
// iterated to convergence. Walls are inelastic, frictionless velocity constraints J·u ≥ −gap/h,
// solved together as one block (the projection of u onto the feasible set in the mass metric):
// several points on one wall are redundant rows that single-row sweeps would converge on slowly.
#pragma once

#include <vector>

#include "caster.hpp"
#include "drivetrain.hpp"
#include "motor.hpp"         // TorqueLaw
#include "robot_params.hpp"  // params::traction, params::motor

namespace cart2d {

// Defaults: the robot (config/robot.toml).
struct BodyParams {
  double mass_kg = params::traction::mass_kg;
  double yaw_inertia_kgm2 = params::traction::inertia_kgm2;  // about the axle centre
  double wheel_radius_m = params::traction::radius_m;
  double track_m = params::traction::track_m;
  double com_x_m = params::traction::com_x_m;                // centre of mass, ahead of the axle (< 0: behind)
  double floor_friction = params::traction::floor_friction;  // μ, tyre on floor
  double drivetrain_inertia_kgm2 = params::motor::inertia_kgm2;  // per side: rotor·N² + gears + wheel
  double gearbox_coulomb_nm = params::motor::coulomb_friction_nm;  // per side, output shaft
  double backlash_rad = params::motor::backlash_rad;               // per side, output shaft
  CasterParams caster;
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

// One side's state (index 0 left, 1 right).
struct SideState {
  double motor_radps = 0.0;  // motor speed at the output shaft
  double wheel_radps = 0.0;  // traction wheel speed (+ = rolling forward)
  double slip_mps = 0.0;     // r·ω_wheel − tyre contact speed (+ = spinning forwards)
  double gap_rad = 0.0;      // backlash angle θ_motor − θ_wheel in [−β/2, β/2]
  double impulse_ns = 0.0;   // the last step's drive impulse (warm start)
};

// A wall constraint in the coordinates w = M^½·u, where the mass metric is Euclidean: a·w ≥ b.
struct MetricConstraint {
  double a0, a1, b;
};
// Scales constraints into that form (M = diag(m_v, m_w)); drops those that do not involve u.
void to_metric(const std::vector<VelocityConstraint>& constraints, double m_v, double m_w,
               std::vector<MetricConstraint>* out);
// Closest velocity to `free` in the metric M satisfying every constraint: the velocity an
// inelastic, frictionless contact leaves (its impulse M·(u − free) is the projection's).
Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<MetricConstraint>& rows);
Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<VelocityConstraint>& constraints);

// Wraps an angle into (−π, π].
double wrap_angle(double a);

class Body {
 public:
  explicit Body(const BodyParams& p);

  // Puts the cart at a pose, at rest (the caster and the gearboxes' backlash stay as they were).
  void place(const Pose& pose);
  void set_caster_angle(double angle_rad) { caster_angle_rad_ = wrap_angle(angle_rad); }
  // Advances by h seconds under the two motors' torque laws and the active wall contacts.
  void step(double h, const TorqueLaw& left, const TorqueLaw& right, const std::vector<VelocityConstraint>& contacts);
  // Moves with a prescribed twist, ignoring forces (scripted motion for tests): the wheels roll,
  // the caster trails.
  void advance_kinematic(double h, const Twist& twist);

  const Pose& pose() const { return pose_; }
  const Twist& twist() const { return twist_; }
  const SideState& side(int i) const { return sides_[i]; }
  double caster_angle_rad() const { return caster_angle_rad_; }
  // The floor's forces on the caster over the last step: rolling resistance along its wheel and
  // the sideways drag (newtons, signed along e_c and n_c of caster.hpp).
  double caster_rolling_force_n() const { return caster_roll_impulse_ / last_h_; }
  double caster_side_force_n() const { return caster_side_impulse_ / last_h_; }
  SupportLoads loads() const;
  // Gauss-Seidel sweeps the last step needed (for benchmarks and tests).
  int last_sweeps() const { return last_sweeps_; }
  const BodyParams& params() const { return p_; }

  static constexpr double kGravity = 9.80665;  // m/s², standard gravity

 private:
  struct Row {  // a dry-friction row: jv·v + jw·ω = 0 while |impulse| < bound
    double jv, jw, inv_compliance, bound, impulse;
  };
  void build_rows(double h, const std::vector<VelocityConstraint>& contacts, const SupportLoads& n,
                  const CasterJacobians& jc);
  DriveRow drive_row(double h, const TorqueLaw& law, const SideState& side, double load_n, int i) const;
  void warm_start(const DriveRow drive[2]);
  void solve(const DriveRow drive[2]);
  void finish(double h, const DriveRow drive[2]);
  double solve_walls();  // returns how much it changed the twist
  void apply(double jv, double jw, double impulse_ns);
  double contact_speed(int side) const;
  void integrate_pose(double h);

  BodyParams p_;
  Pose pose_;
  Twist twist_;
  SideState sides_[2];
  double caster_angle_rad_;
  double caster_roll_impulse_ = 0.0, caster_side_impulse_ = 0.0;  // warm start
  std::vector<Row> rows_;  // the caster's two rows
  std::vector<MetricConstraint> walls_;
  Twist wall_impulse_;  // the walls' generalised impulse M·Δu this step (N·s, N·m·s)
  int last_sweeps_ = 0;
  double last_h_ = 1.0;
};

}  // namespace cart2d
