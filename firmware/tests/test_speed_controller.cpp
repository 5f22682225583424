// Wheel-speed control: the PIs regulate the measuring wheels' speeds, the feedforward drives
// the traction wheels, which are on another track (0.182 m against 0.305 m).
#include <gtest/gtest.h>

#include "robot_params.hpp"
#include "speed_controller.hpp"

namespace {

constexpr float kMeasuringTrack = params::encoders::track_m;
constexpr float kRatio = params::traction::track_m / params::encoders::track_m;

TEST(SpeedController, TractionSpeedsKeepVAndScaleTheTurn) {
  const core::WheelSpeeds measuring = core::wheel_speeds(0.3f, 2.0f, kMeasuringTrack);
  const core::WheelSpeeds traction = core::traction_speeds(measuring, kRatio);
  EXPECT_NEAR(0.3f, 0.5f * (traction.left_mps + traction.right_mps), 1e-6f);
  EXPECT_NEAR(2.0f, (traction.right_mps - traction.left_mps) / params::traction::track_m, 1e-5f);
}

// Turning on the spot at 3 rad/s: the measuring wheels run at +-0.4575 m/s, the traction wheels
// at +-0.273 m/s. With nothing for the PIs to correct, the command is the feedforward alone, and
// it must be the traction wheels' (it was the measuring wheels': 1.68 x too much).
TEST(SpeedController, TurningOnTheSpotFeedsForwardTheTractionWheelsSpeeds) {
  const core::WheelSpeeds target = core::wheel_speeds(0.0f, 3.0f, kMeasuringTrack);
  core::SpeedController speed;
  const core::SpeedGains gains{{1000.0f, 3000.0f}, 1000.0f};
  const core::MotorCommand out =
      speed.update(target, target, core::traction_speeds(target, kRatio), gains, 0.008f, 1000.0f);
  EXPECT_EQ(-273, out.left);
  EXPECT_EQ(273, out.right);
}

TEST(SpeedController, StraightDrivingIsTheSameOnBothTracks) {
  const core::WheelSpeeds target = core::wheel_speeds(0.4f, 0.0f, kMeasuringTrack);
  const core::WheelSpeeds traction = core::traction_speeds(target, kRatio);
  EXPECT_FLOAT_EQ(target.left_mps, traction.left_mps);
  EXPECT_FLOAT_EQ(target.right_mps, traction.right_mps);
}

}  // namespace
