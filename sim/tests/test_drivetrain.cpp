// The drivetrain: the motor's dry friction, the drive row's backlash and tyre-friction laws, and
// what they do to the whole cart (wheel spin against a wall and on a hard launch, no slip in normal
// driving, the delay of a torque reversal through the backlash).
#include <gtest/gtest.h>

#include <cmath>

#include "cart.hpp"
#include "drivetrain.hpp"
#include "measuring_wheels.hpp"

namespace cart2d {
namespace {

constexpr double kH = 0.00025;
constexpr double kR = 0.0315;

// ---- the motor over one step ------------------------------------------------------------------

TEST(MotorStep, HeldStillWhenTheDriveIsBelowCoulombFriction) {
  const MotorStep m{0.04 * kH, 5e-4, 0.05 * kH};  // from rest, 0.04 N·m against 0.05 N·m of dry friction
  EXPECT_EQ(motor_speed_after(m, kR, 0.0), 0.0);
  EXPECT_EQ(motor_speed_after({-0.04 * kH, 5e-4, 0.05 * kH}, kR, 0.0), 0.0);
}

TEST(MotorStep, TurnsWithFrictionAndTheTyreImpulseSubtracted) {
  const MotorStep m{5e-4 * 10.0 + 0.5 * kH, 5e-4, 0.05 * kH};  // 10 rad/s, 0.5 N·m drive
  EXPECT_NEAR(motor_speed_after(m, kR, 0.0), 10.0 + kH * (0.5 - 0.05) / 5e-4, 1e-12);
  EXPECT_NEAR(motor_speed_after(m, kR, 0.002), 10.0 + (kH * (0.5 - 0.05) - kR * 0.002) / 5e-4, 1e-12);
}

// ---- the drive row ---------------------------------------------------------------------------

DriveRow row_with_gap(double gap_fwd_mps, double gap_back_mps) {
  DriveRow row;
  row.motor = MotorStep{5e-4 * 20.0 + 1.0 * kH, 5e-4, 0.05 * kH};  // 20 rad/s, pushing with 1 N·m
  row.radius_m = kR;
  row.body_compliance = 0.27;
  row.gap_fwd_mps = gap_fwd_mps;
  row.gap_back_mps = gap_back_mps;
  row.max_impulse_ns = 16.0 * kH;
  return row;
}

// The contact speed the body would reach with impulse λ on top of what it has at `current`.
double rate(const DriveRow& row, double contact, double current, double lambda) {
  return contact + row.body_compliance * (lambda - current) - kR * motor_speed_after(row.motor, kR, lambda);
}

TEST(DriveRow, InsideTheBacklashTheMotorDoesNotDriveTheWheel) {
  // The motor runs 0.63 m/s ahead of a body at 0; the forward flank is 2° away: not closed this step.
  const DriveRow row = row_with_gap(kR * 0.035 / kH, kR * 0.0 / kH);
  EXPECT_EQ(solve_drive_row(row, 0.0, 0.0), 0.0);
}

TEST(DriveRow, AClosedFlankHoldsTheTyreToTheMotorBelowTheFrictionLimit) {
  DriveRow row = row_with_gap(0.0, 4.0);
  row.max_impulse_ns = 1.0;  // plenty of grip
  const double contact = 20.0 * kR;  // the tyre rolls at the motor's speed: the mesh must push
  const double lambda = solve_drive_row(row, contact, 0.0);
  EXPECT_GT(lambda, 0.0);
  EXPECT_NEAR(rate(row, contact, 0.0, lambda), 0.0, 1e-12);  // no slip: the contact moves with the rim
}

TEST(DriveRow, BeyondTheFrictionLimitTheTyreSlides) {
  const DriveRow row = row_with_gap(0.0, 4.0);  // 16 N of grip against ~32 N of push
  const double contact = 20.0 * kR;
  const double lambda = solve_drive_row(row, contact, 0.0);
  EXPECT_EQ(lambda, row.max_impulse_ns);
  EXPECT_LT(rate(row, contact, 0.0, lambda), 0.0);  // the rim runs ahead of the contact: slip
  const DriveOutcome out = drive_outcome(row, contact + row.body_compliance * lambda, lambda, 0.0175, 0.035, kH);
  EXPECT_GT(out.slip_mps, 0.0);
  EXPECT_EQ(out.wheel_radps, out.motor_radps);
}

TEST(DriveRow, TheRearFlankBrakes) {
  DriveRow row = row_with_gap(4.0, 0.0);
  row.motor.momentum_nms = 5e-4 * 5.0 - 1.0 * kH;  // 5 rad/s, braking hard
  row.max_impulse_ns = 1.0;
  const double contact = 5.0 * kR;
  const double lambda = solve_drive_row(row, contact, 0.0);
  EXPECT_LT(lambda, 0.0);
  EXPECT_NEAR(rate(row, contact, 0.0, lambda), 0.0, 1e-12);
}

// ---- the whole cart --------------------------------------------------------------------------

struct Arena {
  World world{ArenaParams{}};  // walls 0.25 m outside [0, 1.8]²
  Cart cart{CartParams{}};
};

double tyre_grip_n(const Cart& cart, int side) {
  const SupportLoads n = cart.body().loads();
  return cart.params().body.floor_friction * (side == 0 ? n.left_n : n.right_n);
}

// Full PWM against a wall: the body stops, the wheels spin where the motor's torque equals what the
// floor can take, k·(V − k·ω)/R − b·ω − τc = r·μ·N, and the current is the motor model's.
TEST(Traction, PushingAWallAtFullDutySpinsTheWheels) {
  Arena a;
  a.cart.set_caster_angle(0.0);
  a.cart.place({1.5, 0.9, 0.0});
  const MeasuringWheelParams wheels;
  double measured_m = 0.0, turned_m = 0.0;
  for (int i = 0; i < 3 * 4000; ++i) {
    a.cart.step(kH, 1.0, 1.0, a.world);
    if (i >= 2 * 4000) {  // the last second, pressed against the wall
      measured_m += advance_measuring_wheels(wheels, Faults{}, a.cart.twist(), kH).dist_l_m;
      turned_m += kR * a.cart.wheel_speed_l_radps() * kH;
    }
  }
  const MotorParams& m = a.cart.params().motor;
  const double k = m.torque_constant_nm_per_a, r = m.resistance_ohm;
  const double load = kR * tyre_grip_n(a.cart, 0);
  const double expected = (k * m.battery_v / r - m.coulomb_friction_nm - load) / (k * k / r + m.viscous_friction_nms);
  EXPECT_NEAR(a.cart.pose().x_m, a.world.arena().x_max() - a.cart.params().geometry.bumper_x_m, 1e-6);
  EXPECT_NEAR(a.cart.twist().v_mps, 0.0, 1e-9);
  EXPECT_NEAR(a.cart.wheel_speed_l_radps(), expected, 1e-6);  // ~21.6 rad/s: 0.68 m/s of slip
  EXPECT_NEAR(a.cart.slip_l_mps(), kR * expected, 1e-6);
  EXPECT_NEAR(a.cart.current_l_a(), (m.battery_v - k * expected) / r, 1e-6);  // ~1.7 A, not the 4.8 A stall
  EXPECT_NEAR(measured_m, 0.0, 1e-9);  // the encoders see the floor, not the spinning wheel
  EXPECT_GT(turned_m, 0.6);
}

// From rest at full duty the motors could push 15 m/s²; the floor allows μ·(N_L + N_R)/m less the
// caster's rolling resistance: the tyres spin and the measuring wheels roll less than they turn.
TEST(Traction, AcceleratingHarderThanTheFloorAllowsSpinsTheWheels) {
  Arena a;
  a.cart.set_caster_angle(0.0);
  a.cart.place({-0.05, 0.9, 0.0});
  const MeasuringWheelParams wheels;
  double measured_m = 0.0, turned_m = 0.0, v_20ms = 0.0;
  for (int i = 0; i < 400; ++i) {  // 0.1 s; the first ~3 ms the motors cross the backlash
    a.cart.step(kH, 1.0, 1.0, a.world);
    measured_m += advance_measuring_wheels(wheels, Faults{}, a.cart.twist(), kH).dist_l_m;
    turned_m += kR * a.cart.wheel_speed_l_radps() * kH;
    if (i == 79) v_20ms = a.cart.twist().v_mps;
  }
  const BodyParams& p = a.cart.params().body;
  const SupportLoads loads = a.cart.body().loads();
  const double grip_accel = (p.floor_friction * (loads.left_n + loads.right_n) -
                             p.caster.rolling_resistance * loads.caster_n) / p.mass_kg;  // ~5.4 m/s²
  EXPECT_NEAR((a.cart.twist().v_mps - v_20ms) / (320 * kH), grip_accel, 1e-6);
  EXPECT_GT(a.cart.slip_l_mps(), 0.1);
  EXPECT_LT(measured_m, 0.8 * turned_m);
}

// The firmware's speed control in miniature (125 Hz, PI on the measuring wheels' speeds, with
// feedforward) following the missions' limits: 1 m/s² up to 0.5 m/s and down, then a turn on the
// spot at 12 rad/s² up to 3 rad/s and down. The tyres must not slide appreciably.
TEST(Traction, NormalDrivingDoesNotSlip) {
  Arena a;
  a.cart.set_caster_angle(0.4);  // not aligned: the caster swings on the way too
  a.cart.place({0.0, 0.9, 0.0});
  const double half_track = a.cart.params().body.track_m / 2;
  auto profile = [&](double t, double* v, double* w) {
    *v = t < 0.5 ? t : t < 1.5 ? 0.5 : t < 2.0 ? 0.5 - (t - 1.5) : 0.0;
    const double s = t - 2.2;
    *w = s < 0 ? 0.0 : s < 0.25 ? 12 * s : s < 1.25 ? 3.0 : s < 1.5 ? 3.0 - 12 * (s - 1.25) : 0.0;
  };
  double integral[2] = {0, 0}, duty[2] = {0, 0}, slip_m[2] = {0, 0};
  int since_flank_closed[2] = {0, 0};  // steps
  const int ticks_per_control = 32;  // 8 ms
  for (int i = 0; i < 4 * 4000; ++i) {
    if (i % ticks_per_control == 0) {
      double v, w;
      profile(i * kH, &v, &w);
      const double target[2] = {v - w * half_track, v + w * half_track};
      const double measured[2] = {a.cart.twist().v_mps - a.cart.twist().omega_radps * half_track,
                                  a.cart.twist().v_mps + a.cart.twist().omega_radps * half_track};
      for (int s = 0; s < 2; ++s) {
        const double err = target[s] - measured[s];
        integral[s] += err * ticks_per_control * kH;
        duty[s] = std::clamp((1000 * target[s] + 1000 * err + 3000 * integral[s]) / 1000, -1.0, 1.0);
      }
    }
    double gap_before[2];
    for (int s = 0; s < 2; ++s) gap_before[s] = a.cart.body().side(s).gap_rad;
    a.cart.step(kH, duty[0], duty[1], a.world);
    for (int s = 0; s < 2; ++s) {
      const SideState& side = a.cart.body().side(s);
      const bool closed_now = std::fabs(side.gap_rad) == a.cart.params().body.backlash_rad / 2 && side.gap_rad != gap_before[s];
      since_flank_closed[s] = closed_now ? 0 : since_flank_closed[s] + 1;
      slip_m[s] += std::fabs(side.slip_mps) * kH;
      // Accelerating and turning within the limits, the tyres hold...
      if (since_flank_closed[s] > 20) {
        ASSERT_EQ(side.slip_mps, 0.0) << "side " << s << " slips at " << i * kH << " s";
      }
    }
  }
  // ...except for ~2 ms after a flank of the backlash closes (starting, braking, stopping):
  // the rigid, inelastic impact hands the motor's momentum to the tyre faster than friction can,
  // a few cm/s of slip, some 0.05 mm per impact; a real tyre's torsional give absorbs much of it.
  EXPECT_LT(slip_m[0], 5e-4);
  EXPECT_LT(slip_m[1], 5e-4);
}

// Torque reversal: cruising on the forward flank, the duty flips. The motor must first cross the
// 2° of backlash (the wheel, unloaded, rolls on with the body) before the rear flank closes and
// brakes the cart. The delay is the crossing time of the motor's own dynamics,
//   J·ω̇ = d − c·ω − τc  ⇒  ∫(ω − ω0)dt = (ω∞ − ω0)·(t − τ·(1 − e^(−t/τ))) = −β,  τ = J/c.
TEST(Backlash, ATorqueReversalWaitsForTheMotorToCrossTheGap) {
  auto delay_s = [](double backlash_rad) {
    CartParams p;
    p.body.backlash_rad = backlash_rad;
    World world{ArenaParams{0.2, 10, 1000.0}};
    Cart cart{p};
    cart.set_caster_angle(0.0);
    cart.place({0, 0, 0});
    for (int i = 0; i < 2 * 4000; ++i) cart.step(kH, 0.3, 0.3, world);
    EXPECT_GT(cart.body().side(0).impulse_ns, 0.0);  // on the forward flank
    for (int i = 1; i < 4000; ++i) {
      cart.step(kH, -0.3, -0.3, world);
      if (cart.body().side(0).impulse_ns < 0.0) {
        for (int k = 0; k < 400; ++k) {  // the impact is inelastic: it stays on the rear flank
          cart.step(kH, -0.3, -0.3, world);
          EXPECT_LT(cart.body().side(0).impulse_ns, 0.0) << "bounced " << k << " steps after closing";
        }
        return i * kH;
      }
    }
    return 1.0;
  };
  CartParams p;
  p.body.backlash_rad = 0.035;  // 2°
  const MotorParams& m = p.motor;
  const double k = m.torque_constant_nm_per_a, c = k * k / m.resistance_ohm + m.viscous_friction_nms;
  const double j = p.body.drivetrain_inertia_kgm2, beta = p.body.backlash_rad;
  // Cruise speed after the 2 s run (each motor carries half the trailing caster's rolling
  // resistance), then the crossing time by bisection.
  Body trailing{p.body};
  trailing.set_caster_angle(0.0);
  const double caster_drag_n = p.body.caster.rolling_resistance * trailing.loads().caster_n;
  const double w0 = steady_speed_radps(m, 0.3 * m.battery_v, kR * caster_drag_n / 2);
  const double w_inf = (-k * 0.3 * m.battery_v / m.resistance_ohm - m.coulomb_friction_nm) / c;
  auto crossed = [&](double t) { return (w_inf - w0) * (t - j / c * (1 - std::exp(-t * c / j))) + beta; };
  double lo = 0.0, hi = 0.1;
  for (int i = 0; i < 60; ++i) (crossed((lo + hi) / 2) > 0 ? lo : hi) = (lo + hi) / 2;
  const double expected = lo;  // ~5.6 ms
  ASSERT_GT(expected, 10 * kH);
  EXPECT_NEAR(delay_s(beta), expected, 2 * kH);
  EXPECT_LE(delay_s(0.0), kH);  // a rigid gearbox brakes at once
}

}  // namespace
}  // namespace cart2d
