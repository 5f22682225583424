// A port pin (letter + bit), as tools/gen_params.py maps the Arduino Nano pin numbers.
#pragma once

#include <cstdint>

#include "robot_params.hpp"  // params::pins::Pin

namespace cart2d {

struct PinRef {
  char port = 'D';
  uint8_t bit = 0;
};

inline PinRef pin_of(const params::pins::Pin& p) { return PinRef{p.port, p.bit}; }

}  // namespace cart2d
