// Where a hold stops simulated time (hold.hpp): at the hold, past it while the host waits for
// the MCU's answer, and the wall time it waited. Cycles by hand.
#include <gtest/gtest.h>

#include "hold.hpp"

namespace cart2d {
namespace {

constexpr uint64_t kQuiet = 16000;  // 1 ms at 16 MHz
constexpr uint64_t kLong = 1000000000;  // a transmitter idle since long ago: start and end at 0

TEST(Hold, NoHoldStopsNothingAndAHoldStopsThere) {
  Hold h;
  EXPECT_EQ(h.stop_cycle(100, 0, 0, kQuiet), Hold::kNone);
  h.set(5000);
  EXPECT_EQ(h.stop_cycle(100, 0, 0, kQuiet), 5000u);
  EXPECT_EQ(h.stop_cycle(9000, 0, 0, kQuiet), 5000u);  // already past: stops where it is
  h.clear();
  EXPECT_EQ(h.stop_cycle(9000, 0, 0, kQuiet), Hold::kNone);
}

TEST(Hold, AHostRequestRunsTimeOnUntilTheMcuHasAnsweredAndGoneQuiet) {
  Hold h;
  h.set(1000);
  // The request is at the MCU by 2000; the answer may take until 300000 at most.
  h.host_wrote(2000, 300000);
  EXPECT_EQ(h.stop_cycle(1000, 0, 0, kQuiet), 300000u);  // nothing sent since: run on
  // A telemetry frame that started before the request arrived is not the answer.
  EXPECT_EQ(h.stop_cycle(50000, 1500, 3000, kQuiet), 300000u);
  // The answer started at 60000 and is on the wire until 80000: run on, then a quiet millisecond.
  EXPECT_EQ(h.stop_cycle(70000, 60000, 80000, kQuiet), 300000u);
  EXPECT_EQ(h.stop_cycle(80000 + kQuiet - 1, 60000, 80000, kQuiet), 300000u);
  EXPECT_EQ(h.stop_cycle(80000 + kQuiet, 60000, 80000, kQuiet), 1000u);  // answered: held again
}

TEST(Hold, AnUnansweredRequestRunsTimeOnNoLongerThanItsLimit) {
  Hold h;
  h.set(1000);
  h.host_wrote(2000, 300000);
  EXPECT_EQ(h.stop_cycle(299999, 0, 0, kQuiet), 300000u);
  EXPECT_EQ(h.stop_cycle(300000, 0, 0, kQuiet), 1000u);
  // A later request opens its own window, answered by a frame after it only.
  h.host_wrote(kLong, kLong + 300000);
  EXPECT_EQ(h.stop_cycle(kLong, 60000, 80000, kQuiet), kLong + 300000);
  // A hold beyond the window stands where it is.
  h.set(kLong + 500000);
  EXPECT_EQ(h.stop_cycle(kLong, 60000, 80000, kQuiet), kLong + 500000);
}

TEST(Hold, TheWaitsAndTheWallTimeWaitedAreCounted) {
  Hold h;
  h.account(false, 1.0);
  EXPECT_FALSE(h.waiting());
  h.account(true, 2.0);
  h.account(true, 2.5);
  EXPECT_TRUE(h.waiting());
  EXPECT_DOUBLE_EQ(h.waited_s(2.75), 0.75);  // the wait under way counts
  h.account(false, 3.0);
  h.account(true, 4.0);
  h.account(false, 4.5);
  EXPECT_EQ(h.waits(), 2u);
  EXPECT_DOUBLE_EQ(h.waited_s(10.0), 1.5);
}

}  // namespace
}  // namespace cart2d
