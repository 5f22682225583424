// One side of the drivetrain: DC motor + gearbox with backlash + traction wheel on the floor,
// reduced to ONE constraint row between the motor and the body (the "drive row").
//
// Quantities are referred to the output shaft (like [motor] in config/robot.toml). The wheel's own
// inertia (about a tenth of the side's, ~5·10⁻⁵ kg·m²) is lumped with the motor's, so the wheel is
// massless between two contacts:
// - the gear mesh, a dead band of width β (backlash) in the angle δ = θ_motor − θ_wheel ∈ [−β/2, β/2]:
//   it transmits torque only at a flank (δ = +β/2 driving forwards, −β/2 backwards) and none inside
//   (Nordin & Gutman, "Controlling mechanical systems with backlash — a survey", Automatica 38(10),
//   2002, §2: the dead-zone model; the flank closes as an inelastic impact, their "impact model"
//   with zero restitution);
// - the tyre on the floor, Coulomb friction bounded by μ·N (the longitudinal force a wheel can take).
// A massless wheel carries the same force through both, so a side is one impulse λ (N·s, forward on
// the body at the tyre, −r·λ on the motor) with the law of a friction row that has a dead zone:
//   λ = 0            ⇒ −g₊/h ≤ w ≤ g₋/h        (gap open: the wheel rolls with the floor, the motor is free)
//   0 < λ < λ_max    ⇒ w = −g₊/h               (+ flank closed, the tyre sticks)
//   λ = λ_max        ⇒ w ≤ −g₊/h               (the tyre slides: the wheel spins faster than the floor moves)
//   (and the mirror image for λ < 0 on the − flank)
// with w = v_contact − r·ω_motor (m/s) and g± = r·(β/2 ∓ δ) the rim distance left to each flank
// (a speculative contact: the gap may close within the step, not beyond). This is one row of the
// velocity-level complementarity problem of Stewart & Trinkle (IJNME 39, 1996) / Anitescu & Potra
// (Nonlinear Dynamics 14, 1997); body.cpp solves all rows together.
//
// The motor is eliminated inside the row: over a step, implicit in the back-EMF damping and exact in
// the gearbox's Coulomb friction (stick when the net torque is below it),
//   (J + h·c)·ω₁ = J·ω₀ + h·drive − r·λ + h·f,   f ∈ −τc·Sgn(ω₁),
// so ω₁(λ) is piecewise linear and w(λ) increases with λ: the row is solved exactly given the rest.
#pragma once

namespace cart2d {

// The motor's momentum balance over one step, without the drive impulse.
struct MotorStep {
  double momentum_nms = 0.0;        // J·ω₀ + h·drive (N·m·s)
  double inertia_kgm2 = 0.0;        // J + h·c: inertia plus the implicit damping
  double friction_impulse_nms = 0.0;  // h·τc
};

// The motor speed at the end of the step when the tyre carries impulse λ (N·s) at radius r.
double motor_speed_after(const MotorStep& m, double radius_m, double impulse_ns);

// The drive row of one side for one step.
struct DriveRow {
  MotorStep motor;
  double radius_m = 0.0;
  double body_compliance = 0.0;   // J·M⁻¹·Jᵀ of the tyre contact on the body, 1/kg
  double gap_fwd_mps = 0.0;       // g₊/h: rim speed that closes the forward flank within the step
  double gap_back_mps = 0.0;      // g₋/h
  double max_impulse_ns = 0.0;    // μ·N·h
};

// The impulse that satisfies the row given the other rows: `contact_mps` is the tyre contact's
// forward speed from the body as it is with impulse `current_ns` applied. Exact (the row is
// piecewise linear).
double solve_drive_row(const DriveRow& row, double contact_mps, double current_ns);

// What a side does after the step, from its converged impulse.
struct DriveOutcome {
  double motor_radps = 0.0;
  double wheel_radps = 0.0;  // the real traction wheel speed
  double slip_mps = 0.0;     // r·ω_wheel − v_contact: + = the tyre spins forwards over the floor
  double gap_rad = 0.0;      // δ at the end of the step
};
DriveOutcome drive_outcome(const DriveRow& row, double contact_mps, double impulse_ns, double gap_rad,
                           double backlash_rad, double h_s);

}  // namespace cart2d
