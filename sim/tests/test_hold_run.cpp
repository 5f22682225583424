// The side channel's "hold" (sim/README.md): simulated time stops at the hold, the camera's frames
// up to it arrive, and time goes on when a later hold moves it or a null one ends it. Runs the
// cart2d-sim binary with the real firmware (`make firmware`) at full speed and talks to it over
// TCP as the launcher does.
#include <gtest/gtest.h>

#include <arpa/inet.h>   // inet_pton, htons
#include <netinet/in.h>  // sockaddr_in
#include <poll.h>        // poll
#include <sys/socket.h>  // socket, connect, send, recv
#include <unistd.h>      // close

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>

#include "json.hpp"

namespace cart2d {
namespace {

constexpr double kFps = 15.0;         // the test's camera settings, sent with "camera"
constexpr double kLatencyS = 0.06;
constexpr double kInstructionS = 4.0 / 16e6;  // the MCU stops within an instruction of the hold
constexpr double kWallLimitS = 60.0;  // generous: a busy machine is slow, never wrong

// cart2d-sim at full speed, paused at 0 until a test resumes it, on an ephemeral side-channel
// port, and one client connection to it.
class SimProcess {
 public:
  SimProcess() {
    const std::string cmd = std::string("exec '") + CART2D_SIM_EXE + "' --firmware '" + CART2D_FIRMWARE_ELF +
                            "' --eeprom '" + ::testing::TempDir() + "cart2d_hold_eeprom.bin' --speed max --truth-hz 0 --paused --quiet";
    out_ = ::popen(cmd.c_str(), "r");
    char line[4096];
    if (!out_ || !std::fgets(line, sizeof line, out_)) return;
    json::Value ready;
    std::string error;
    if (!json::parse(line, &ready, &error) || !ready.find("control")) return;
    const std::string control = ready.find("control")->string;
    const int port = std::stoi(control.substr(control.find(':') + 1));
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~SimProcess() {
    if (fd_ >= 0) {
      request(R"({"type":"quit"})");
      ::close(fd_);
    }
    if (out_) ::pclose(out_);
  }
  bool ok() const { return fd_ >= 0; }

  // Sends one message and returns its ack; frames on the way go to on_frame.
  json::Value request(const std::string& message) {
    const std::string line = message + "\n";
    if (::send(fd_, line.data(), line.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(line.size())) return {};
    for (json::Value v; next(&v);) {
      const json::Value* type = v.find("type");
      if (type && type->string == "ack") return v;
      if (type && type->string == "frame" && v.find("t")) newest_frame_t = v.find("t")->number;
    }
    return {};
  }

  json::Value stats() { return *request(R"({"type":"stats"})").find("stats"); }
  double sim_time() { return stats().find("t")->number; }
  bool held() {
    const json::Value* hold = stats().find("hold");
    return hold && hold->find("held")->boolean;
  }

  // Asks until the predicate holds (true) or kWallLimitS of wall time passed (false).
  bool wait_until(const std::function<bool()>& predicate) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(kWallLimitS);
    while (std::chrono::steady_clock::now() < end) {
      if (predicate()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

  double newest_frame_t = -1.0;  // the capture time of the newest camera frame received

 private:
  bool next(json::Value* v) {
    for (;;) {
      const size_t nl = in_.find('\n');
      if (nl != std::string::npos) {
        std::string error;
        const bool parsed = json::parse(in_.substr(0, nl), v, &error);
        in_.erase(0, nl + 1);
        if (parsed) return true;
        continue;
      }
      pollfd p = {fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(kWallLimitS * 1000)) <= 0) return false;
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return false;
      in_.append(buf, static_cast<size_t>(n));
    }
  }

  FILE* out_ = nullptr;
  int fd_ = -1;
  std::string in_;
};

// Whether an ack said ok (false for no ack at all).
bool ok(const json::Value& ack) {
  const json::Value* v = ack.find("ok");
  return v && v->is_bool() && v->boolean;
}

std::string hold_until(double t) { return R"({"type":"hold","until":)" + json::number(t) + "}"; }

TEST(Hold, SimulatedTimeStopsAtTheHoldAndGoesOnWhenItMoves) {
  SimProcess sim;
  ASSERT_TRUE(sim.ok()) << "cart2d-sim did not start: run `make firmware sim`";
  json::Value ack = sim.request(hold_until(0.5));
  ASSERT_TRUE(ok(ack));
  EXPECT_EQ(ack.find("t")->number, 0.0);
  EXPECT_FALSE(ack.find("hold")->find("held")->boolean);
  ASSERT_TRUE(ok(sim.request(R"({"type":"resume"})")));

  ASSERT_TRUE(sim.wait_until([&] { return sim.held(); }));
  const double first = sim.sim_time();
  EXPECT_NEAR(first, 0.5, kInstructionS);
  // At full speed it would run ~20 simulated seconds in a wall second: held, it stays.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(sim.sim_time(), first);
  json::Value hold = *sim.stats().find("hold");
  EXPECT_EQ(hold.find("until")->number, 0.5);
  EXPECT_EQ(hold.find("waits")->number, 1.0);
  EXPECT_GE(hold.find("wait_s")->number, 0.2);

  // A later hold moves it: time goes on to there and stops again.
  ASSERT_TRUE(ok(sim.request(hold_until(0.75))));
  ASSERT_TRUE(sim.wait_until([&] { return sim.held() && sim.sim_time() > 0.6; }));
  EXPECT_NEAR(sim.sim_time(), 0.75, kInstructionS);
  EXPECT_EQ(sim.stats().find("hold")->find("waits")->number, 2.0);

  // null ends holding.
  ack = sim.request(R"({"type":"hold","until":null})");
  ASSERT_TRUE(ok(ack));
  EXPECT_TRUE(ack.find("hold")->find("until")->is_null());
  ASSERT_TRUE(sim.wait_until([&] { return sim.sim_time() > 1.5; }));
  EXPECT_FALSE(sim.held());
}

TEST(Hold, TheCameraDeliversTheFramesThatArriveBeforeTheHold) {
  SimProcess sim;
  ASSERT_TRUE(sim.ok()) << "cart2d-sim did not start: run `make firmware sim`";
  ASSERT_TRUE(ok(sim.request(R"({"type":"camera","on":true,"fps":)" + json::number(kFps) + R"(,"latency_ms":)" +
                             json::number(kLatencyS * 1000) + "}")));
  // Frame k is captured at k / 15 s and arrives 60 ms later: by 0.5 s frames 0 to 6 have arrived
  // (frame 6, captured at 0.4 s, at 0.46 s); frame 7 (0.467 s) is still on its way.
  ASSERT_TRUE(ok(sim.request(hold_until(0.5))));
  ASSERT_TRUE(ok(sim.request(R"({"type":"resume"})")));
  ASSERT_TRUE(sim.wait_until([&] { return sim.held(); }));
  EXPECT_NEAR(sim.newest_frame_t, 6 / kFps, 1e-9);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  sim.stats();  // reads what came meanwhile
  EXPECT_NEAR(sim.newest_frame_t, 6 / kFps, 1e-9);
  // Moved past its arrival, frame 7 comes.
  ASSERT_TRUE(ok(sim.request(hold_until(7 / kFps + kLatencyS + 0.001))));
  ASSERT_TRUE(sim.wait_until([&] { return sim.held() && sim.sim_time() > 0.5; }));
  EXPECT_NEAR(sim.newest_frame_t, 7 / kFps, 1e-9);
}

TEST(Hold, BadHoldsAreRefusedAndChangeNothing) {
  SimProcess sim;
  ASSERT_TRUE(sim.ok()) << "cart2d-sim did not start: run `make firmware sim`";
  ASSERT_TRUE(ok(sim.request(hold_until(0.25))));
  for (const char* bad : {R"({"type":"hold"})", R"({"type":"hold","until":-1})", R"({"type":"hold","until":"soon"})",
                          R"({"type":"hold","until":1e300})"}) {
    json::Value ack = sim.request(bad);
    ASSERT_TRUE(ack.find("error")) << bad;
    EXPECT_FALSE(ok(ack)) << bad;
    EXPECT_NE(ack.find("error")->string.find("until"), std::string::npos) << bad;
  }
  EXPECT_EQ(sim.stats().find("hold")->find("until")->number, 0.25);
}

}  // namespace
}  // namespace cart2d
