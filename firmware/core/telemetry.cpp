#include "telemetry.hpp"

namespace core {

uint8_t telemetry_divider(float rate_hz) {
  if (!(rate_hz > 0.0f)) return 0;
  const float ticks = params::control::tick_hz / rate_hz + 0.5f;
  return ticks >= 255.0f ? 255 : (ticks < 1.0f ? 1 : static_cast<uint8_t>(ticks));
}

float telemetry_rate_hz(float rate_hz) {
  const uint8_t divider = telemetry_divider(rate_hz);
  return divider == 0 ? 0.0f : static_cast<float>(params::control::tick_hz) / divider;
}

namespace {

// Writes channels one after the other. Out of line: a 16-float array built on the stack and
// copied cost ~500 B of the AVR's flash.
class ChannelWriter {
 public:
  explicit ChannelWriter(uint8_t* frame) : next_(frame + 3) {}
  __attribute__((noinline)) void put(float value) {
    put_f32(next_, value);
    next_ += 4;
  }

 private:
  uint8_t* next_;
};

}  // namespace

void encode_cart_telemetry(const Cart& cart, uint32_t tick, uint8_t* out) {
  const Odometry& odo = cart.odometry();
  ChannelWriter ch(out);
  ch.put(odo.pose().x_m);
  ch.put(odo.pose().y_m);
  ch.put(odo.pose().theta_rad);
  ch.put(odo.v_left_mps());
  ch.put(odo.v_right_mps());
  ch.put(cart.wheel_targets().left_mps);
  ch.put(cart.wheel_targets().right_mps);
  ch.put(cart.output().pwm.left);
  ch.put(cart.output().pwm.right);
  ch.put(odo.v_mps());
  ch.put(odo.omega_radps());
  ch.put(cart.v_ref_mps());
  ch.put(cart.omega_ref_radps());
  ch.put(cart.distance_to_waypoint_m());
  ch.put(cart.path().index());
  ch.put(cart.mode() | (cart.flags() << 4));
  finish_telemetry(out, static_cast<uint16_t>(tick));
}

}  // namespace core
