#include "rig.hpp"

#include "atmega328p.hpp"
#include "log.hpp"
#include "robot_params.hpp"  // params::*

extern "C" {
#include <sim_avr.h>  // avr_cycle_timer_register
}

namespace cart2d {

Rig::Rig() : world_(ArenaParams{}) {}

Rig::~Rig() = default;

bool Rig::init(const RigConfig& config, std::string* error) {
  const uint32_t f_cpu = static_cast<uint32_t>(params::control::f_cpu_hz);
  mcu_.set_seed(config.seed);
  if (!mcu_.load(config.firmware, f_cpu, error)) return false;
  if (!config.bootloader.empty() && !mcu_.load_bootloader(config.bootloader, error)) return false;
  avr_t* avr = mcu_.avr();
  eeprom_ = std::make_unique<EepromPart>(avr, config.seed);
  if (!eeprom_->attach(error)) return false;

  world_.set_square_arena(ArenaParams{config.grid_step_m, config.grid_nodes, config.arena_margin_m});
  cart_ = std::make_unique<Cart>(CartParams{});
  cart_->place(config.start);
  cart_->sense(world_);

  pins_ = std::make_unique<PinDriver>(avr);
  hbridge_ = std::make_unique<HBridgePart>(avr, pin_of(params::pins::left_dir), pin_of(params::pins::right_dir),
                                           pin_of(params::pins::left_pwm), pin_of(params::pins::right_pwm));
  switches_ = std::make_unique<SwitchPart>(avr, pins_.get(), pin_of(params::pins::left_switch),
                                           pin_of(params::pins::right_switch));
  switches_->set_pressed(cart_->switch_left(), cart_->switch_right());
  enc_l_ = std::make_unique<EncoderPart>(avr, pins_.get(), pin_of(params::pins::left_enc_a), pin_of(params::pins::left_enc_b),
                                         params::encoders::pulses_per_rev,
                                         params::encoders::left_b_high_on_rise_is_forward, config.seed, kStreamEncLeft);
  enc_r_ = std::make_unique<EncoderPart>(avr, pins_.get(), pin_of(params::pins::right_enc_a), pin_of(params::pins::right_enc_b),
                                         params::encoders::pulses_per_rev,
                                         params::encoders::right_b_high_on_rise_is_forward, config.seed, kStreamEncRight);
  if (config.open_pty && !uart_.open_pty(error)) return false;
  uart_.attach(avr, config.seed);

  const uint64_t tick_cycles = f_cpu / static_cast<uint64_t>(params::control::tick_hz);
  cpu_ = std::make_unique<CpuMeter>(tick_cycles, static_cast<size_t>(params::control::tick_hz));
  cpu_->attach(avr, m328p::kVectorTimer2CompA);
  mcu_.set_sleep_hook([this](uint64_t cycle) { cpu_->on_sleep(cycle); });
  mcu_.set_reset_hook([this](ResetCause cause) { after_mcu_reset(cause); });

  next_step_cycle_ = mcu_.cycle();
  arm_physics();
  return true;
}

void Rig::arm_physics() {
  avr_t* avr = mcu_.avr();
  const uint64_t now = avr->cycle;
  avr_cycle_timer_register(avr, next_step_cycle_ > now ? next_step_cycle_ - now : 0, physics_timer, this);
}

uint64_t Rig::physics_timer(avr_t*, uint64_t when, void* param) {
  return static_cast<Rig*>(param)->physics_step(when);
}

// One physics step covering cycles [when, when + step): the duties the MCU outputs now act over
// the whole step (zero-order hold), the cart moves, and the edges its encoders make during the
// step are scheduled at their exact cycles within it.
uint64_t Rig::physics_step(uint64_t when) {
  duties_ = hbridge_->sample();
  if (scripted_) cart_->step_kinematic(step_s_, *scripted_, world_);
  else cart_->step(step_s_, duties_.left, duties_.right, world_);

  const WheelAdvance adv = advance_measuring_wheels(wheels_, faults_, cart_->twist(), step_s_);
  enc_dist_l_m_ += adv.dist_l_m;
  enc_dist_r_m_ += adv.dist_r_m;
  enc_l_->advance(adv.angle_l_rad, when, step_cycles_, qfaults_);
  enc_r_->advance(adv.angle_r_rad, when, step_cycles_, qfaults_);
  switches_->set_pressed(cart_->switch_left(), cart_->switch_right());

  if (!world_.deferred().empty()) world_.settle(cart_->pose(), cart_->params().geometry);

  const uint64_t end = when + step_cycles_;
  contacts_.update(static_cast<double>(end) / mcu_.frequency_hz(), world_, cart_->pose(), cart_->params().geometry,
                   cart_->probes());
  ++physics_steps_;
  next_step_cycle_ = end;
  if (step_hook_) step_hook_(end);
  return end;
}

bool Rig::run_cycles(uint64_t n) { return mcu_.run_until(mcu_.cycle() + n); }

void Rig::reset_mcu(ResetCause cause, double off_s) {
  const double off_cycles = off_s > 0.0 ? off_s * mcu_.frequency_hz() : 0.0;
  mcu_.reset(cause, static_cast<uint64_t>(off_cycles + 0.5));  // calls after_mcu_reset()
}

// The one place every reset comes through (Mcu's reset hook), the watchdog's included:
// avr_reset() cleared every cycle timer, so each part re-arms its own, and the physics goes on.
void Rig::after_mcu_reset(ResetCause cause) {
  eeprom_->on_reset();
  pins_->restore_after_reset();
  switches_->refresh();
  cpu_->abandon();
  uart_.rearm_after_reset();
  enc_l_->rearm_after_reset();
  enc_r_->rearm_after_reset();
  arm_physics();
  duties_ = hbridge_->sample();  // every pin floats now
  reset_events_.push_back({cause, mcu_.time_s()});
}

void Rig::place(const Pose& pose) {
  cart_->place(pose);
  cart_->sense(world_);
  switches_->set_pressed(cart_->switch_left(), cart_->switch_right());
}

void Rig::world_changed() {
  world_.defer_overlapping(cart_->pose(), cart_->params().geometry);
  cart_->sense(world_);
  switches_->set_pressed(cart_->switch_left(), cart_->switch_right());
}

void Rig::set_faults(const Faults& faults) {
  faults_ = faults;
  qfaults_.miss_prob = faults.enc_miss_prob;
  qfaults_.noise_hz = faults.enc_noise_hz;
  uart_.set_faults(faults);
  hbridge_->set_pulldowns(faults.hbridge_pulldowns != 0.0);
}

}  // namespace cart2d
