// The periodic telemetry frame: which values go in which channel (docs/protocol.md), and when.
#pragma once

#include <stdint.h>

#include "cart.hpp"
#include "packet.hpp"

namespace core {

// Ticks between frames for a requested rate; 0 = off. The tick rate divided by a whole number.
uint8_t telemetry_divider(float rate_hz);
// The rate actually achieved for a requested one.
float telemetry_rate_hz(float rate_hz);

// Fills out[wire::kTelemetrySize] with the cart's state at control tick `tick`.
void encode_cart_telemetry(const Cart& cart, uint32_t tick, uint8_t* out);

}  // namespace core
