// The hex test vectors of docs/protocol.md, checked against the firmware's codec and dispatcher.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "crc16.hpp"
#include "harness.hpp"
#include "packet.hpp"
#include "spec_vectors.hpp"

namespace {

using spec::Vector;

// Every packet the receiver finds in `bytes`, as (seq, body).
std::vector<std::pair<uint8_t, std::vector<uint8_t>>> packets_in(const std::vector<uint8_t>& bytes) {
  core::PacketReceiver rx;
  std::vector<std::pair<uint8_t, std::vector<uint8_t>>> out;
  for (uint8_t b : bytes) {
    rx.push(b);
    core::PacketView p;
    while (rx.poll(p)) out.push_back({p.seq, std::vector<uint8_t>(p.body, p.body + p.len)});
  }
  return out;
}

void expect_same_float(float expected, float actual, const std::string& what) {
  if (std::isnan(expected))
    EXPECT_TRUE(std::isnan(actual)) << what;
  else
    EXPECT_EQ(expected, actual) << what;  // bit-exact: the bytes are the contract
}

TEST(ProtocolVectors, SpecHasVectorsOfEveryKind) {
  for (const char* kind : {"crc", "request", "reply", "telemetry", "reject", "stream", "exchange"})
    EXPECT_FALSE(spec::of_kind(kind).empty()) << kind;
}

TEST(ProtocolVectors, Crc) {
  for (const Vector& v : spec::of_kind("crc")) {
    const unsigned expected = std::stoul(v.fields.at("crc"), nullptr, 16);
    EXPECT_EQ(expected, core::crc16_mcrf4xx(v.bytes.data(), v.bytes.size())) << v.name;
  }
}

TEST(ProtocolVectors, RequestsDecodeAndEncode) {
  for (const Vector& v : spec::of_kind("request")) {
    const auto found = packets_in(v.bytes);
    ASSERT_EQ(1u, found.size()) << v.name;
    const std::vector<uint8_t>& body = found[0].second;
    const std::vector<float> args = spec::floats(v.fields.at("args"));
    EXPECT_EQ(std::stoi(v.fields.at("seq")), found[0].first) << v.name;
    EXPECT_EQ(std::stoi(v.fields.at("cmd")), body[0]) << v.name;
    ASSERT_EQ(args.size(), body[1]) << v.name;
    for (size_t i = 0; i < args.size(); ++i) expect_same_float(args[i], core::get_f32(&body[2 + 4 * i]), v.name);
    EXPECT_EQ(spec::hex(v.bytes), spec::hex(harness::request(found[0].first, body[0], args))) << v.name;
  }
}

TEST(ProtocolVectors, RepliesDecodeAndEncode) {
  for (const Vector& v : spec::of_kind("reply")) {
    const auto found = packets_in(v.bytes);
    ASSERT_EQ(1u, found.size()) << v.name;
    const std::vector<uint8_t>& body = found[0].second;
    const std::vector<float> results = spec::floats(v.fields.at("args"));
    EXPECT_EQ(std::stoi(v.fields.at("status")), body[0]) << v.name;
    EXPECT_EQ(std::stoi(v.fields.at("cmd")), body[1]) << v.name;
    ASSERT_EQ(results.size(), body[2]) << v.name;
    for (size_t i = 0; i < results.size(); ++i) expect_same_float(results[i], core::get_f32(&body[3 + 4 * i]), v.name);
    uint8_t out[core::wire::kMaxPacket];
    const uint8_t n = core::encode_reply(out, found[0].first, body[0], body[1], results.data(),
                                         static_cast<uint8_t>(results.size()));
    EXPECT_EQ(spec::hex(v.bytes), spec::hex(std::vector<uint8_t>(out, out + n))) << v.name;
  }
}

TEST(ProtocolVectors, Telemetry) {
  for (const Vector& v : spec::of_kind("telemetry")) {
    const std::vector<float> values = spec::floats(v.fields.at("values"));
    ASSERT_EQ(core::wire::kTelemetryChannels, values.size()) << v.name;
    ASSERT_EQ(core::wire::kTelemetrySize, v.bytes.size()) << v.name;
    uint8_t out[core::wire::kTelemetrySize];
    core::encode_telemetry(out, values.data(), static_cast<uint16_t>(std::stoi(v.fields.at("tick"))));
    EXPECT_EQ(spec::hex(v.bytes), spec::hex(std::vector<uint8_t>(out, out + sizeof out))) << v.name;
    // And the integrity fields a host checks: CRC over floats + tick, SUM8 over the payload.
    const uint8_t* payload = v.bytes.data() + 3;
    const uint16_t crc = payload[66] | (payload[67] << 8);
    EXPECT_EQ(core::crc16_mcrf4xx(payload, 66), crc) << v.name;
    uint8_t sum = 0;
    for (int i = 0; i < 68; ++i) sum += payload[i];
    EXPECT_EQ(sum, v.bytes.back()) << v.name;
  }
}

TEST(ProtocolVectors, RejectsYieldNoPacket) {
  for (const Vector& v : spec::of_kind("reject")) EXPECT_TRUE(packets_in(v.bytes).empty()) << v.name;
}

TEST(ProtocolVectors, StreamsResynchronise) {
  for (const Vector& v : spec::of_kind("stream")) {
    std::vector<int> seqs;
    for (const auto& p : packets_in(v.bytes)) seqs.push_back(p.first);
    EXPECT_EQ(spec::ints(v.fields.at("seqs")), seqs) << v.name;
  }
}

TEST(ProtocolVectors, ExchangesWithAFreshFirmware) {
  for (const Vector& v : spec::of_kind("exchange")) {
    harness::RamEeprom::erase();
    harness::Firmware fw;
    EXPECT_EQ(spec::hex(v.reply), spec::hex(fw.send(v.bytes))) << v.name;
  }
}

}  // namespace
