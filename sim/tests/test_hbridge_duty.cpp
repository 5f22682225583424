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

// TCCR1A/B as written: WGM11:10 in TCCR1A bits 1:0, WGM13:12 in TCCR1B bits 4:3, CS12:10 in bits 2:0.
TEST(HBridgeDuty, OnlyPwmOnTheBridgePinsInAnotherModeIsMisread) {
  const uint8_t com_a = 0x80, com_b = 0x20;  // COM1A1, COM1B1: non-inverting PWM on OC1A, OC1B
  const uint8_t mode8 = 0x10 | 0x01;         // WGM13, clk/1
  EXPECT_EQ(8u, timer1_misread_mode(com_a | com_b, mode8));  // the firmware's motors
  EXPECT_EQ(8u, timer1_misread_mode(0, mode8));              // the firmware with the motors off
  EXPECT_EQ(8u, timer1_misread_mode(0, 0x05));               // Optiboot's LED timer: mode 0, clk/1024, no pin
  EXPECT_EQ(8u, timer1_misread_mode(com_a | 0x02, 0x18));    // stopped clock: the pins are GPIOs
  EXPECT_EQ(14u, timer1_misread_mode(com_a | 0x02, 0x18 | 0x01));  // fast PWM, TOP = ICR1: misread
  EXPECT_EQ(0u, timer1_misread_mode(com_b, 0x01));                 // normal mode toggling OC1B: misread
}

}  // namespace
}  // namespace cart2d
