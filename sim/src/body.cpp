#include "body.hpp"

#include <cmath>   // std::sin, std::cos, std::sqrt, std::fabs
#include <limits>  // std::numeric_limits

namespace cart2d {

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

void solve_wheel_step(const double mq[4], const double c[2], const double q0[2], const double drive[2],
                      double coulomb_nm, double h, double q1[2]) {
  const double a[4] = {mq[0] + h * c[0], mq[1], mq[2], mq[3] + h * c[1]};
  const double rhs0[2] = {mq[0] * q0[0] + mq[1] * q0[1] + h * drive[0], mq[2] * q0[0] + mq[3] * q0[1] + h * drive[1]};
  const double tol = 1e-12;
  // Each wheel either slides forwards (+1, friction −tc), backwards (−1, friction +tc) or sticks
  // (0, q1 = 0, friction unknown within ±tc). A is positive definite, so exactly one combination
  // is consistent (up to ties on the boundary, which give the same q1).
  static const int kModes[3] = {1, -1, 0};
  for (int ml : kModes) {
    for (int mr : kModes) {
      const int mode[2] = {ml, mr};
      double g[4];
      double rhs[2] = {rhs0[0], rhs0[1]};
      for (int i = 0; i < 2; ++i) {
        if (mode[i] != 0) {
          const double f = -mode[i] * coulomb_nm;
          rhs[0] += (i == 0 ? h * f : 0.0);
          rhs[1] += (i == 1 ? h * f : 0.0);
          g[0 + i] = a[0 + i];  // column i of A
          g[2 + i] = a[2 + i];
        } else {
          g[0 + i] = (i == 0 ? -h : 0.0);  // column −h·e_i for the unknown friction
          g[2 + i] = (i == 1 ? -h : 0.0);
        }
      }
      double x[2];
      if (!solve2(g, rhs, x)) continue;
      bool ok = true;
      for (int i = 0; i < 2 && ok; ++i) {
        if (mode[i] == 1) ok = x[i] >= -tol;
        else if (mode[i] == -1) ok = x[i] <= tol;
        else ok = std::fabs(x[i]) <= coulomb_nm * (1.0 + 1e-9) + tol;
      }
      if (!ok) continue;
      q1[0] = mode[0] != 0 ? x[0] : 0.0;
      q1[1] = mode[1] != 0 ? x[1] : 0.0;
      return;
    }
  }
  // Not reachable for a positive-definite A; fall back to the frictionless solution.
  if (!solve2(a, rhs0, q1)) q1[0] = q1[1] = 0.0;
}

Twist project_contacts(const Twist& free, double m_v, double m_w, const std::vector<VelocityConstraint>& constraints) {
  // Work in w = M^½·u where the metric is Euclidean; constraint k reads a_k·w ≥ b_k.
  const double sv = std::sqrt(m_v), sw = std::sqrt(m_w);
  struct Row { double a0, a1, b; };
  std::vector<Row> rows;
  rows.reserve(constraints.size());
  for (const auto& c : constraints) {
    const Row r{c.jv / sv, c.jw / sw, c.min_rate};
    if (r.a0 * r.a0 + r.a1 * r.a1 < 1e-18) continue;  // e.g. the disc against a wall it runs along
    rows.push_back(r);
  }
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
    const Row& r = rows[i];
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

Body::Body(const BodyParams& p) : p_(p) {
  const double r = p.wheel_radius_m, b = p.track_m, j = p.wheel_inertia_kgm2;
  m_v_ = p.mass_kg + 2.0 * j / (r * r);
  m_w_ = p.yaw_inertia_kgm2 + j * b * b / (2.0 * r * r);
  // Mq = T⁻ᵀ·diag(m_v, m_w)·T⁻¹ with T⁻¹ = [[r/2, r/2], [−r/B, r/B]].
  const double sv = (r / 2.0) * (r / 2.0) * m_v_, sw = (r / b) * (r / b) * m_w_;
  mq_[0] = sv + sw;
  mq_[1] = sv - sw;
  mq_[2] = sv - sw;
  mq_[3] = sv + sw;
}

void Body::place(const Pose& pose) {
  pose_ = pose;
  pose_.theta_rad = wrap_angle(pose.theta_rad);
  twist_ = Twist{};
}

double Body::wheel_speed_l_radps() const {
  return (twist_.v_mps - twist_.omega_radps * p_.track_m / 2.0) / p_.wheel_radius_m;
}

double Body::wheel_speed_r_radps() const {
  return (twist_.v_mps + twist_.omega_radps * p_.track_m / 2.0) / p_.wheel_radius_m;
}

void Body::step(double h, const TorqueLaw& left, const TorqueLaw& right,
                const std::vector<VelocityConstraint>& contacts) {
  const double r = p_.wheel_radius_m, b = p_.track_m;
  const double q0[2] = {wheel_speed_l_radps(), wheel_speed_r_radps()};
  const double c[2] = {left.damping_nms, right.damping_nms};
  const double drive[2] = {left.drive_nm, right.drive_nm};
  double q1[2];
  solve_wheel_step(mq_, c, q0, drive, p_.wheel_coulomb_nm, h, q1);
  Twist free;
  free.v_mps = r * (q1[0] + q1[1]) / 2.0;
  free.omega_radps = r * (q1[1] - q1[0]) / b;
  twist_ = contacts.empty() ? free : project_contacts(free, m_v_, m_w_, contacts);
  integrate_pose(h);
}

void Body::advance_kinematic(double h, const Twist& twist) {
  twist_ = twist;
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
