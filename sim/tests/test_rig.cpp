// The simavr parts against a tiny AVR program (avr/pin_exerciser.c) that uses the pins exactly
// as the firmware does: encoder interrupts, Timer1 PWM, switches with pull-ups, the UART, the
// 125 Hz tick and idle sleep. All assertions are in simulated time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "eeprom_store.hpp"
#include "rig.hpp"
#include "robot_params.hpp"

namespace cart2d {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr uint64_t kHz = 16000000;

struct Report {
  long left = 0, right = 0;
  bool sw_left = false, sw_right = false;
  bool ok = false;
};

class RigTest : public ::testing::Test {
 protected:
  void SetUp() override { start(RigConfig{}); }

  void start(RigConfig rc) {
    rig_ = std::make_unique<Rig>();
    rc.firmware = PIN_EXERCISER_ELF;
    rc.open_pty = false;
    if (rc.start.x_m == 0 && rc.start.y_m == 0) rc.start = Pose{0.9, 0.9, 0.0};
    std::string err;
    ASSERT_TRUE(rig_->init(rc, &err)) << err;
    rig_->set_scripted_twist(Twist{});  // the cart only moves when a test says so
    run_s(boot_s());                    // the reset time-out, then the program sets up its peripherals
  }

  void run_s(double s) { ASSERT_TRUE(rig_->run_cycles(static_cast<uint64_t>(s * kHz))); }
  // From a reset until the program has set up its peripherals: the time-out tTOUT, then 50 ms.
  double boot_s() const { return static_cast<double>(rig_->mcu().timeout_cycles()) / kHz + 0.05; }

  // Asks the program for its counters ('c') and parses the line it answers.
  Report report() {
    run_s(0.002);  // edges of the last physics step are still on their way
    rig_->uart().take_output(rig_->cycle());
    rig_->uart().inject("c");
    run_s(0.02);
    const std::string line = rig_->uart().take_output(rig_->cycle());
    Report r;
    char sw[3] = {0};
    r.ok = std::sscanf(line.c_str(), "L=%ld R=%ld S=%2c", &r.left, &r.right, sw) == 3;
    r.sw_left = sw[0] == '1';
    r.sw_right = sw[1] == '1';
    return r;
  }

  std::unique_ptr<Rig> rig_;
};

TEST_F(RigTest, DutiesFollowTimer1AndDirectionPins) {
  // The program: OCR1A = 40 (right, forward), OCR1B = 120 (left, D4 high = backward), ICR1 = 160.
  EXPECT_DOUBLE_EQ(rig_->duties().right, 0.25);
  EXPECT_DOUBLE_EQ(rig_->duties().left, -0.75);
  rig_->uart().inject("o");  // COM bits cleared, pins low
  run_s(0.01);
  EXPECT_DOUBLE_EQ(rig_->duties().right, 0.0);
  EXPECT_DOUBLE_EQ(rig_->duties().left, 0.0);
}

TEST_F(RigTest, OneRevolutionGives2000CountsPerWheel) {
  const double r = params::encoders::radius_m;
  rig_->set_scripted_twist(Twist{2 * kPi * r, 0.0});  // one measuring-wheel revolution per second
  run_s(1.0);
  rig_->set_scripted_twist(Twist{});
  const Report fwd = report();
  ASSERT_TRUE(fwd.ok);
  EXPECT_EQ(fwd.left, 2000);   // x2 decoding: both edges of A, 1000 pulses
  EXPECT_EQ(fwd.right, 2000);
  EXPECT_EQ(rig_->encoder_left().edges_emitted(), 4000u);  // A and B
  EXPECT_EQ(rig_->encoder_right().edges_emitted(), 4000u);

  rig_->set_scripted_twist(Twist{-2 * kPi * r, 0.0});
  run_s(0.25);
  rig_->set_scripted_twist(Twist{});
  const Report back = report();
  EXPECT_EQ(back.left, 1500);
  EXPECT_EQ(back.right, 1500);
}

TEST_F(RigTest, TurningCountsOppositeWays) {
  // ω such that each measuring wheel rolls one circumference per second.
  const double w = 2 * kPi * params::encoders::radius_m / (params::encoders::track_m / 2);
  rig_->set_scripted_twist(Twist{0.0, w});
  run_s(0.5);
  rig_->set_scripted_twist(Twist{});
  const Report rep = report();
  EXPECT_EQ(rep.left, -1000);
  EXPECT_EQ(rep.right, 1000);
}

TEST_F(RigTest, FastWheelsLoseNoEdges) {
  // 1 m/s (the cart's top speed): 30 000 edges/s per encoder, every A edge an interrupt.
  rig_->set_scripted_twist(Twist{1.0, 0.0});
  run_s(0.5);
  rig_->set_scripted_twist(Twist{});
  const Report rep = report();
  // Every A edge counted (x2 decoding), none misread.
  EXPECT_EQ(rep.left, static_cast<long>(rig_->encoder_left().a_edges_emitted()));
  EXPECT_EQ(rep.right, static_cast<long>(rig_->encoder_right().a_edges_emitted()));
  // 0.5 s at 1 m/s, give or take the physics step that straddles the end of the run.
  EXPECT_NEAR(rep.left, 0.5 / (2 * kPi * params::encoders::radius_m) * 2000, 5);
}

TEST_F(RigTest, SwitchesCloseAgainstTheWallWithPullUps) {
  Report rep = report();
  EXPECT_FALSE(rep.sw_left);
  EXPECT_FALSE(rep.sw_right);
  const double x_touch = rig_->world().arena().x_max() - params::body::bumper_x_m;
  rig_->place(Pose{x_touch, 0.9, 0.0});
  rep = report();
  EXPECT_TRUE(rep.sw_left);
  EXPECT_TRUE(rep.sw_right);
  rig_->place(Pose{x_touch, 0.9, 0.1});  // turned left: only the right switch touches
  rep = report();
  EXPECT_FALSE(rep.sw_left);
  EXPECT_TRUE(rep.sw_right);
}

TEST_F(RigTest, CpuMeterSeesTheTickIsrBurn) {
  rig_->cpu().reset_total();
  run_s(1.0);
  const CpuMeter::Summary s = rig_->cpu().total();
  EXPECT_NEAR(static_cast<double>(s.ticks), 125, 1);
  // 12 800 burnt cycles = 10 % plus interrupt entry/exit and the sleep loop.
  EXPECT_GT(s.mean, 0.100);
  EXPECT_LT(s.mean, 0.101);
  EXPECT_EQ(s.overruns, 0u);
}

TEST_F(RigTest, UartRoundTripTakesAboutTwoFrames) {
  // 115200 baud with U2X and UBRR = 16: (16 + 1)·8 cycles per bit, 10 bits per 8N1 frame.
  const uint64_t frame = 17 * 8 * 10;
  EXPECT_EQ(rig_->uart().frame_cycles(), frame);
  rig_->uart().take_output(rig_->cycle());
  const uint64_t t0 = rig_->cycle();
  rig_->uart().inject("x");
  uint64_t done = 0;
  std::string out;
  while (out.empty() && rig_->cycle() < t0 + 10 * frame) {
    ASSERT_TRUE(rig_->run_cycles(8));
    out = rig_->uart().take_output(rig_->cycle());
    done = rig_->cycle();
  }
  ASSERT_EQ(out, "X");
  // Each receiver decides a byte at its stop bit's centre, not at its end (test_usart.cpp has
  // the exact figures): the 'x' is read 77 of 136 / 8 samples after it starts, the echo
  // reaches the host 153 of its 16x samples after it leaves; the ISR adds a few cycles.
  EXPECT_GE(done - t0, 2 * frame - 2 * 136);
  EXPECT_LE(done - t0, 2 * frame);
}

TEST_F(RigTest, ResetRestartsTheProgramAndKeepsPins) {
  rig_->set_scripted_twist(Twist{0.1, 0.0});
  run_s(0.2);
  rig_->set_scripted_twist(Twist{});
  EXPECT_GT(report().left, 0);
  rig_->reset_mcu();
  EXPECT_DOUBLE_EQ(rig_->duties().left, 0.0);
  run_s(boot_s());
  const Report rep = report();
  ASSERT_TRUE(rep.ok);
  EXPECT_EQ(rep.left, 0);
  EXPECT_DOUBLE_EQ(rig_->duties().left, -0.75);
  // The encoders keep working after the reset.
  rig_->set_scripted_twist(Twist{2 * kPi * params::encoders::radius_m, 0.0});
  run_s(0.5);
  rig_->set_scripted_twist(Twist{});
  EXPECT_EQ(report().right, 1000);
}

TEST_F(RigTest, EepromSurvivesARestartThroughTheStore) {
  const std::string path = ::testing::TempDir() + "/cart2d_sim_test_eeprom.bin";
  std::remove(path.c_str());
  EepromStore store(path);
  EXPECT_FALSE(store.load(rig_->mcu().avr()));
  EXPECT_EQ(EepromStore::read_eeprom(rig_->mcu().avr())[0], 0xFF);
  rig_->uart().inject("w");
  run_s(0.02);
  EXPECT_TRUE(store.changed(rig_->mcu().avr()));
  std::string err;
  ASSERT_TRUE(store.save(rig_->mcu().avr(), &err)) << err;
  EXPECT_FALSE(store.changed(rig_->mcu().avr()));

  start(RigConfig{});  // a fresh MCU: erased EEPROM until the store restores it
  EXPECT_EQ(EepromStore::read_eeprom(rig_->mcu().avr())[0], 0xFF);
  EepromStore again(path);
  ASSERT_TRUE(again.load(rig_->mcu().avr()));
  EXPECT_EQ(EepromStore::read_eeprom(rig_->mcu().avr())[0], 0x5A);
  std::remove(path.c_str());
}

// Same seed, same inputs → the same trajectory and the same counts, faults included.
TEST(RigDeterminism, SameSeedSameRun) {
  auto run = [](uint64_t seed) {
    Rig rig;
    RigConfig rc;
    rc.firmware = PIN_EXERCISER_ELF;
    rc.open_pty = false;
    rc.seed = seed;
    rc.start = Pose{0.9, 0.9, 0.0};
    std::string err;
    EXPECT_TRUE(rig.init(rc, &err)) << err;
    Faults f;
    f.enc_miss_prob = 0.01;
    f.enc_noise_hz = 200;
    f.uart_tx_corrupt = 0.2;
    rig.set_faults(f);
    // The program drives left −0.75, right +0.25: the cart spins and crawls under real dynamics.
    rig.run_cycles(2 * kHz);
    rig.uart().inject("cccc");
    rig.run_cycles(kHz / 20);
    return std::make_tuple(rig.cart().pose().x_m, rig.cart().pose().y_m, rig.cart().pose().theta_rad,
                           rig.uart().take_output(rig.cycle()), rig.encoder_left().edges_emitted());
  };
  const auto a = run(5), b = run(5), c = run(6);
  EXPECT_EQ(a, b);
  EXPECT_NE(std::get<3>(a), std::get<3>(c));  // different corruption pattern
}

}  // namespace
}  // namespace cart2d
