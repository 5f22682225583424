// The two front bumper switches (active low, internal pull-ups).
#pragma once

namespace board {
namespace switches {

void init();
bool left_pressed();
bool right_pressed();

}  // namespace switches
}  // namespace board
