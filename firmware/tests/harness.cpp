#include "harness.hpp"

#include <stdexcept>

namespace harness {

std::array<uint8_t, 1024> RamEeprom::memory = [] {
  std::array<uint8_t, 1024> m;
  m.fill(0xFF);
  return m;
}();
int RamEeprom::busy_polls = 0;
int RamEeprom::latency = 0;
int RamEeprom::writes = 0;
const core::EepromPort RamEeprom::port = {RamEeprom::ready, RamEeprom::read, RamEeprom::write};

std::vector<uint8_t> request(uint8_t seq, uint8_t cmd, const std::vector<float>& args) {
  std::vector<uint8_t> body = {cmd, static_cast<uint8_t>(args.size())};
  for (float a : args) {
    uint8_t b[4];
    core::put_f32(b, a);
    body.insert(body.end(), b, b + 4);
  }
  std::vector<uint8_t> out(body.size() + core::wire::kOverhead);
  out.resize(core::encode_packet(out.data(), seq, body.data(), static_cast<uint8_t>(body.size())));
  return out;
}

std::vector<Reply> replies(const std::vector<uint8_t>& bytes) {
  core::PacketReceiver rx;
  std::vector<Reply> out;
  for (uint8_t b : bytes) {
    rx.push(b);
    core::PacketView p;
    while (rx.poll(p)) {
      Reply r;
      r.seq = p.seq;
      r.status = p.body[0];
      r.cmd = p.body[1];
      for (uint8_t i = 0; i < p.body[2]; ++i) r.results.push_back(core::get_f32(p.body + 3 + 4 * i));
      if (p.len != 3 + 4 * p.body[2]) throw std::runtime_error("malformed reply");
      out.push_back(r);
    }
  }
  if (rx.holding()) throw std::runtime_error("trailing bytes in replies");
  return out;
}

}  // namespace harness
