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

void encode_cart_telemetry(const Cart& cart, uint32_t tick, uint8_t* out) {
  const Odometry& odo = cart.odometry();
  const float channels[wire::kTelemetryChannels] = {
      odo.pose().x_m,
      odo.pose().y_m,
      odo.pose().theta_rad,
      odo.v_left_mps(),
      odo.v_right_mps(),
      cart.wheel_targets().left_mps,
      cart.wheel_targets().right_mps,
      static_cast<float>(cart.output().pwm.left),
      static_cast<float>(cart.output().pwm.right),
      odo.v_mps(),
      odo.omega_radps(),
      cart.v_ref_mps(),
      cart.omega_ref_radps(),
      cart.distance_to_waypoint_m(),
      static_cast<float>(cart.path().index()),
      static_cast<float>(cart.mode() | (cart.flags() << 4)),
  };
  encode_telemetry(out, channels, static_cast<uint16_t>(tick));
}

}  // namespace core
