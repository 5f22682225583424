// The waypoint buffer (core/path): upload validation, multi-frame upload, approach() data
// (remaining length, exit speed, final flag) and passed().
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "path.hpp"
#include "protocol_table.hpp"

namespace {

constexpr float kVmax = 0.5f;

// Upload `pts` in one go and check it was accepted.
void upload(core::Path& path, const std::vector<core::Point>& pts) {
  std::vector<float> xy;
  for (const core::Point& p : pts) {
    xy.push_back(p.x_m);
    xy.push_back(p.y_m);
  }
  ASSERT_EQ(path.begin(static_cast<float>(pts.size())), 0);
  ASSERT_EQ(path.append(0.0f, xy.data(), static_cast<uint8_t>(pts.size())), 0);
}

// The waypoints in order, read through the public interface (consumes the path).
std::vector<core::Point> drain(core::Path& path) {
  std::vector<core::Point> out;
  while (path.active()) {
    out.push_back(path.current());
    path.advance();
  }
  return out;
}

void expect_points(const std::vector<core::Point>& got, const std::vector<core::Point>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].x_m, want[i].x_m) << i;
    EXPECT_EQ(got[i].y_m, want[i].y_m) << i;
  }
}

const std::vector<core::Point> kThree{{0.2f, 0.0f}, {0.4f, 0.2f}, {0.6f, 0.2f}};

TEST(PathBuffer, EmptyPathIsInactive) {
  core::Path path;
  EXPECT_EQ(path.count(), 0);
  EXPECT_FALSE(path.active());
  EXPECT_FALSE(path.upload_open());
}

TEST(PathBuffer, BadCountsAreRefusedWithTheRightReasonAndTheCurrentPathKept) {
  static_assert(core::kWaypointCapacity == 32, "robot.toml: waypoint_capacity = 32");
  struct Case {
    float count;
    uint8_t reason;
  };
  const Case cases[] = {
      {0.0f, proto::REASON_OUT_OF_RANGE},     {-1.0f, proto::REASON_OUT_OF_RANGE},
      {-300.0f, proto::REASON_OUT_OF_RANGE},  {0.5f, proto::REASON_OUT_OF_RANGE},
      {2.5f, proto::REASON_OUT_OF_RANGE},     {31.999f, proto::REASON_OUT_OF_RANGE},
      {33.0f, proto::REASON_OVER_CAPACITY},   {256.0f, proto::REASON_OVER_CAPACITY},
      {1e9f, proto::REASON_OVER_CAPACITY},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.count);
    core::Path path;
    upload(path, kThree);
    EXPECT_EQ(path.begin(c.count), c.reason);
    EXPECT_EQ(path.count(), 3);
    EXPECT_EQ(path.received(), 3);
    EXPECT_FALSE(path.upload_open());
    EXPECT_TRUE(path.active());
    expect_points(drain(path), kThree);
  }
}

TEST(PathBuffer, RefusedBeginKeepsAnUploadInProgress) {
  core::Path path;
  ASSERT_EQ(path.begin(4.0f), 0);
  const float xy[] = {1.0f, 2.0f, 3.0f, 4.0f};
  ASSERT_EQ(path.append(0.0f, xy, 2), 0);
  EXPECT_EQ(path.begin(40.0f), proto::REASON_OVER_CAPACITY);
  EXPECT_TRUE(path.upload_open());
  EXPECT_EQ(path.count(), 4);
  EXPECT_EQ(path.received(), 2);
}

TEST(PathBuffer, FullCapacityIsAccepted) {
  core::Path path;
  std::vector<core::Point> pts;
  for (int i = 0; i < 32; ++i) pts.push_back(core::Point{0.1f * i, 0.0f});
  upload(path, pts);
  EXPECT_EQ(path.count(), 32);
  expect_points(drain(path), pts);
}

TEST(PathBuffer, MultiFrameUploadInOrder) {
  // 5 points in frames of 2, 2, 1: the path is active only once all have arrived.
  core::Path path;
  ASSERT_EQ(path.begin(5.0f), 0);
  EXPECT_TRUE(path.upload_open());
  EXPECT_FALSE(path.active());
  const float a[] = {0.1f, 0.0f, 0.2f, 0.0f};
  const float b[] = {0.3f, 0.1f, 0.4f, 0.1f};
  const float c[] = {0.5f, 0.2f};
  EXPECT_EQ(path.append(0.0f, a, 2), 0);
  EXPECT_EQ(path.received(), 2);
  EXPECT_EQ(path.append(2.0f, b, 2), 0);
  EXPECT_EQ(path.received(), 4);
  EXPECT_TRUE(path.upload_open());
  EXPECT_FALSE(path.active());
  EXPECT_EQ(path.append(4.0f, c, 1), 0);
  EXPECT_EQ(path.received(), 5);
  EXPECT_FALSE(path.upload_open());
  EXPECT_TRUE(path.active());
  expect_points(drain(path), {{0.1f, 0.0f}, {0.2f, 0.0f}, {0.3f, 0.1f}, {0.4f, 0.1f}, {0.5f, 0.2f}});
}

TEST(PathBuffer, AppendOutOfOrderIsRefused) {
  core::Path path;
  ASSERT_EQ(path.begin(5.0f), 0);
  const float a[] = {0.1f, 0.0f, 0.2f, 0.0f};
  ASSERT_EQ(path.append(0.0f, a, 2), 0);
  // Skipping ahead (index 3 while 2 have arrived) would leave a hole.
  const float later[] = {9.0f, 9.0f};
  EXPECT_EQ(path.append(3.0f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.received(), 2);
  // A non-whole or negative index is refused too.
  EXPECT_EQ(path.append(1.5f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.append(-1.0f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.received(), 2);
  // Going past the announced count is refused and stores nothing.
  const float three[] = {1.0f, 1.0f, 2.0f, 2.0f, 3.0f, 3.0f, 4.0f, 4.0f};
  EXPECT_EQ(path.append(2.0f, three, 4), proto::REASON_OVER_CAPACITY);
  EXPECT_EQ(path.received(), 2);
  // The right continuation is still accepted afterwards.
  EXPECT_EQ(path.append(2.0f, three, 3), 0);
  EXPECT_FALSE(path.upload_open());
  expect_points(drain(path), {{0.1f, 0.0f}, {0.2f, 0.0f}, {1.0f, 1.0f}, {2.0f, 2.0f}, {3.0f, 3.0f}});
}

TEST(PathBuffer, RetransmittedAppendIsAcceptedWithoutChange) {
  core::Path path;
  ASSERT_EQ(path.begin(4.0f), 0);
  const float a[] = {0.1f, 0.0f, 0.2f, 0.0f};
  ASSERT_EQ(path.append(0.0f, a, 2), 0);
  // The reply was lost: the host sends the same frame again.
  EXPECT_EQ(path.append(0.0f, a, 2), 0);
  EXPECT_EQ(path.received(), 2);
  EXPECT_TRUE(path.upload_open());
  const float b[] = {0.3f, 0.0f, 0.4f, 0.0f};
  ASSERT_EQ(path.append(2.0f, b, 2), 0);
  expect_points(drain(path), {{0.1f, 0.0f}, {0.2f, 0.0f}, {0.3f, 0.0f}, {0.4f, 0.0f}});
}

TEST(PathBuffer, AppendWithNoUploadOpenIsBadState) {
  const float xy[] = {1.0f, 1.0f};
  core::Path fresh;
  EXPECT_EQ(fresh.append(0.0f, xy, 1), proto::REASON_BAD_STATE);
  EXPECT_EQ(fresh.count(), 0);

  core::Path done;
  upload(done, kThree);
  EXPECT_EQ(done.append(3.0f, xy, 1), proto::REASON_BAD_STATE);
  EXPECT_EQ(done.append(0.0f, xy, 1), proto::REASON_BAD_STATE);
  expect_points(drain(done), kThree);
}

TEST(PathBuffer, SetSingleReplacesThePath) {
  core::Path path;
  upload(path, kThree);
  path.set_single(core::Point{-1.0f, 2.0f});
  EXPECT_EQ(path.count(), 1);
  EXPECT_TRUE(path.at_last());
  const core::Approach a = path.approach(kVmax);
  EXPECT_TRUE(a.final);
  EXPECT_EQ(a.exit_speed_mps, 0.0f);
  expect_points(drain(path), {{-1.0f, 2.0f}});
}

TEST(PathBuffer, ClearEmptiesThePath) {
  core::Path path;
  upload(path, kThree);
  path.clear();
  EXPECT_FALSE(path.active());
  EXPECT_EQ(path.count(), 0);
}

TEST(PathBuffer, ApproachWalksThePointsAndFlagsOnlyTheLastAsFinal) {
  core::Path path;
  const std::vector<core::Point> points = {{1.0f, 0.0f}, {1.0f, 1.0f}, {4.0f, 5.0f}, {4.0f, 6.0f}};
  upload(path, points);
  path.start_from(core::Pose{});
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(path.active());
    const core::Approach a = path.approach(kVmax);
    EXPECT_EQ(a.x_m, points[i].x_m) << i;
    EXPECT_EQ(a.y_m, points[i].y_m) << i;
    EXPECT_EQ(a.final, i == 3) << i;
    EXPECT_EQ(path.at_last(), i == 3) << i;
    path.advance();
  }
  EXPECT_FALSE(path.active());
}

TEST(PathBuffer, ExitSpeedFollowsTheTurnAngle) {
  struct Case {
    const char* name;
    core::Point next;     // after the waypoint (1, 0), reached from the start (0, 0)
    float expected_exit;  // v_max * (1 - |tan(turn)|), 0 from 45 deg on and when turning back
  };
  const Case cases[] = {
      {"collinear", {2.0f, 0.0f}, kVmax},                   // tan 0 = 0
      {"gentle_26.6deg", {3.0f, 1.0f}, kVmax * 0.5f},       // tan = 1/2
      {"45deg_turns_on_the_spot", {2.0f, 1.0f}, 0.0f},       // tan 45 = 1
      {"right_angle_left", {1.0f, 1.0f}, 0.0f},
      {"right_angle_right", {1.0f, -3.0f}, 0.0f},
      {"sharp_135deg", {0.0f, 1.0f}, 0.0f},                 // |tan 135| = 1, but turning back anyway
      {"nearly_back_170deg", {-4.67f, 1.0f}, 0.0f},         // |tan| ~ 0.18: still 0, it turns back
      {"u_turn", {0.0f, 0.0f}, 0.0f},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    core::Path path;
    upload(path, {{1.0f, 0.0f}, c.next});
    path.start_from(core::Pose{});
    const core::Approach a = path.approach(kVmax);
    EXPECT_FALSE(a.final);
    EXPECT_NEAR(a.exit_speed_mps, c.expected_exit, 1e-5f);
    EXPECT_EQ(a.x_m, 1.0f);
    EXPECT_EQ(a.y_m, 0.0f);
  }
}

TEST(PathBuffer, ApproachCarriesTheDirectionOfTheSegmentIntoTheWaypoint) {
  core::Path path;
  upload(path, {{3.0f, 4.0f}, {3.0f, 0.0f}});
  path.start_from(core::Pose{});
  core::Approach a = path.approach(kVmax);
  EXPECT_NEAR(a.dir_x, 0.6f, 1e-6f);  // (3, 4) / 5
  EXPECT_NEAR(a.dir_y, 0.8f, 1e-6f);
  path.advance();
  a = path.approach(kVmax);
  EXPECT_NEAR(a.dir_x, 0.0f, 1e-6f);
  EXPECT_NEAR(a.dir_y, -1.0f, 1e-6f);
}

TEST(PathBuffer, ThePassRadiusShrinksToTheFinalToleranceAtCornersToStopFor) {
  const float tol_pass = 0.05f, tol_final = 0.005f;
  core::Path path;
  upload(path, {{1.0f, 0.0f}, {2.0f, 0.0f}, {2.0f, 1.0f}, {2.5f, 2.0f}});
  path.start_from(core::Pose{});
  EXPECT_NEAR(path.pass_radius(tol_pass, tol_final), tol_pass, 1e-7f);  // straight on
  path.advance();
  EXPECT_NEAR(path.pass_radius(tol_pass, tol_final), tol_final, 1e-7f);  // 90 deg: stop on it
  path.advance();
  EXPECT_NEAR(path.pass_radius(tol_pass, tol_final), tol_pass * 0.5f, 1e-7f);  // tan = 1/2
  path.advance();
  EXPECT_NEAR(path.pass_radius(tol_pass, tol_final), tol_final, 1e-7f);  // the end
}

TEST(PathBuffer, ExitSpeedUsesThePreviousWaypointAfterAdvancing) {
  // (0,0) -> (1,0) -> (2,0) -> (2,1): at (2,0) the incoming segment is (1,0)->(2,0), the
  // outgoing (2,0)->(2,1): a right angle, exit 0. At (1,0) it is straight on: exit v_max.
  core::Path path;
  upload(path, {{1.0f, 0.0f}, {2.0f, 0.0f}, {2.0f, 1.0f}});
  path.start_from(core::Pose{});
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, kVmax, 1e-6f);
  path.advance();
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, 0.0f, 1e-6f);
  path.advance();
  const core::Approach last = path.approach(kVmax);
  EXPECT_TRUE(last.final);
  EXPECT_EQ(last.exit_speed_mps, 0.0f);
}

TEST(PathBuffer, FirstCornerIsMeasuredFromTheStartPose) {
  // The same two points; starting from (1, -1) the approach to (1, 0) is along +y and the
  // path turns right onto +x: exit 0. Starting from (0, 0) it is straight on: exit v_max.
  core::Path path;
  upload(path, {{1.0f, 0.0f}, {2.0f, 0.0f}});
  path.start_from(core::Pose{1.0f, -1.0f, 0.0f});
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, 0.0f, 1e-6f);
  path.start_from(core::Pose{0.0f, 0.0f, 0.0f});
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, kVmax, 1e-6f);
}

TEST(PathBuffer, PassedMeansBeyondTheWaypointAlongItsSegment) {
  // Segment (0,0) -> (1,0): passed when (pose - waypoint) . (1, 0) > 0, i.e. x > 1, whatever y.
  struct Case {
    float x;
    float y;
    bool passed;
  };
  const Case cases[] = {{0.5f, 0.0f, false}, {0.99f, 0.3f, false}, {1.0f, 0.0f, false},
                        {1.01f, 0.0f, true},  {1.2f, -0.5f, true}, {3.0f, 2.0f, true}};
  core::Path path;
  upload(path, {{1.0f, 0.0f}, {1.0f, 1.0f}});
  path.start_from(core::Pose{});
  for (const Case& c : cases)
    EXPECT_EQ(path.passed(core::Pose{c.x, c.y, 0.0f}), c.passed) << c.x << "," << c.y;
  // Second waypoint: segment (1,0) -> (1,1): passed when y > 1.
  path.advance();
  EXPECT_FALSE(path.passed(core::Pose{5.0f, 0.9f, 0.0f}));
  EXPECT_TRUE(path.passed(core::Pose{1.0f, 1.1f, 0.0f}));
}

}  // namespace
