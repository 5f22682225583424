#include "switches.hpp"

#include "io.hpp"  // make_input, read_pin

namespace board {
namespace switches {

namespace pins = params::pins;

void init() {
  make_input(pins::left_switch, true);
  make_input(pins::right_switch, true);
}

bool left_pressed() { return !read_pin(pins::left_switch); }
bool right_pressed() { return !read_pin(pins::right_switch); }

}  // namespace switches
}  // namespace board
