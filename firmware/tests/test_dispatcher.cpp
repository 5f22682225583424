// Command semantics through the whole receive -> dispatch -> reply path of a booted firmware.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "harness.hpp"
#include "protocol_table.hpp"

namespace {

using harness::Firmware;
using harness::Reply;

class Dispatcher : public ::testing::Test {
 protected:
  void SetUp() override {
    harness::RamEeprom::erase();
    harness::RamEeprom::latency = 3;
  }

  Reply call(Firmware& fw, uint8_t cmd, const std::vector<float>& args = {}) {
    const std::vector<Reply> r = harness::replies(fw.send(harness::request(++seq_, cmd, args)));
    EXPECT_EQ(1u, r.size());
    return r.empty() ? Reply() : r[0];
  }

  void expect_error(const Reply& r, proto::Reason reason) {
    EXPECT_EQ(proto::CONTROL_ERROR, r.status);
    ASSERT_EQ(1u, r.results.size());
    EXPECT_EQ(reason, r.results[0]);
  }

  uint8_t seq_ = 0;
};

TEST_F(Dispatcher, ReplyEchoesSequenceAndCommand) {
  Firmware fw;
  const Reply r = harness::replies(fw.send(harness::request(42, proto::COMMAND_POSE, {})))[0];
  EXPECT_EQ(42, r.seq);
  EXPECT_EQ(proto::COMMAND_POSE, r.cmd);
  EXPECT_EQ(proto::CONTROL_OK, r.status);
}

TEST_F(Dispatcher, RetransmittedRequestIsAnsweredButNotExecutedTwice) {
  Firmware fw;
  const std::vector<uint8_t> set = harness::request(102, proto::COMMAND_SET_POSE, {5.0f, 5.0f, 0.0f});
  const std::vector<uint8_t> first_reply = fw.send(set);
  fw.cart.set_pose(core::Pose{7.0f, 7.0f, 0.0f});  // the cart moves on
  // The host lost the reply and sends the identical bytes again:
  EXPECT_EQ(first_reply, fw.send(set));
  EXPECT_FLOAT_EQ(7.0f, fw.cart.odometry().pose().x_m);  // not set back to 5
}

// docs/protocol.md: hosts retransmit within 1.5 s of the first transmission; the firmware
// remembers for 2 s. A host's last retry (at up to 1.5 s, plus the line) is never run twice.
TEST_F(Dispatcher, ALateRetransmissionWithinTheHostsLimitIsNotExecutedTwice) {
  Firmware fw;
  const std::vector<uint8_t> set = harness::request(5, proto::COMMAND_SET_POSE, {5.0f, 0.0f, 0.0f});
  fw.send(set);
  fw.cart.set_pose(core::Pose{1.0f, 0.0f, 0.0f});
  for (int i = 0; i < 237; ++i) fw.tick();  // 1.9 s
  fw.send(set);
  EXPECT_FLOAT_EQ(1.0f, fw.cart.odometry().pose().x_m);
}

TEST_F(Dispatcher, SameSequenceAfterTheDuplicateWindowExecutesAgain) {
  Firmware fw;
  const std::vector<uint8_t> set = harness::request(5, proto::COMMAND_SET_POSE, {5.0f, 0.0f, 0.0f});
  fw.send(set);
  fw.cart.set_pose(core::Pose{1.0f, 0.0f, 0.0f});
  for (int i = 0; i < 250; ++i) fw.tick();  // 2 s
  fw.send(set);
  EXPECT_FLOAT_EQ(5.0f, fw.cart.odometry().pose().x_m);
}

TEST_F(Dispatcher, KpidSetIsAllOrNothing) {
  Firmware fw;
  expect_error(call(fw, proto::COMMAND_KPID_SET, {2.0f, 5.0f, 1500.0f, -1.0f}), proto::REASON_OUT_OF_RANGE);
  const Reply r = call(fw, proto::COMMAND_KPID_GET);
  EXPECT_EQ((std::vector<float>{6.0f, 8.0f, 1000.0f, 3000.0f}), r.results);
  EXPECT_EQ((std::vector<float>{2.0f, 5.0f, 1500.0f, 2500.0f}),
            call(fw, proto::COMMAND_KPID_SET, {2.0f, 5.0f, 1500.0f, 2500.0f}).results);
}

TEST_F(Dispatcher, NonFiniteArgumentsChangeNothing) {
  Firmware fw;
  for (float bad : {NAN, INFINITY, -INFINITY}) {
    expect_error(call(fw, proto::COMMAND_TOL_SET, {bad}), proto::REASON_NOT_FINITE);
    expect_error(call(fw, proto::COMMAND_SET_POSE, {0.0f, bad, 0.0f}), proto::REASON_NOT_FINITE);
    expect_error(call(fw, proto::COMMAND_WAIT_XY_ARRAY, {2.0f, 0.1f, 0.1f, bad, 0.2f}), proto::REASON_NOT_FINITE);
  }
  EXPECT_FLOAT_EQ(0.005f, call(fw, proto::COMMAND_TOL_GET).results.at(0));
  EXPECT_EQ(proto::MODE_IDLE, fw.cart.mode());
  EXPECT_EQ(0, fw.cart.path().count());
}

TEST_F(Dispatcher, HugeButFiniteValuesAreRefusedOrWrapped) {
  Firmware fw;
  expect_error(call(fw, proto::COMMAND_GOTO, {1e30f, 0.0f}), proto::REASON_OUT_OF_RANGE);
  expect_error(call(fw, proto::COMMAND_SET_POSE, {0.0f, -2e6f, 0.0f}), proto::REASON_OUT_OF_RANGE);
  expect_error(call(fw, proto::COMMAND_WAIT_XY_ARRAY, {1.0f, 0.0f, 1048576.0f}), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(0, fw.cart.path().count());
  // A huge finite heading is refused (the fuzzer found one that hung the wrapping loop), one
  // within +-100 rad is wrapped into [-pi, pi].
  expect_error(call(fw, proto::COMMAND_SET_POSE, {1.0f, 1.0f, -1.69e38f}), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_SET_POSE, {1.0f, 1.0f, 99.0f}).status);
  EXPECT_NEAR(99.0f - 16 * 6.28318531f, fw.cart.odometry().pose().theta_rad, 1e-4f);
  EXPECT_EQ(proto::MODE_IDLE, fw.cart.mode());
}

// A path of `n` points along x, 0.1 m apart from x = 1 m: point i as {x, y}.
std::vector<float> line_points(int first, int n) {
  std::vector<float> xy;
  for (int i = first; i < first + n; ++i) xy.insert(xy.end(), {1.0f + 0.1f * i, 0.0f});
  return xy;
}

std::vector<float> with_head(float head, const std::vector<float>& xy) {
  std::vector<float> args = {head};
  args.insert(args.end(), xy.begin(), xy.end());
  return args;
}

TEST_F(Dispatcher, AStreamedPathStartsAtOnceAndEveryReplyCarriesThePacing) {
  Firmware fw;
  // 20 points: 15 in the first frame, 5 appended. Each reply: received, index, room.
  const Reply begun = call(fw, proto::COMMAND_WAIT_XY_ARRAY, with_head(20.0f, line_points(0, 15)));
  EXPECT_EQ((std::vector<float>{15.0f, 0.0f, 5.0f}), begun.results);
  EXPECT_EQ(proto::MODE_PATH, fw.cart.mode());
  EXPECT_TRUE(fw.cart.flags() & proto::FLAG_UPLOAD_OPEN);
  const Reply r = call(fw, proto::COMMAND_XY_APPEND, with_head(15.0f, line_points(15, 5)));
  EXPECT_EQ((std::vector<float>{20.0f, 0.0f, 0.0f}), r.results);
  EXPECT_FALSE(fw.cart.flags() & proto::FLAG_UPLOAD_OPEN);
  EXPECT_EQ(20, fw.cart.path().count());
  const Reply status = call(fw, proto::COMMAND_STATUS);
  ASSERT_EQ(16u, status.results.size());
  EXPECT_EQ(0.0f, status.results[2]);   // waypoint_index
  EXPECT_EQ(20.0f, status.results[3]);  // waypoint_count
  EXPECT_EQ(20.0f, status.results[15]);  // waypoints_received
}

TEST_F(Dispatcher, AppendsBeyondTheWindowOrOutOfOrderAreRefusedAndStoreNothing) {
  Firmware fw;
  const float w = core::kWindow;
  call(fw, proto::COMMAND_WAIT_XY_ARRAY, with_head(100.0f, line_points(0, 15)));
  EXPECT_EQ((std::vector<float>{30.0f, 0.0f, w - 30.0f}),
            call(fw, proto::COMMAND_XY_APPEND, with_head(15.0f, line_points(15, 15))).results);
  expect_error(call(fw, proto::COMMAND_XY_APPEND, with_head(30.0f, line_points(30, w - 29))),
               proto::REASON_WINDOW_FULL);
  expect_error(call(fw, proto::COMMAND_XY_APPEND, with_head(29.0f, line_points(29, 1))), proto::REASON_OUT_OF_ORDER);
  expect_error(call(fw, proto::COMMAND_XY_APPEND, with_head(31.0f, line_points(31, 1))), proto::REASON_OUT_OF_ORDER);
  EXPECT_EQ(proto::REASON_OUT_OF_ORDER, call(fw, proto::COMMAND_STATUS).results.at(11));  // last_error
  expect_error(call(fw, proto::COMMAND_XY_APPEND, {30.0f}), proto::REASON_ARG_COUNT);  // no point
  EXPECT_EQ(30, fw.cart.path().received());
  EXPECT_EQ((std::vector<float>{w, 0.0f, 0.0f}),
            call(fw, proto::COMMAND_XY_APPEND, with_head(30.0f, line_points(30, w - 30))).results);
}

TEST_F(Dispatcher, OverlongPathIsRefusedAndTheCurrentPathKept) {
  Firmware fw;
  call(fw, proto::COMMAND_WAIT_XY_ARRAY, {2.0f, 0.2f, 0.0f, 0.4f, 0.0f});
  expect_error(call(fw, proto::COMMAND_WAIT_XY_ARRAY, {65536.0f}), proto::REASON_OVER_CAPACITY);
  expect_error(call(fw, proto::COMMAND_WAIT_XY_ARRAY, {1e6f}), proto::REASON_OVER_CAPACITY);
  expect_error(call(fw, proto::COMMAND_WAIT_XY_ARRAY, {1.0f, 0.1f, 0.1f, 0.2f, 0.2f}), proto::REASON_ARG_COUNT);
  ASSERT_EQ(2, fw.cart.path().count());
  const core::Approach first = fw.path.approach(0.5f);
  EXPECT_FLOAT_EQ(0.2f, first.x_m);
  fw.path.advance();
  EXPECT_FLOAT_EQ(0.4f, fw.path.approach(0.5f).x_m);
}

TEST_F(Dispatcher, AppendBeyondTheAnnouncedCountIsRefused) {
  Firmware fw;
  call(fw, proto::COMMAND_WAIT_XY_ARRAY, {2.0f});
  expect_error(call(fw, proto::COMMAND_XY_APPEND, {0.0f, 0.1f, 0.1f, 0.2f, 0.2f, 0.3f, 0.3f}),
               proto::REASON_OVER_CAPACITY);
  EXPECT_EQ(0, fw.cart.path().received());
}

TEST_F(Dispatcher, ARetransmittedAppendIsAnsweredFromMemoryAndNotStoredTwice) {
  Firmware fw;
  call(fw, proto::COMMAND_WAIT_XY_ARRAY, with_head(40.0f, line_points(0, 2)));
  const std::vector<uint8_t> append = harness::request(77, proto::COMMAND_XY_APPEND, with_head(2.0f, line_points(2, 3)));
  const std::vector<uint8_t> first_reply = fw.send(append);
  EXPECT_EQ(first_reply, fw.send(append));  // the host lost the reply
  EXPECT_EQ(5, fw.cart.path().received());
}

TEST_F(Dispatcher, SaveSurvivesAResetAndLoadRestoresIt) {
  {
    Firmware fw;
    call(fw, proto::COMMAND_TOL_SET, {0.02f});
    call(fw, proto::COMMAND_PARAM_SET, {8.0f, 0.75f});  // a_max
    EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_SAVE).status);
    int ticks = 0;
    while (fw.store.busy() && ticks < 1000) fw.tick(), ++ticks;
    EXPECT_FALSE(fw.store.busy());
    call(fw, proto::COMMAND_TOL_SET, {0.03f});
    EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_LOAD).status);
    EXPECT_FLOAT_EQ(0.02f, call(fw, proto::COMMAND_TOL_GET).results.at(0));
  }
  Firmware rebooted;  // same RAM EEPROM
  EXPECT_FLOAT_EQ(0.02f, call(rebooted, proto::COMMAND_TOL_GET).results.at(0));
  EXPECT_FLOAT_EQ(0.75f, call(rebooted, proto::COMMAND_PARAM_GET, {8.0f}).results.at(1));
  EXPECT_EQ(0.0f, call(rebooted, proto::COMMAND_STATUS).results.at(8));  // settings from EEPROM
}

TEST_F(Dispatcher, BlankEepromGivesDefaultsReportedInStatusAndLoadRefused) {
  Firmware fw;
  const Reply status = call(fw, proto::COMMAND_STATUS);
  ASSERT_EQ(16u, status.results.size());
  EXPECT_EQ(1.0f, status.results[8]);  // defaults: blank
  EXPECT_TRUE(static_cast<int>(status.results[1]) & proto::FLAG_SETTINGS_DEFAULTED);
  expect_error(call(fw, proto::COMMAND_LOAD), proto::REASON_EEPROM_INVALID);
}

// The settings in use come from the EEPROM once a SAVE has written them: STATUS and the flag say
// so then (the panel's "default settings" badge stayed after Save until the next boot).
TEST_F(Dispatcher, ASaveThatHasLandedMakesTheEepromTheSettingsSource) {
  Firmware fw;
  auto defaulted = [this, &fw]() {
    const Reply status = call(fw, proto::COMMAND_STATUS);
    return std::make_pair(status.results.at(8), (static_cast<int>(status.results.at(1)) & proto::FLAG_SETTINGS_DEFAULTED) != 0);
  };
  EXPECT_EQ(std::make_pair(1.0f, true), defaulted());
  EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_SAVE).status);
  fw.tick();
  ASSERT_TRUE(fw.store.busy());
  EXPECT_EQ(std::make_pair(1.0f, true), defaulted());  // not on the chip yet: a reset now loads defaults
  int ticks = 0;
  while (fw.store.busy() && ticks < 1000) fw.tick(), ++ticks;
  fw.tick();
  EXPECT_EQ(std::make_pair(0.0f, false), defaulted());
  EXPECT_FALSE(static_cast<int>(fw.cart.flags()) & proto::FLAG_SETTINGS_DEFAULTED);  // telemetry's flags too
}

// Between the record landing and the next tick the store is idle but the source not yet the
// EEPROM: STATUS says busy then, so a host polling for the end of a SAVE never reads "done,
// settings from defaults".
TEST_F(Dispatcher, StatusShowsTheEepromBusyUntilItIsTheSettingsSource) {
  Firmware fw;
  EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_SAVE).status);
  int polls = 0;
  while (fw.store.busy() && polls < 1000) fw.store.poll(), ++polls;  // the main loop's, between ticks
  Reply status = call(fw, proto::COMMAND_STATUS);
  EXPECT_EQ(1.0f, status.results.at(8));  // defaults still: the tick that takes the EEPROM is due
  EXPECT_EQ(1.0f, status.results.at(9));  // so busy
  fw.tick();
  status = call(fw, proto::COMMAND_STATUS);
  EXPECT_EQ(0.0f, status.results.at(8));
  EXPECT_EQ(0.0f, status.results.at(9));
}

TEST_F(Dispatcher, CorruptEepromGivesDefaults) {
  {
    Firmware fw;
    call(fw, proto::COMMAND_SAVE);
    while (fw.store.busy()) fw.tick();
  }
  harness::RamEeprom::memory[core::record::slot_address(0) + 10] ^= 0x01;
  Firmware fw;
  EXPECT_EQ(2.0f, call(fw, proto::COMMAND_STATUS).results.at(8));
  EXPECT_FLOAT_EQ(1000.0f, call(fw, proto::COMMAND_KPID_GET).results.at(2));
}

TEST_F(Dispatcher, VersionReportsTheTablesItWasBuiltFrom) {
  Firmware fw;
  const Reply r = call(fw, proto::COMMAND_VERSION);
  ASSERT_EQ(6u, r.results.size());
  EXPECT_EQ(proto::kVersion, r.results[0]);
  EXPECT_EQ(static_cast<float>(proto::kDictionaryHash), r.results[2]);
  EXPECT_EQ(static_cast<float>(core::setting::kLayoutHash), r.results[3]);
  EXPECT_EQ(static_cast<float>(core::kWindow), r.results[4]);
}

TEST_F(Dispatcher, TelemetryRateIsRoundedToWholeTickDivisions) {
  Firmware fw;
  EXPECT_FLOAT_EQ(125.0f / 3, call(fw, proto::COMMAND_TELEMETRY, {50.0f}).results.at(0));
  EXPECT_FLOAT_EQ(25.0f, call(fw, proto::COMMAND_TELEMETRY, {25.0f}).results.at(0));
  EXPECT_FLOAT_EQ(0.0f, call(fw, proto::COMMAND_TELEMETRY, {0.0f}).results.at(0));
  expect_error(call(fw, proto::COMMAND_TELEMETRY, {51.0f}), proto::REASON_OUT_OF_RANGE);
}

TEST_F(Dispatcher, ParamIdsMustBeWholeAndKnown) {
  Firmware fw;
  expect_error(call(fw, proto::COMMAND_PARAM_GET, {1.5f}), proto::REASON_OUT_OF_RANGE);
  expect_error(call(fw, proto::COMMAND_PARAM_GET, {-1.0f}), proto::REASON_OUT_OF_RANGE);
  expect_error(call(fw, proto::COMMAND_PARAM_SET, {static_cast<float>(core::setting::kCount), 1.0f}),
               proto::REASON_OUT_OF_RANGE);
  const Reply r = call(fw, proto::COMMAND_PARAM_GET, {6.0f});
  EXPECT_EQ((std::vector<float>{6.0f, 0.5f, 0.01f, 1.0f}), r.results);
}

TEST_F(Dispatcher, HeartbeatReportsUptime) {
  Firmware fw;
  for (int i = 0; i < 250; ++i) fw.tick();
  EXPECT_FLOAT_EQ(2.0f, call(fw, proto::COMMAND_HEARTBEAT).results.at(0));
}

TEST_F(Dispatcher, RebootIsRequestedOnlyByItsCommand) {
  Firmware fw;
  call(fw, proto::COMMAND_STATUS);
  EXPECT_FALSE(fw.dispatcher.reboot_requested());
  EXPECT_EQ(proto::CONTROL_OK, call(fw, proto::COMMAND_REBOOT).status);
  EXPECT_TRUE(fw.dispatcher.reboot_requested());
}

TEST_F(Dispatcher, ReplyStatusCodesAreOnlyTheThreeOfTheSeed) {
  Firmware fw;
  for (int cmd = 0; cmd < 256; ++cmd) {
    if (cmd == proto::COMMAND_REBOOT) continue;
    const Reply r = call(fw, static_cast<uint8_t>(cmd));
    EXPECT_LE(r.status, 2) << cmd;
    const bool known = cmd > proto::CONTROL_INVALID_COM && cmd < proto::kCommandCount;
    EXPECT_EQ(known, r.status != proto::CONTROL_INVALID_COM) << cmd;
  }
}

}  // namespace

namespace {

TEST(DispatcherStatus, ReportsTheResetCauseBootCountAndDroppedReplies) {
  harness::RamEeprom::erase();
  harness::Firmware fw;
  fw.health.reset_cause = proto::RESET_WATCHDOG | proto::RESET_REBOOT;
  fw.health.boot_count = 7;
  fw.health.replies_dropped = 3;
  const std::vector<harness::Reply> r =
      harness::replies(fw.send(harness::request(1, proto::COMMAND_STATUS, {})));
  ASSERT_EQ(1u, r.size());
  ASSERT_EQ(16u, r[0].results.size());
  EXPECT_EQ(proto::RESET_WATCHDOG | proto::RESET_REBOOT, r[0].results[12]);
  EXPECT_EQ(7.0f, r[0].results[13]);
  EXPECT_EQ(3.0f, r[0].results[14]);
}

}  // namespace
