// Packets on the wire (docs/protocol.md): 0x7E | LEN | SEQ | BODY | CRC-16 little-endian.
#pragma once

#include <stdint.h>

namespace core {

namespace wire {
constexpr uint8_t kSync = 0x7E;
constexpr uint8_t kMinBody = 2;
constexpr uint8_t kMaxBody = 127;
constexpr uint8_t kOverhead = 5;  // sync, LEN, SEQ, CRC (2)
constexpr uint8_t kMaxPacket = kMaxBody + kOverhead;
constexpr uint8_t kRequestHeader = 2;  // CMD, ARGC
constexpr uint8_t kReplyHeader = 3;    // STATUS, CMD, ARGC
constexpr uint8_t kMaxArgs = (kMaxBody - kRequestHeader) / 4;  // 31
constexpr uint8_t kMaxResults = 16;    // the longest reply is STATUS
constexpr uint8_t kMaxReply = kOverhead + kReplyHeader + 4 * kMaxResults;

constexpr uint8_t kTelemetrySync0 = 0xAA;
constexpr uint8_t kTelemetrySync1 = 0xBB;
constexpr uint8_t kTelemetryChannels = 16;
constexpr uint8_t kTelemetryPayload = 4 * kTelemetryChannels + 4;  // + TICK + CRC
constexpr uint8_t kTelemetrySize = 3 + kTelemetryPayload + 1;      // sync (2), size, SUM8
}  // namespace wire

struct PacketView {
  uint8_t seq;
  uint8_t len;
  const uint8_t* body;
  uint16_t crc;
};

// Finds packets in a byte stream. On a bad LEN or CRC it drops the 0x7E it started from and
// rescans the bytes it holds, so a good packet right after a truncated one is not lost.
class PacketReceiver {
 public:
  void push(uint8_t byte);
  // The next complete valid packet, if any. The view stays valid until push() or poll().
  bool poll(PacketView& out);
  // One control tick passed; `bytes_waiting`: bytes have arrived that are not pushed yet (the
  // line is not quiet). After kExpiryTicks quiet ticks a partial packet is given up (expire()):
  // then poll() may find a complete packet among the bytes it held.
  void tick(bool bytes_waiting);
  // The line went quiet in the middle of a packet: give up on it and rescan.
  void expire();
  bool holding() const { return held_ > 0; }
  // The bytes held make up a whole packet by its LEN (its CRC is checked by poll()).
  bool complete() const {
    return held_ >= 2 && buf_[1] >= wire::kMinBody && buf_[1] <= wire::kMaxBody && held_ >= buf_[1] + wire::kOverhead;
  }

  // 2 ticks = 16 ms = ~180 byte times: no packet takes that long on the wire.
  static constexpr uint8_t kExpiryTicks = 2;
  uint16_t errors() const { return errors_; }

 private:
  void release_returned();
  void drop_to_next_sync(uint8_t from);

  uint8_t buf_[wire::kMaxPacket] = {};
  uint8_t held_ = 0;      // bytes in buf_; buf_[0] is a sync byte when held_ > 0
  uint8_t returned_ = 0;  // length of the packet handed out by the last poll()
  uint8_t quiet_ticks_ = 0;  // ticks since the last byte, while holding a partial packet
  uint16_t errors_ = 0;
};

// Little-endian float32 (the AVR and x86 are both little-endian, but say it explicitly).
void put_f32(uint8_t* out, float value);
float get_f32(const uint8_t* in);

// Frames `body` as a packet into out (room for len + kOverhead); returns the packet length.
uint8_t encode_packet(uint8_t* out, uint8_t seq, const uint8_t* body, uint8_t len);
uint8_t encode_reply(uint8_t* out, uint8_t seq, uint8_t status, uint8_t cmd, const float* results,
                     uint8_t count);
// A SerialPlot-compatible telemetry frame into out[kTelemetrySize].
void encode_telemetry(uint8_t* out, const float* channels, uint16_t tick);
// Completes a frame whose channels are already in place: header, TICK, CRC and SUM8.
void finish_telemetry(uint8_t* out, uint16_t tick);

}  // namespace core
