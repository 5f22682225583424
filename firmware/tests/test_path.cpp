// The path and its waypoint window (core/path): validation, streaming in order through the
// window (room, overwriting only passed points), replacement, the exit speed and the length
// ahead that the follower brakes by, approach() data and passed().
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "path.hpp"
#include "protocol_table.hpp"

namespace {

constexpr float kVmax = 0.5f;
constexpr uint16_t W = core::kWindow;

std::vector<float> flat(const std::vector<core::Point>& pts, size_t first = 0, size_t n = SIZE_MAX) {
  std::vector<float> xy;
  for (size_t i = first; i < pts.size() && i < first + n; ++i) {
    xy.push_back(pts[i].x_m);
    xy.push_back(pts[i].y_m);
  }
  return xy;
}

// Begin a path of `pts` with up to 15 of them and append the rest in frames of 15 (it must fit
// the window); checks that every request was accepted.
void upload(core::Path& path, const std::vector<core::Point>& pts, const core::Pose& start = core::Pose{}) {
  const size_t first = pts.size() < 15 ? pts.size() : 15;
  const std::vector<float> xy = flat(pts, 0, first);
  ASSERT_EQ(path.begin(static_cast<float>(pts.size()), xy.data(), static_cast<uint8_t>(first), start), 0);
  for (size_t i = first; i < pts.size(); i += 15) {
    const std::vector<float> more = flat(pts, i, 15);
    ASSERT_EQ(path.append(static_cast<float>(i), more.data(), static_cast<uint8_t>(more.size() / 2)), 0);
  }
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

// A serpentine of n points 5 cm apart: rows along x, a step up in y every 20 points.
std::vector<core::Point> serpentine(int n) {
  std::vector<core::Point> pts;
  for (int i = 0; i < n; ++i) {
    const int row = i / 20, k = i % 20;
    const float x = 0.05f * static_cast<float>(row % 2 == 0 ? k : 19 - k);
    pts.push_back(core::Point{x, 0.3f * static_cast<float>(row)});
  }
  return pts;
}

const std::vector<core::Point> kThree{{0.2f, 0.0f}, {0.4f, 0.2f}, {0.6f, 0.2f}};

TEST(PathWindow, EmptyPathIsInactive) {
  core::Path path;
  EXPECT_EQ(path.count(), 0);
  EXPECT_FALSE(path.active());
  EXPECT_FALSE(path.pending());
  EXPECT_TRUE(path.all_received());
  EXPECT_EQ(path.room(), 0);
}

TEST(PathWindow, BadCountsAreRefusedWithTheRightReasonAndTheCurrentPathKept) {
  struct Case {
    float count;
    uint8_t n;  // points carried with it
    uint8_t reason;
  };
  const Case cases[] = {
      {0.0f, 0, proto::REASON_OUT_OF_RANGE},      {-1.0f, 0, proto::REASON_OUT_OF_RANGE},
      {-300.0f, 0, proto::REASON_OUT_OF_RANGE},   {0.5f, 0, proto::REASON_OUT_OF_RANGE},
      {2.5f, 0, proto::REASON_OUT_OF_RANGE},      {31.999f, 0, proto::REASON_OUT_OF_RANGE},
      {NAN, 0, proto::REASON_OUT_OF_RANGE},       {65536.0f, 0, proto::REASON_OVER_CAPACITY},
      {1e9f, 0, proto::REASON_OVER_CAPACITY},     {1.0f, 2, proto::REASON_ARG_COUNT},
      {14.0f, 15, proto::REASON_ARG_COUNT},
  };
  const std::vector<float> xy(30, 9.0f);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.count);
    core::Path path;
    upload(path, kThree);
    EXPECT_EQ(path.begin(c.count, xy.data(), c.n, core::Pose{5.0f, 5.0f, 0.0f}), c.reason);
    EXPECT_EQ(path.count(), 3);
    EXPECT_EQ(path.received(), 3);
    EXPECT_TRUE(path.active());
    EXPECT_NEAR(path.approach(kVmax).dir_x, 1.0f, 1e-6f);  // still from the old start (0, 0)
    expect_points(drain(path), kThree);
  }
}

TEST(PathWindow, PathsOfAnyLengthUpToTheMaximumAreAccepted) {
  for (float n : {1.0f, 32.0f, 33.0f, 1000.0f, 65535.0f}) {
    SCOPED_TRACE(n);
    core::Path path;
    const float xy[] = {1.0f, 0.0f};
    ASSERT_EQ(path.begin(n, xy, 1, core::Pose{}), 0);
    EXPECT_EQ(path.count(), n);
    EXPECT_EQ(path.received(), 1);
    EXPECT_EQ(path.all_received(), n == 1.0f);
    EXPECT_EQ(path.room(), std::min<float>(n - 1, W - 1));
    EXPECT_TRUE(path.active());  // it drives on what it has
  }
}

TEST(PathWindow, APathDrivesOnItsFirstPointsAndTheRestFollowsInOrder) {
  core::Path path;
  const float a[] = {0.1f, 0.0f, 0.2f, 0.0f};
  const float b[] = {0.3f, 0.1f, 0.4f, 0.1f};
  const float c[] = {0.5f, 0.2f};
  ASSERT_EQ(path.begin(5.0f, a, 2, core::Pose{}), 0);
  EXPECT_TRUE(path.active());
  EXPECT_FALSE(path.all_received());
  EXPECT_EQ(path.append(2.0f, b, 2), 0);
  EXPECT_EQ(path.received(), 4);
  EXPECT_FALSE(path.all_received());
  EXPECT_EQ(path.append(4.0f, c, 1), 0);
  EXPECT_TRUE(path.all_received());
  expect_points(drain(path), {{0.1f, 0.0f}, {0.2f, 0.0f}, {0.3f, 0.1f}, {0.4f, 0.1f}, {0.5f, 0.2f}});
}

TEST(PathWindow, AnAppendMustContinueAtReceivedAndStoresNothingOtherwise) {
  core::Path path;
  const float a[] = {0.1f, 0.0f, 0.2f, 0.0f};
  ASSERT_EQ(path.begin(5.0f, a, 2, core::Pose{}), 0);
  const float later[] = {9.0f, 9.0f};
  // Skipping ahead would leave a hole; going back would rewrite points the cart may be using
  // (a retransmission never reaches the path: the dispatcher answers it from its memory).
  EXPECT_EQ(path.append(3.0f, later, 1), proto::REASON_OUT_OF_ORDER);
  EXPECT_EQ(path.append(1.0f, later, 1), proto::REASON_OUT_OF_ORDER);
  EXPECT_EQ(path.append(0.0f, a, 2), proto::REASON_OUT_OF_ORDER);
  // Not a whole index in range: out of range.
  EXPECT_EQ(path.append(1.5f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.append(-1.0f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.append(65536.0f, later, 1), proto::REASON_OUT_OF_RANGE);
  EXPECT_EQ(path.append(NAN, later, 1), proto::REASON_OUT_OF_RANGE);
  // Beyond the path's count.
  const float four[] = {1.0f, 1.0f, 2.0f, 2.0f, 3.0f, 3.0f, 4.0f, 4.0f};
  EXPECT_EQ(path.append(2.0f, four, 4), proto::REASON_OVER_CAPACITY);
  EXPECT_EQ(path.received(), 2);
  EXPECT_EQ(path.append(2.0f, four, 3), 0);
  EXPECT_TRUE(path.all_received());
  expect_points(drain(path), {{0.1f, 0.0f}, {0.2f, 0.0f}, {1.0f, 1.0f}, {2.0f, 2.0f}, {3.0f, 3.0f}});
}

TEST(PathWindow, AppendWhenEveryPointHasArrivedIsBadState) {
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

TEST(PathWindow, TheWindowHoldsWPointsFromTheOneBeforeTheCurrentWaypoint) {
  const std::vector<core::Point> pts = serpentine(100);
  core::Path path;
  const std::vector<float> first = flat(pts, 0, 15);
  ASSERT_EQ(path.begin(100.0f, first.data(), 15, core::Pose{}), 0);
  EXPECT_EQ(path.room(), W - 15);
  const std::vector<float> fill = flat(pts, 15, W - 15);
  ASSERT_EQ(path.append(15.0f, fill.data(), static_cast<uint8_t>(W - 15)), 0);
  EXPECT_EQ(path.room(), 0);
  const std::vector<float> one = flat(pts, W, 1);
  EXPECT_EQ(path.append(W, one.data(), 1), proto::REASON_WINDOW_FULL);
  // At waypoint 1 the window still starts at point 0 (the segment into waypoint 1 starts there).
  path.advance();
  EXPECT_EQ(path.index(), 1);
  EXPECT_EQ(path.room(), 0);
  EXPECT_EQ(path.append(W, one.data(), 1), proto::REASON_WINDOW_FULL);
  // At waypoint 2 point 0 is no longer needed: one slot is free, for point W only.
  path.advance();
  EXPECT_EQ(path.room(), 1);
  const std::vector<float> two = flat(pts, W, 2);
  EXPECT_EQ(path.append(W, two.data(), 2), proto::REASON_WINDOW_FULL);
  EXPECT_EQ(path.received(), W);
  EXPECT_EQ(path.append(W, one.data(), 1), 0);
  EXPECT_EQ(path.room(), 0);
  // Point W took point 0's slot; points 1 on are intact: the segment into waypoint 2 still
  // starts at point 1, and the points read back in order.
  const core::Approach a = path.approach(kVmax);
  const float dx = pts[2].x_m - pts[1].x_m, dy = pts[2].y_m - pts[1].y_m;
  EXPECT_NEAR(a.dir_x, dx / std::hypot(dx, dy), 1e-6f);
  EXPECT_NEAR(a.dir_y, dy / std::hypot(dx, dy), 1e-6f);
  std::vector<core::Point> want(pts.begin() + 2, pts.begin() + W + 1);
  expect_points(drain(path), want);
}

TEST(PathWindow, ALongPathStreamsThroughTheWindowAndOnlyPassedPointsAreOverwritten) {
  // 1000 points through a window of W: the host sends whatever room there is (in frames of up
  // to 15) after every waypoint. Every waypoint comes out in order, and the direction of the
  // segment into it is computed from the right previous point, i.e. no slot still needed was
  // overwritten.
  const std::vector<core::Point> pts = serpentine(1000);
  core::Path path;
  std::vector<float> xy = flat(pts, 0, 15);
  ASSERT_EQ(path.begin(1000.0f, xy.data(), 15, core::Pose{}), 0);
  size_t checked = 0;
  while (path.pending()) {
    while (path.room() > 0) {
      const uint16_t n = std::min<uint16_t>(path.room(), 15);
      xy = flat(pts, path.received(), n);
      ASSERT_EQ(path.append(path.received(), xy.data(), static_cast<uint8_t>(n)), 0);
    }
    const uint16_t i = path.index();
    ASSERT_EQ(path.current().x_m, pts[i].x_m) << i;
    ASSERT_EQ(path.current().y_m, pts[i].y_m) << i;
    if (i > 0) {
      const float dx = pts[i].x_m - pts[i - 1].x_m, dy = pts[i].y_m - pts[i - 1].y_m;
      const core::Approach a = path.approach(kVmax);
      ASSERT_NEAR(a.dir_x, dx / std::hypot(dx, dy), 1e-6f) << i;
      ASSERT_NEAR(a.dir_y, dy / std::hypot(dx, dy), 1e-6f) << i;
      ++checked;
    }
    EXPECT_LE(path.received() - (i > 0 ? i - 1 : 0), W);
    path.advance();
  }
  EXPECT_EQ(checked, 999u);
  EXPECT_EQ(path.index(), 1000);
}

TEST(PathWindow, LengthAheadIsALowerBoundOfTheReceivedPathWithin30Percent) {
  // Segments at every angle: the bound (the larger of |dx| and |dy|) is exact along the axes
  // and 1/sqrt 2 of the length on the diagonals.
  std::vector<core::Point> pts;
  float x = 0.0f, y = 0.0f;
  for (int i = 0; i < 200; ++i) {
    const float angle = 0.37f * static_cast<float>(i);
    const float length = 0.02f + 0.01f * static_cast<float>(i % 7);
    x += length * std::cos(angle);
    y += length * std::sin(angle);
    pts.push_back(core::Point{x, y});
  }
  core::Path path;
  std::vector<float> xy = flat(pts, 0, 15);
  ASSERT_EQ(path.begin(200.0f, xy.data(), 15, core::Pose{}), 0);
  while (path.pending()) {
    if (path.room() > 0) {
      const uint16_t n = std::min<uint16_t>(path.room(), 15);
      xy = flat(pts, path.received(), n);
      ASSERT_EQ(path.append(path.received(), xy.data(), static_cast<uint8_t>(n)), 0);
    }
    double exact = 0.0;
    for (uint16_t k = path.index(); k + 1 < path.received(); ++k)
      exact += std::hypot(pts[k + 1].x_m - pts[k].x_m, pts[k + 1].y_m - pts[k].y_m);
    ASSERT_LE(path.length_ahead_m(), exact * (1 + 1e-5) + 1e-6) << path.index();
    ASSERT_GE(path.length_ahead_m(), exact * 0.7071 - 1e-6) << path.index();
    EXPECT_EQ(path.approach(kVmax).beyond_m, path.length_ahead_m());
    path.advance();
  }
}

TEST(PathWindow, TheLastPointReceivedIsApproachedAsAnEndUntilItsSuccessorArrives) {
  core::Path path;
  const float first[] = {1.0f, 0.0f};
  ASSERT_EQ(path.begin(3.0f, first, 1, core::Pose{}), 0);
  core::Approach a = path.approach(kVmax);
  EXPECT_TRUE(path.at_last_received());
  EXPECT_FALSE(path.at_last());
  EXPECT_TRUE(a.final);  // stop on it unless more arrive
  EXPECT_EQ(a.exit_speed_mps, 0.0f);
  EXPECT_EQ(a.beyond_m, 0.0f);
  EXPECT_NEAR(path.pass_radius(0.08f, 0.005f), 0.005f, 1e-7f);
  // Straight on: now it may be passed at full speed, with 1 m received beyond it.
  const float next[] = {2.0f, 0.0f};
  ASSERT_EQ(path.append(1.0f, next, 1), 0);
  a = path.approach(kVmax);
  EXPECT_FALSE(a.final);
  EXPECT_NEAR(a.exit_speed_mps, kVmax, 1e-6f);
  EXPECT_NEAR(a.beyond_m, 1.0f, 1e-6f);
  EXPECT_NEAR(path.pass_radius(0.08f, 0.005f), 0.08f, 1e-7f);
  path.advance();
  EXPECT_TRUE(path.approach(kVmax).final);
  EXPECT_EQ(path.approach(kVmax).beyond_m, 0.0f);
}

TEST(PathWindow, NoPointYetMeansNothingToDriveForButThePathIsPending) {
  core::Path path;
  ASSERT_EQ(path.begin(40.0f, nullptr, 0, core::Pose{}), 0);
  EXPECT_FALSE(path.active());
  EXPECT_TRUE(path.pending());
  EXPECT_EQ(path.room(), W);
  const float xy[] = {1.0f, 0.0f, 2.0f, 0.0f};
  ASSERT_EQ(path.append(0.0f, xy, 2), 0);
  EXPECT_TRUE(path.active());
  const core::Approach a = path.approach(kVmax);
  EXPECT_EQ(a.x_m, 1.0f);
  EXPECT_NEAR(a.dir_x, 1.0f, 1e-6f);  // from the start pose
  EXPECT_NEAR(a.exit_speed_mps, kVmax, 1e-6f);
}

TEST(PathWindow, AReplacementDropsTheOldPathWhole) {
  // A long path half driven, its window full; the replacement brings 3 points of a 50-point
  // path. Nothing of the old one is left: the waypoints, the index, the counts, the length
  // ahead, the segment into the first waypoint (from the new start) and the room.
  const std::vector<core::Point> old_pts = serpentine(300);
  core::Path path;
  std::vector<float> xy = flat(old_pts, 0, 15);
  ASSERT_EQ(path.begin(300.0f, xy.data(), 15, core::Pose{}), 0);
  for (int i = 0; i < 40; ++i) {
    if (path.room() > 0) {
      const uint16_t n = std::min<uint16_t>(path.room(), 15);
      xy = flat(old_pts, path.received(), n);
      ASSERT_EQ(path.append(path.received(), xy.data(), static_cast<uint8_t>(n)), 0);
    }
    path.advance();
  }
  ASSERT_EQ(path.index(), 40);
  const uint16_t old_received = path.received();
  const std::vector<core::Point> fresh{{3.0f, 3.0f}, {4.0f, 3.0f}, {5.0f, 3.0f}};
  xy = flat(fresh);
  ASSERT_EQ(path.begin(50.0f, xy.data(), 3, core::Pose{3.0f, 2.0f, 0.0f}), 0);
  EXPECT_EQ(path.index(), 0);
  EXPECT_EQ(path.count(), 50);
  EXPECT_EQ(path.received(), 3);
  EXPECT_EQ(path.room(), W - 3);
  EXPECT_NEAR(path.length_ahead_m(), 2.0f, 1e-6f);
  const core::Approach a = path.approach(kVmax);
  EXPECT_NEAR(a.dir_x, 0.0f, 1e-6f);  // from (3, 2) up to (3, 3)
  EXPECT_NEAR(a.dir_y, 1.0f, 1e-6f);
  EXPECT_EQ(a.exit_speed_mps, 0.0f);  // a right angle at (3, 3)
  // The old path's next append no longer fits anywhere.
  xy = flat(old_pts, old_received, 1);
  EXPECT_EQ(path.append(old_received, xy.data(), 1), proto::REASON_OUT_OF_ORDER);
  expect_points(drain(path), fresh);
  EXPECT_TRUE(path.pending());  // 47 more to come
}

TEST(PathWindow, SetSingleReplacesThePath) {
  core::Path path;
  upload(path, kThree);
  path.advance();
  path.set_single(core::Point{-1.0f, 2.0f}, core::Pose{-1.0f, 0.0f, 0.0f});
  EXPECT_EQ(path.count(), 1);
  EXPECT_EQ(path.index(), 0);
  EXPECT_TRUE(path.at_last());
  EXPECT_TRUE(path.all_received());
  const core::Approach a = path.approach(kVmax);
  EXPECT_TRUE(a.final);
  EXPECT_EQ(a.exit_speed_mps, 0.0f);
  EXPECT_NEAR(a.dir_y, 1.0f, 1e-6f);
  expect_points(drain(path), {{-1.0f, 2.0f}});
}

TEST(PathWindow, ApproachWalksThePointsAndFlagsOnlyTheLastAsFinal) {
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

TEST(PathWindow, ExitSpeedFollowsTheTurnAngle) {
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

TEST(PathWindow, ApproachCarriesTheDirectionOfTheSegmentIntoTheWaypoint) {
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

TEST(PathWindow, ThePassRadiusShrinksToTheFinalToleranceAtCornersToStopFor) {
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

TEST(PathWindow, ExitSpeedUsesThePreviousWaypointAfterAdvancing) {
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

TEST(PathWindow, FirstCornerIsMeasuredFromTheStartPose) {
  // The same two points; starting from (1, -1) the approach to (1, 0) is along +y and the
  // path turns right onto +x: exit 0. Starting from (0, 0) it is straight on: exit v_max.
  core::Path path;
  upload(path, {{1.0f, 0.0f}, {2.0f, 0.0f}});
  path.start_from(core::Pose{1.0f, -1.0f, 0.0f});
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, 0.0f, 1e-6f);
  path.start_from(core::Pose{0.0f, 0.0f, 0.0f});
  EXPECT_NEAR(path.approach(kVmax).exit_speed_mps, kVmax, 1e-6f);
}

TEST(PathWindow, PassedMeansBeyondTheWaypointAlongItsSegment) {
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
