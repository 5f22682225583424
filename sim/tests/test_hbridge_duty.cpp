#include <gtest/gtest.h>

#include "hbridge_part.hpp"

namespace cart2d {
namespace {

struct Case {
  unsigned com;
  uint16_t ocr;
  bool port, ddr;
  double duty;
};

// Timer1 mode 8, TOP = ICR1 = 160.
TEST(HBridgeDuty, OutputCompareModes) {
  const Case cases[] = {
      {2, 0, false, true, 0.0},     // non-inverting, OCR = BOTTOM: always low
      {2, 40, false, true, 0.25},
      {2, 160, false, true, 1.0},   // OCR = TOP: always high
      {2, 200, false, true, 1.0},   // beyond TOP: never cleared
      {3, 40, false, true, 0.75},   // inverting
      {0, 80, false, true, 0.0},    // COM cleared: GPIO driven low
      {0, 80, true, true, 1.0},     // COM cleared: GPIO driven high
      {1, 80, false, true, 0.0},    // COM = 1 is GPIO in mode 8
      {2, 80, false, false, 0.0},   // no DDR bit: input, pulled down
      {0, 80, true, false, 0.0},    // an input with the MCU's pull-up: the board's pull-down wins
  };
  for (const Case& c : cases)
    EXPECT_DOUBLE_EQ(oc1_duty(c.com, c.ocr, 160, c.port, c.ddr, false), c.duty) << c.com << "/" << c.ocr;
}

// Without the board's pull-downs a floating (input) pin reads high at the TTL input: full duty.
TEST(HBridgeDuty, FloatingInputReadsHighWithoutPullDowns) {
  EXPECT_DOUBLE_EQ(oc1_duty(2, 40, 160, false, false, true), 1.0);
  EXPECT_DOUBLE_EQ(oc1_duty(0, 0, 160, false, false, true), 1.0);
  EXPECT_DOUBLE_EQ(oc1_duty(2, 40, 160, false, true, true), 0.25);  // an output is driven either way
}

}  // namespace
}  // namespace cart2d
