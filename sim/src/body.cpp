#include "body.hpp"

#include <algorithm>  // std::clamp, std::max
#include <cmath>      // std::sin, std::cos, std::fabs, std::fmod, std::sqrt
#include <limits>     // std::numeric_limits

namespace cart2d {

namespace {
// Gauss-Seidel stops when no row changed a velocity by more than this in a sweep (m/s, or rad/s
// times a metre). A sweep typically shrinks the error a hundredfold or more, so what is left is
// ~1e-12 m/s; a stuck contact creeps by less than 1e-10 m per second even when convergence is slow.
// The impulses themselves need not settle: with redundant contacts (two points on one wall, a body
// both pushed and stuck) their split is not unique, only the motion is.
constexpr double kVelocityTol = 1e-10;
// A safety net only: converged steps take a few sweeps (sim/README.md gives the distribution).
constexpr int kMaxSweeps = 500;
}  // namespace

double wrap_angle(double a) {
  constexpr double kPi = 3.14159265358979323846;
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

// Solves the 2×2 system [g0 g1; g2 g3]·x = r by Cramer's rule; false if singular.
static bool solve2(const double g[4], const double r[2], double x[2]) {
  const double det = g[0] * g[3] - g[1] * g[2];
  if (std::fabs(det) < 1e-300) return false;
  x[0] = (r[0] * g[3] - g[1] * r[1]) / det;
  x[1] = (g[0] * r[1] - r[0] * g[2]) / det;
  return true;
}

void to_metric(const std::vector<VelocityConstraint>& constraints, double m_v, double m_w,
               std::vector<MetricConstraint>* out) {
  out->clear();
  const double sv = std::sqrt(m_v), sw = std::sqrt(m_w);
  for (const auto& c : constraints) {
    const MetricConstraint r{c.jv / sv, c.jw / sw, c.min_rate};
    if (r.a0 * r.a0 + r.a1 * r.a1 < 1e-18) continue;  // e.g. the disc against a wall it runs along
    out->push_back(r);
  }
}

Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<VelocityConstraint>& constraints) {
  std::vector<MetricConstraint> rows;
  to_metric(constraints, m_v, m_w, &rows);
  return project_contacts(free, m_v, m_w, rows);
}

Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<MetricConstraint>& rows) {
  const double sv = std::sqrt(m_v), sw = std::sqrt(m_w);
  const double w0[2] = {free.v_mps * sv, free.omega_radps * sw};
  auto feasible = [&](const double w[2]) {
    for (const auto& r : rows)
      if (r.a0 * w[0] + r.a1 * w[1] < r.b - 1e-9) return false;
    return true;
  };
  if (feasible(w0)) return free;

  // The projection lies on a face of the feasible polygon: try every single and every pair of
  // active constraints and keep the closest feasible candidate.
  double best[2] = {0.0, 0.0};
  double best_d2 = std::numeric_limits<double>::infinity();
  auto consider = [&](const double w[2]) {
    if (!feasible(w)) return;
    const double d2 = (w[0] - w0[0]) * (w[0] - w0[0]) + (w[1] - w0[1]) * (w[1] - w0[1]);
    if (d2 < best_d2) {
      best_d2 = d2;
      best[0] = w[0];
      best[1] = w[1];
    }
  };
  for (size_t i = 0; i < rows.size(); ++i) {
    const MetricConstraint& r = rows[i];
    const double n2 = r.a0 * r.a0 + r.a1 * r.a1;
    const double viol = r.b - (r.a0 * w0[0] + r.a1 * w0[1]);
    const double w[2] = {w0[0] + r.a0 * viol / n2, w0[1] + r.a1 * viol / n2};
    consider(w);
    for (size_t j = i + 1; j < rows.size(); ++j) {
      const double g[4] = {r.a0, r.a1, rows[j].a0, rows[j].a1};
      const double rhs[2] = {r.b, rows[j].b};
      double wj[2];
      if (solve2(g, rhs, wj)) consider(wj);
    }
  }
  Twist out;  // nothing feasible (wedged between conflicting walls): stop
  if (best_d2 < std::numeric_limits<double>::infinity()) {
    out.v_mps = best[0] / sv;
    out.omega_radps = best[1] / sw;
  }
  return out;
}

Body::Body(const BodyParams& p) : p_(p), caster_angle_rad_(wrap_angle(p.caster.initial_angle_rad)) {
  rows_.reserve(2);
}

void Body::place(const Pose& pose) {
  pose_ = pose;
  pose_.theta_rad = wrap_angle(pose.theta_rad);
  twist_ = Twist{};
  for (SideState& s : sides_) {
    const double gap = s.gap_rad;
    s = SideState{};
    s.gap_rad = gap;
  }
  caster_roll_impulse_ = caster_side_impulse_ = 0.0;
}

SupportLoads Body::loads() const {
  return support_loads(p_.mass_kg * kGravity, p_.com_x_m, p_.track_m, caster_contact_x_m(p_.caster, caster_angle_rad_),
                       caster_contact_y_m(p_.caster, caster_angle_rad_));
}

// Lateral position of each tyre: left (0) at +track/2.
static double tyre_y(const BodyParams& p, int side) { return side == 0 ? p.track_m / 2.0 : -p.track_m / 2.0; }

double Body::contact_speed(int side) const { return twist_.v_mps - twist_.omega_radps * tyre_y(p_, side); }

void Body::apply(double jv, double jw, double impulse_ns) {
  twist_.v_mps += jv * impulse_ns / p_.mass_kg;
  twist_.omega_radps += jw * impulse_ns / p_.yaw_inertia_kgm2;
}

void Body::build_rows(double h, const std::vector<VelocityConstraint>& contacts, const SupportLoads& n,
                      const CasterJacobians& jc) {
  auto inv_compliance = [&](double jv, double jw) {
    return 1.0 / (jv * jv / p_.mass_kg + jw * jw / p_.yaw_inertia_kgm2);
  };
  rows_.clear();
  const double roll = h * caster_rolling_limit_n(p_.caster, n.caster_n);
  const double side = h * caster_side_limit_n(p_.caster, n.caster_n);
  rows_.push_back({jc.roll_v, jc.roll_w, inv_compliance(jc.roll_v, jc.roll_w), roll,
                   std::clamp(caster_roll_impulse_, -roll, roll)});
  rows_.push_back({jc.side_v, jc.side_w, inv_compliance(jc.side_v, jc.side_w), side,
                   std::clamp(caster_side_impulse_, -side, side)});
  to_metric(contacts, p_.mass_kg, p_.yaw_inertia_kgm2, &walls_);
  wall_impulse_ = Twist{};
}

void Body::solve(const DriveRow drive[2]) {
  int sweep = 0;
  while (sweep < kMaxSweeps) {
    ++sweep;
    double change = 0.0;
    for (int i = 0; i < 2; ++i) {
      const double next = solve_drive_row(drive[i], contact_speed(i), sides_[i].impulse_ns);
      const double d = next - sides_[i].impulse_ns;
      apply(1.0, -tyre_y(p_, i), d);
      sides_[i].impulse_ns = next;
      const double motor_compliance = drive[i].radius_m * drive[i].radius_m / drive[i].motor.inertia_kgm2;
      change = std::max(change, std::fabs(d) * (drive[i].body_compliance + motor_compliance));
    }
    for (Row& row : rows_) {
      const double rate = row.jv * twist_.v_mps + row.jw * twist_.omega_radps;
      const double next = std::clamp(row.impulse - rate * row.inv_compliance, -row.bound, row.bound);
      const double d = next - row.impulse;
      apply(row.jv, row.jw, d);
      row.impulse = next;
      change = std::max(change, std::fabs(d) / row.inv_compliance);
    }
    if (!walls_.empty()) change = std::max(change, solve_walls());
    if (change <= kVelocityTol) break;
  }
  last_sweeps_ = sweep;
}

double Body::solve_walls() {
  const double m = p_.mass_kg, inertia = p_.yaw_inertia_kgm2;
  const Twist without{twist_.v_mps - wall_impulse_.v_mps / m, twist_.omega_radps - wall_impulse_.omega_radps / inertia};
  const Twist with = project_contacts(without, m, inertia, walls_);
  const double change = std::max(std::fabs(with.v_mps - twist_.v_mps), std::fabs(with.omega_radps - twist_.omega_radps));
  wall_impulse_ = Twist{m * (with.v_mps - without.v_mps), inertia * (with.omega_radps - without.omega_radps)};
  twist_ = with;
  return change;
}

void Body::step(double h, const TorqueLaw& left, const TorqueLaw& right,
                const std::vector<VelocityConstraint>& contacts) {
  last_h_ = h;
  const double cos_phi = std::cos(caster_angle_rad_), sin_phi = std::sin(caster_angle_rad_);
  const SupportLoads n = support_loads(p_.mass_kg * kGravity, p_.com_x_m, p_.track_m,
                                       caster_contact_x_m(p_.caster, cos_phi, sin_phi),
                                       caster_contact_y_m(p_.caster, cos_phi, sin_phi));
  // Free motion: the velocity-product terms of an off-axle centre of mass (explicit).
  const double m = p_.mass_kg, xg = p_.com_x_m, v0 = twist_.v_mps, w0 = twist_.omega_radps;
  twist_.v_mps = v0 + h * xg * w0 * w0;
  twist_.omega_radps = w0 - h * m * xg * w0 * v0 / p_.yaw_inertia_kgm2;

  DriveRow drive[2];
  drive[0] = drive_row(h, left, sides_[0], n.left_n, 0);
  drive[1] = drive_row(h, right, sides_[1], n.right_n, 1);
  build_rows(h, contacts, n, caster_jacobians(p_.caster, cos_phi, sin_phi));
  warm_start(drive);
  solve(drive);
  finish(h, drive);
}

DriveRow Body::drive_row(double h, const TorqueLaw& law, const SideState& side, double load_n, int i) const {
  const double j = p_.drivetrain_inertia_kgm2, y = tyre_y(p_, i), r = p_.wheel_radius_m;
  DriveRow row;
  row.motor = MotorStep{j * side.motor_radps + h * law.drive_nm, j + h * law.damping_nms, h * p_.gearbox_coulomb_nm};
  row.radius_m = r;
  row.body_compliance = 1.0 / p_.mass_kg + y * y / p_.yaw_inertia_kgm2;
  row.gap_fwd_mps = r * (p_.backlash_rad / 2 - side.gap_rad) / h;
  row.gap_back_mps = r * (p_.backlash_rad / 2 + side.gap_rad) / h;
  row.max_impulse_ns = h * p_.floor_friction * load_n;
  return row;
}

// Last step's impulses, clamped to this step's bounds, are the first guess (the walls start from 0).
void Body::warm_start(const DriveRow drive[2]) {
  for (int i = 0; i < 2; ++i) {
    sides_[i].impulse_ns = std::clamp(sides_[i].impulse_ns, -drive[i].max_impulse_ns, drive[i].max_impulse_ns);
    apply(1.0, -tyre_y(p_, i), sides_[i].impulse_ns);
  }
  for (const Row& row : rows_) apply(row.jv, row.jw, row.impulse);
}

// What the converged impulses leave: the sides' speeds, slips and backlash, the caster's swing, the pose.
void Body::finish(double h, const DriveRow drive[2]) {
  for (int i = 0; i < 2; ++i) {
    SideState& s = sides_[i];
    const DriveOutcome out = drive_outcome(drive[i], contact_speed(i), s.impulse_ns, s.gap_rad, p_.backlash_rad, h);
    s.motor_radps = out.motor_radps;
    s.wheel_radps = out.wheel_radps;
    s.slip_mps = out.slip_mps;
    s.gap_rad = out.gap_rad;
  }
  caster_roll_impulse_ = rows_[0].impulse;
  caster_side_impulse_ = rows_[1].impulse;
  const double side_speed = rows_[1].jv * twist_.v_mps + rows_[1].jw * twist_.omega_radps;
  caster_angle_rad_ = wrap_angle(caster_angle_rad_ + h * caster_swivel_rate_radps(p_.caster, side_speed));
  integrate_pose(h);
}

void Body::advance_kinematic(double h, const Twist& twist) {
  twist_ = twist;
  for (int i = 0; i < 2; ++i) {
    SideState& s = sides_[i];
    s.wheel_radps = s.motor_radps = contact_speed(i) / p_.wheel_radius_m;
    s.slip_mps = s.impulse_ns = 0.0;
  }
  caster_roll_impulse_ = caster_side_impulse_ = 0.0;
  const CasterJacobians jc = caster_jacobians(p_.caster, caster_angle_rad_);
  const double side_speed = jc.side_v * twist_.v_mps + jc.side_w * twist_.omega_radps;
  caster_angle_rad_ = wrap_angle(caster_angle_rad_ + h * caster_swivel_rate_radps(p_.caster, side_speed));
  integrate_pose(h);
}

void Body::integrate_pose(double h) {
  // Exact pose update for constant (v, ω) over the step (a circular arc).
  const double v = twist_.v_mps, w = twist_.omega_radps, th = pose_.theta_rad;
  if (std::fabs(w * h) < 1e-9) {
    pose_.x_m += v * h * std::cos(th + w * h / 2.0);
    pose_.y_m += v * h * std::sin(th + w * h / 2.0);
  } else {
    pose_.x_m += v / w * (std::sin(th + w * h) - std::sin(th));
    pose_.y_m -= v / w * (std::cos(th + w * h) - std::cos(th));
  }
  pose_.theta_rad = wrap_angle(th + w * h);
}

}  // namespace cart2d
