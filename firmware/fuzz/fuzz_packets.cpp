// libFuzzer target: the packet receiver + dispatcher + control tick, as on the MCU.
// Input byte 0 picks the mode: even = the rest is a raw byte stream (framing, resync);
// odd = the rest is a list of requests that get framed with valid CRCs (so that the
// dispatcher and the cart are reached with arbitrary commands and arguments), interleaved
// with control ticks fed arbitrary encoder counts and switch states.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "../tests/harness.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

void check_replies(const std::vector<uint8_t>& bytes) {
  for (const harness::Reply& r : harness::replies(bytes))
    check(r.status <= 2 && r.results.size() <= core::wire::kMaxResults);
}

void check_state(const harness::Firmware& fw, const core::MotorOutput& out) {
  const core::Pose& p = fw.cart.odometry().pose();
  check(std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::fabs(p.theta_rad) <= 3.1416f);
  check(out.pwm.left >= -1000 && out.pwm.left <= 1000 && out.pwm.right >= -1000 && out.pwm.right <= 1000);
  check(out.enabled || (out.pwm.left == 0 && out.pwm.right == 0));
  check(fw.cart.path().index() <= fw.cart.path().count());
  // The window: never ahead of the path, never more than kWindow points from the one before
  // the current waypoint.
  const core::Path& path = fw.cart.path();
  check(path.index() <= path.received() && path.received() <= path.count());
  const uint16_t base = path.index() > 0 ? path.index() - 1 : 0;
  check(path.received() <= base + core::kWindow);
  check(path.room() <= core::kWindow && path.length_ahead_m() >= 0.0f && std::isfinite(path.length_ahead_m()));
  for (uint8_t id = 0; id < core::setting::kCount; ++id)
    check(core::Settings::acceptable(id, fw.settings.get(id)));
}

class Reader {
 public:
  Reader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  float f32() {
    uint8_t b[4] = {byte(), byte(), byte(), byte()};
    return core::get_f32(b);
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

void tick(harness::Firmware& fw, Reader& in) {
  core::TickInput t;
  t.counts_left = static_cast<int8_t>(in.byte());
  t.counts_right = static_cast<int8_t>(in.byte());
  const uint8_t sw = in.byte();
  t.switch_left = sw & 1;
  t.switch_right = sw & 2;
  check_state(fw, fw.tick(t));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  harness::RamEeprom::erase();
  harness::RamEeprom::latency = 2;
  harness::Firmware fw;
  Reader in(data + 1, size - 1);
  if ((data[0] & 1) == 0) {
    std::vector<uint8_t> stream(data + 1, data + size);
    check_replies(fw.send(stream));
    check_state(fw, fw.tick());
    return 0;
  }
  uint8_t seq = 0;
  while (!in.empty()) {
    const uint8_t op = in.byte();
    if (op < 0x40) {  // a burst of control ticks
      for (uint8_t i = 0; i <= (op & 0x0F); ++i) tick(fw, in);
      continue;
    }
    const uint8_t cmd = in.byte() % (proto::kCommandCount + 2);
    const uint8_t argc = in.byte() % 32;
    std::vector<float> args;
    for (uint8_t i = 0; i < argc && !in.empty(); ++i) args.push_back(in.f32());
    if (cmd == proto::COMMAND_REBOOT) continue;  // the board resets; nothing to check here
    if (op & 0x80) ++seq;  // otherwise a retransmission of the same sequence number
    check_replies(fw.send(harness::request(seq, cmd, args)));
  }
  return 0;
}
