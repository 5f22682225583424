// The receiver's behaviour beyond the spec's vectors: quiet-line expiry, error counting,
// and that it never holds more than one packet's worth of bytes.
#include <gtest/gtest.h>

#include "harness.hpp"
#include "packet.hpp"

namespace {

std::vector<int> seqs_after(core::PacketReceiver& rx, const std::vector<uint8_t>& bytes) {
  std::vector<int> seqs;
  for (uint8_t b : bytes) {
    rx.push(b);
    core::PacketView p;
    while (rx.poll(p)) seqs.push_back(p.seq);
  }
  return seqs;
}

TEST(PacketReceiver, TruncatedPacketIsDroppedWhenTheLineGoesQuiet) {
  core::PacketReceiver rx;
  std::vector<uint8_t> goto_request = harness::request(1, 6, {0.5f, 0.5f});
  goto_request.resize(6);  // cut short
  EXPECT_TRUE(seqs_after(rx, goto_request).empty());
  EXPECT_TRUE(rx.holding());
  rx.expire();
  EXPECT_FALSE(rx.holding());
  EXPECT_EQ(1, rx.errors());
  EXPECT_EQ(std::vector<int>{2}, seqs_after(rx, harness::request(2, 5, {})));
}

TEST(PacketReceiver, ExpiryKeepsAPacketThatStartedInsideTheTruncatedOne) {
  core::PacketReceiver rx;
  std::vector<uint8_t> bytes = harness::request(1, 6, {0.5f, 0.5f});
  bytes.resize(4);
  const std::vector<uint8_t> pose = harness::request(9, 5, {});
  bytes.insert(bytes.end(), pose.begin(), pose.end() - 1);  // the good packet is not complete yet
  EXPECT_TRUE(seqs_after(rx, bytes).empty());
  rx.expire();  // drops the first start byte only
  EXPECT_EQ(std::vector<int>{9}, seqs_after(rx, {pose.back()}));
}

TEST(PacketReceiver, CountsCorruptPackets) {
  core::PacketReceiver rx;
  for (int i = 0; i < 3; ++i) {
    std::vector<uint8_t> bad = harness::request(static_cast<uint8_t>(i), 5, {});
    bad[3] ^= 0x40;  // CMD byte flipped: CRC fails
    EXPECT_TRUE(seqs_after(rx, bad).empty());
  }
  EXPECT_EQ(3, rx.errors());
}

TEST(PacketReceiver, LongNoiseNeverOverflowsAndAPacketStillGetsThrough) {
  core::PacketReceiver rx;
  std::vector<uint8_t> noise;
  for (int i = 0; i < 5000; ++i) noise.push_back(i % 7 == 0 ? 0x7E : static_cast<uint8_t>(i * 37));
  seqs_after(rx, noise);
  rx.expire();
  while (rx.holding()) rx.expire();
  EXPECT_EQ(std::vector<int>{4}, seqs_after(rx, harness::request(4, 5, {})));
}

TEST(PacketReceiver, EveryPossibleSingleByteCorruptionIsRejected) {
  // CRC-16 detects all single-byte errors: no corrupted copy of a request may be accepted.
  const std::vector<uint8_t> good = harness::request(7, 6, {0.5f, -0.25f});
  for (size_t i = 1; i < good.size(); ++i) {
    for (int flip = 1; flip < 256; ++flip) {
      std::vector<uint8_t> bad = good;
      bad[i] ^= static_cast<uint8_t>(flip);
      core::PacketReceiver rx;
      const std::vector<int> seqs = seqs_after(rx, bad);
      ASSERT_TRUE(seqs.empty()) << "byte " << i << " xor " << flip;
    }
  }
}

}  // namespace

namespace {

// Noise that opens a packet with the longest length (7E 7F), then a valid request: the receiver
// swallows the request into the bogus packet. The quiet line must uncover it within the expiry,
// and the expiry must not then eat the next request as well.
TEST(PacketReceiver, ARequestAfterLineNoiseIsFoundOnceTheLineIsQuiet) {
  core::PacketReceiver rx;
  std::vector<uint8_t> bytes = {0x7E, 0x7F};
  const std::vector<uint8_t> status = harness::request(3, 19, {});
  bytes.insert(bytes.end(), status.begin(), status.end());
  EXPECT_TRUE(seqs_after(rx, bytes).empty());
  for (uint8_t t = 0; t < core::PacketReceiver::kExpiryTicks; ++t) rx.tick(false);
  core::PacketView p;
  ASSERT_TRUE(rx.poll(p));
  EXPECT_EQ(3, p.seq);
  EXPECT_EQ(1, rx.errors());
  // The next request arrives over two ticks (it straddles a tick): one quiet tick must not
  // expire it.
  const std::vector<uint8_t> pose = harness::request(4, 5, {});
  EXPECT_TRUE(seqs_after(rx, std::vector<uint8_t>(pose.begin(), pose.begin() + 3)).empty());
  rx.tick(false);
  EXPECT_EQ(std::vector<int>{4}, seqs_after(rx, std::vector<uint8_t>(pose.begin() + 3, pose.end())));
  EXPECT_EQ(1, rx.errors());
}

TEST(PacketReceiver, BytesWaitingInTheRingKeepAPartialPacketAlive) {
  core::PacketReceiver rx;
  const std::vector<uint8_t> pose = harness::request(5, 5, {});
  seqs_after(rx, std::vector<uint8_t>(pose.begin(), pose.begin() + 2));
  for (int t = 0; t < 10; ++t) rx.tick(true);  // the main loop has not read them yet
  EXPECT_EQ(std::vector<int>{5}, seqs_after(rx, std::vector<uint8_t>(pose.begin() + 2, pose.end())));
  EXPECT_EQ(0, rx.errors());
}

}  // namespace
