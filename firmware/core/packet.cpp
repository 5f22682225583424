#include "packet.hpp"

#include <string.h>  // memcpy, memmove

#include "crc16.hpp"  // crc16_mcrf4xx

namespace core {

using namespace wire;

// On a little-endian machine (the AVR, x86, ARM) the wire bytes are the memory bytes; the
// shifts are only for a big-endian host (on the AVR they cost ~500 B of flash when inlined).
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
void put_f32(uint8_t* out, float value) { memcpy(out, &value, 4); }

float get_f32(const uint8_t* in) {
  float value;
  memcpy(&value, in, 4);
  return value;
}
#else
void put_f32(uint8_t* out, float value) {
  uint32_t bits;
  memcpy(&bits, &value, sizeof bits);
  for (uint8_t i = 0; i < 4; ++i) out[i] = static_cast<uint8_t>(bits >> (8 * i));
}

float get_f32(const uint8_t* in) {
  uint32_t bits = 0;
  for (uint8_t i = 0; i < 4; ++i) bits |= static_cast<uint32_t>(in[i]) << (8 * i);
  float value;
  memcpy(&value, &bits, sizeof value);
  return value;
}
#endif

void PacketReceiver::push(uint8_t byte) {
  release_returned();
  quiet_ticks_ = 0;
  if (held_ == 0 && byte != kSync) return;  // between packets: noise
  if (held_ == kMaxPacket) drop_to_next_sync(1);  // only if poll() was skipped
  if (held_ == 0 && byte != kSync) return;
  buf_[held_++] = byte;
}

bool PacketReceiver::poll(PacketView& out) {
  release_returned();
  while (held_ >= 2) {
    const uint8_t len = buf_[1];
    if (len < kMinBody || len > kMaxBody) {
      ++errors_;
      drop_to_next_sync(1);
      continue;
    }
    const uint8_t total = len + kOverhead;
    if (held_ < total) return false;
    const uint16_t received = buf_[total - 2] | (buf_[total - 1] << 8);
    if (received != crc16_mcrf4xx(buf_ + 1, len + 2)) {
      ++errors_;
      drop_to_next_sync(1);
      continue;
    }
    out.seq = buf_[2];
    out.len = len;
    out.body = buf_ + 3;
    out.crc = received;
    returned_ = total;
    return true;
  }
  return false;
}

void PacketReceiver::tick(bool bytes_waiting) {
  if (bytes_waiting || held_ == 0) {
    quiet_ticks_ = 0;
    return;
  }
  if (++quiet_ticks_ < kExpiryTicks) return;
  quiet_ticks_ = 0;  // the bytes after the dropped start byte get their own full wait
  expire();
}

void PacketReceiver::expire() {
  release_returned();
  if (held_ == 0) return;
  ++errors_;
  drop_to_next_sync(1);
}

void PacketReceiver::release_returned() {
  if (returned_ == 0) return;
  const uint8_t consumed = returned_;
  returned_ = 0;
  drop_to_next_sync(consumed);
}

// Discards buf_[0, from) and any non-sync bytes after it.
void PacketReceiver::drop_to_next_sync(uint8_t from) {
  uint8_t i = from;
  while (i < held_ && buf_[i] != kSync) ++i;
  held_ -= i;
  memmove(buf_, buf_ + i, held_);
}

uint8_t encode_packet(uint8_t* out, uint8_t seq, const uint8_t* body, uint8_t len) {
  out[0] = kSync;
  out[1] = len;
  out[2] = seq;
  memmove(out + 3, body, len);
  const uint16_t crc = crc16_mcrf4xx(out + 1, len + 2);
  out[3 + len] = crc & 0xFF;
  out[4 + len] = crc >> 8;
  return len + kOverhead;
}

uint8_t encode_reply(uint8_t* out, uint8_t seq, uint8_t status, uint8_t cmd, const float* results,
                     uint8_t count) {
  // Build the body in place after the 3-byte header, then frame it.
  uint8_t* body = out + 3;
  body[0] = status;
  body[1] = cmd;
  body[2] = count;
  for (uint8_t i = 0; i < count; ++i) put_f32(body + kReplyHeader + 4 * i, results[i]);
  return encode_packet(out, seq, body, kReplyHeader + 4 * count);
}

void encode_telemetry(uint8_t* out, const float* channels, uint16_t tick) {
  for (uint8_t i = 0; i < kTelemetryChannels; ++i) put_f32(out + 3 + 4 * i, channels[i]);
  finish_telemetry(out, tick);
}

void finish_telemetry(uint8_t* out, uint16_t tick) {
  out[0] = kTelemetrySync0;
  out[1] = kTelemetrySync1;
  out[2] = kTelemetryPayload;
  uint8_t* payload = out + 3;
  payload[4 * kTelemetryChannels] = tick & 0xFF;
  payload[4 * kTelemetryChannels + 1] = tick >> 8;
  const uint16_t crc = crc16_mcrf4xx(payload, 4 * kTelemetryChannels + 2);
  payload[4 * kTelemetryChannels + 2] = crc & 0xFF;
  payload[4 * kTelemetryChannels + 3] = crc >> 8;
  uint8_t sum = 0;
  for (uint8_t i = 0; i < kTelemetryPayload; ++i) sum += payload[i];
  out[3 + kTelemetryPayload] = sum;
}

}  // namespace core
