#include "cart.hpp"

#include "num.hpp"  // fabsf, step_toward

namespace core {

using namespace params::settings;  // setting ids

constexpr float kOvershootPassFactor = 4.0f;
constexpr uint8_t kStallTicks = params::control::tick_hz;  // 1 s
constexpr int16_t kStallPwm = params::control::pwm_max * 9 / 10;
constexpr float kStallSpeed_mps = 0.01f;

static bool is_stalled(int16_t pwm, float speed_mps) {
  return (pwm >= kStallPwm || pwm <= -kStallPwm) && fabsf(speed_mps) < kStallSpeed_mps;
}

static uint16_t seconds_to_ticks(float seconds) {
  const float ticks = seconds * params::control::tick_hz + 0.5f;
  return ticks > 65535.0f ? 65535 : static_cast<uint16_t>(ticks);
}

// Recomputed only when a setting changed (e.g. a calibration), not at every tick.
const OdometryScale& Cart::scale() {
  if (!scale_valid_ || scale_version_ != settings_.version()) {
    const WheelGeometry geometry{setting(enc_radius_left_m), setting(enc_radius_right_m), setting(enc_track_m),
                                 kCountsPerRev};
    scale_ = OdometryScale(geometry, kTickPeriod_s);
    // Also derived from the settings, for the position loop (each multiplication there costs
    // ~75 cycles per tick on average): the received path beyond a waypoint that lets the cart
    // brake from v_max (polar_controller.hpp, MotionLimits), and the overshoot pass radius.
    const float v_max = setting(v_max_mps);
    stop_horizon_m_ = v_max * v_max / ((2.0f * kBrakingShare) * setting(a_max_mps2));
    overshoot_radius_m_ = kOvershootPassFactor * setting(tol_pass_m);
    scale_version_ = settings_.version();
    scale_valid_ = true;
  }
  return scale_;
}

MotorOutput Cart::tick(const TickInput& in) {
  switch_left_ = in.switch_left;
  switch_right_ = in.switch_right;
  odometry_.update(in.counts_left, in.counts_right, scale());

  float v_mps = 0.0f;
  float omega_radps = 0.0f;
  switch (mode_) {
    case proto::MODE_IDLE:
      return output_;
    case proto::MODE_HOLD:
      break;
    case proto::MODE_PATH:
      // The position loop runs every kPositionDivider ticks; in between, its last output
      // stands (the speed loop below still runs every tick).
      if (position_countdown_ == 0) {
        position_countdown_ = kPositionDivider;
        if (!follow_path(path_v_mps_, path_omega_radps_)) return output_;
      }
      --position_countdown_;
      v_mps = path_v_mps_;
      omega_radps = path_omega_radps_;
      break;
    case proto::MODE_MANUAL:
      if (manual_ticks_left_ == 0) {
        safe_stop(proto::FLAG_MANUAL_TIMEOUT);  // the link went quiet: never drive blind
        return output_;
      }
      --manual_ticks_left_;
      v_mps = manual_v_mps_;
      omega_radps = manual_omega_radps_;
      break;
    case proto::MODE_RESET_ROUTINE:
      run_reset_routine(in);  // the one mode that drives into a contact on purpose
      return output_;
  }

  // A closed front switch means the bumper touches something: driving on pushes it (a wall, a
  // box, a foot) at up to full PWM until the stall guard trips, if it ever does. Backing away
  // and turning on the spot stay possible.
  if (front_contact() && (v_mps > 0.0f || v_ref_mps_ > 0.0f)) {
    safe_stop(proto::FLAG_BUMPER);
    return output_;
  }

  // Acceleration limits keep the commanded speeds physically reachable.
  v_ref_mps_ = step_toward(v_ref_mps_, v_mps, setting(a_max_mps2) * kTickPeriod_s);
  omega_ref_radps_ = step_toward(omega_ref_radps_, omega_radps, setting(alpha_max_radps2) * kTickPeriod_s);
  wheel_targets_ = wheel_speeds(v_ref_mps_, omega_ref_radps_, setting(enc_track_m));
  drive_wheels(WheelSpeeds{odometry_.v_left_mps(), odometry_.v_right_mps()});
  return output_;
}

// Computes the speeds that drive the path; false when the cart has just stopped on the end.
__attribute__((noinline)) bool Cart::follow_path(float& v_mps, float& omega_radps) {
  v_mps = omega_radps = 0.0f;
  if (!path_.active()) {
    if (path_.pending()) return true;  // no point has arrived yet: brake (zero targets) and wait
    safe_stop(0);
    return false;
  }
  const PolarGains gains{setting(pos_rho_kp), setting(pos_phase_kp), setting(reverse_allowed) > 0.5f};
  const MotionLimits limits{setting(v_max_mps), setting(w_max_radps), setting(a_max_mps2), stop_horizon_m_};
  const Pose& pose = odometry_.pose();
  const Heading heading{odometry_.cos_theta(), odometry_.sin_theta()};
  // An intermediate waypoint is passed within its pass radius (tol_pass, shrinking to tol_final
  // at a corner the cart stops for); one overshot a little (beyond it along its segment) counts
  // as passed rather than being chased.
  const float tol_pass = setting(tol_pass_m);
  const float tol_final = setting(tol_final_m);
  const PolarOutput cmd = polar_control(pose, heading, path_.approach(limits.v_max_mps), gains, limits);
  const float distance_m = fabsf(cmd.rho_m);
  distance_to_waypoint_m_ = distance_m;
  stopping_ = cmd.stopping;
  v_mps = cmd.v_mps;
  omega_radps = cmd.omega_radps;
  // Only a waypoint with a known successor is passed: on the last one received the cart stops
  // (and waits for more, unless it is the path's last).
  if (!path_.at_last_received()) {
    if (distance_m < path_.pass_radius(tol_pass, tol_final) ||
        (distance_m < overshoot_radius_m_ && path_.passed(pose))) {
      // Passed. The next waypoint is steered for from the next position tick (16 ms) on:
      // steering for it at once as well made this the heaviest tick of all.
      path_.advance();
    }
    return true;
  }
  // Arrival is judged on the distance between robot and waypoint (the seed compared
  // distances from the origin) and only once the cart has nearly stopped on it.
  if (path_.at_last() && distance_m < tol_final && fabsf(odometry_.v_mps()) < params::control::arrive_speed_mps) {
    path_.advance();
    safe_stop(proto::FLAG_ARRIVED);
    return false;
  }
  return true;
}

void Cart::run_reset_routine(const TickInput& in) {
  const WheelSpeeds creep = routine_.step(in.switch_left, in.switch_right, params::control::reset_routine_speed_mps);
  if (routine_.state() == ResetRoutine::State::kDone) {
    safe_stop(0);
    set_pose(Pose{setting(reset_x_m), setting(reset_y_m), setting(reset_theta_rad)});
    return;
  }
  if (routine_.state() == ResetRoutine::State::kFailed) {
    safe_stop(proto::FLAG_ROUTINE_FAILED);
    return;
  }
  wheel_targets_ = creep;
  drive_wheels(WheelSpeeds{odometry_.v_left_mps(), odometry_.v_right_mps()});
}

// Speed control towards wheel_targets_, and the stall guard: a wheel held at (nearly) full
// PWM that does not turn for kStallTicks is blocked (a wall, a jam); keeping the current up
// would only heat the motor, so the cart stops and says why.
void Cart::drive_wheels(const WheelSpeeds& measured) {
  const SpeedGains gains{{setting(speed_kp), setting(speed_ki)}, setting(speed_kff)};
  const WheelSpeeds feedforward = traction_speeds(wheel_targets_, scale().traction_ratio);
  output_.pwm = speed_.update(wheel_targets_, measured, feedforward, gains, kTickPeriod_s, params::control::pwm_max);
  output_.enabled = true;
  const bool left_stuck = is_stalled(output_.pwm.left, measured.left_mps);
  const bool right_stuck = is_stalled(output_.pwm.right, measured.right_mps);
  stall_ticks_ = (left_stuck || right_stuck) ? stall_ticks_ + 1 : 0;
  if (stall_ticks_ >= kStallTicks) safe_stop(proto::FLAG_STALLED);
}

// Flags that describe the firmware's state rather than the last motion: a new command keeps them.
constexpr uint16_t kLastingFlags = proto::FLAG_SETTINGS_DEFAULTED | proto::FLAG_POSE_RESTORED;

void Cart::set_pose(const Pose& pose) {
  odometry_.set_pose(pose);
  sticky_flags_ &= ~static_cast<uint16_t>(proto::FLAG_POSE_RESTORED);
}

void Cart::restore_pose(const Pose& pose) {
  odometry_.set_pose(pose);
  sticky_flags_ |= proto::FLAG_POSE_RESTORED;
}

void Cart::enter(proto::Mode mode) {
  position_countdown_ = 0;  // a new target: run the position loop at the next tick
  if (mode_ == proto::MODE_IDLE) {
    speed_.reset();  // a fresh start: no stale integrator, speeds ramp up from zero
    v_ref_mps_ = omega_ref_radps_ = 0.0f;
  }
  sticky_flags_ &= kLastingFlags;
  mode_ = mode;
}

void Cart::safe_stop(uint16_t reason_flag) {
  mode_ = proto::MODE_IDLE;
  stall_ticks_ = 0;
  sticky_flags_ |= reason_flag;
  speed_.reset();
  v_ref_mps_ = omega_ref_radps_ = 0.0f;
  wheel_targets_ = WheelSpeeds();
  output_ = MotorOutput();
}

// A new path replaces the current one at once. Driving, the mode stays PATH and the speed
// references carry on through the acceleration limiter (enter() resets them only from IDLE).
void Cart::go_to(const Point& target) {
  path_.set_single(target, odometry_.pose());
  enter(proto::MODE_PATH);
}

uint8_t Cart::begin_path(float count, const float* xy, uint8_t n) {
  const uint8_t refused = path_.begin(count, xy, n, odometry_.pose());
  if (refused) return refused;
  enter(proto::MODE_PATH);
  return 0;
}

uint8_t Cart::append_path(float index, const float* xy, uint8_t n) {
  return path_.append(index, xy, n);
}

void Cart::start() {
  if (mode_ != proto::MODE_IDLE) return;
  const bool path_pending = path_.pending();
  if (path_pending) path_.start_from(odometry_.pose());
  enter(path_pending ? proto::MODE_PATH : proto::MODE_HOLD);
}

uint8_t Cart::drive(float v_mps, float omega_radps) {
  if (!(fabsf(v_mps) <= setting(v_max_mps) && fabsf(omega_radps) <= setting(w_max_radps)))  // NaN fails
    return proto::REASON_OUT_OF_RANGE;
  if (v_mps > 0.0f && front_contact()) return proto::REASON_BLOCKED;
  manual_v_mps_ = v_mps;
  manual_omega_radps_ = omega_radps;
  manual_ticks_left_ = seconds_to_ticks(setting(manual_timeout_s));
  enter(proto::MODE_MANUAL);
  return 0;
}

void Cart::start_reset_routine() {
  routine_.start(seconds_to_ticks(params::control::reset_routine_timeout_s));
  enter(proto::MODE_RESET_ROUTINE);
}

void Cart::set_settings_defaulted(bool defaulted) {
  if (defaulted)
    sticky_flags_ |= proto::FLAG_SETTINGS_DEFAULTED;
  else
    sticky_flags_ &= ~static_cast<uint16_t>(proto::FLAG_SETTINGS_DEFAULTED);
}

uint16_t Cart::flags() const {
  uint16_t f = sticky_flags_;
  if (output_.enabled) f |= proto::FLAG_MOTORS_ENABLED;
  if (switch_left_) f |= proto::FLAG_SWITCH_LEFT;
  if (switch_right_) f |= proto::FLAG_SWITCH_RIGHT;
  if (!path_.all_received()) {
    f |= proto::FLAG_UPLOAD_OPEN;
    // Fewer points received ahead than the braking distance from v_max (as the position loop
    // last saw it, or none at all): the cart brakes for the last one unless more arrive.
    if (mode_ == proto::MODE_PATH && (stopping_ || !path_.active())) f |= proto::FLAG_STARVED;
  }
  return f;
}

}  // namespace core
