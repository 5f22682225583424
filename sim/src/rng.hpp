// Seeded pseudo-random numbers for fault injection. Our own generator (xoshiro256**, seeded by
// splitmix64; Blackman & Vigna, "Scrambled linear pseudorandom number generators", 2021) rather
// than <random> distributions, whose output differs between standard libraries: a seed must give
// the same trajectory everywhere. Each fault site owns a stream so that enabling one fault does
// not shift the random sequence of another.
#pragma once

#include <cmath>
#include <cstdint>

namespace cart2d {

class Rng {
 public:
  explicit Rng(uint64_t seed = 0, uint64_t stream = 0) { reseed(seed, stream); }

  void reseed(uint64_t seed, uint64_t stream) {
    uint64_t x = seed ^ (stream * 0x9E3779B97F4A7C15ull);
    for (uint64_t& s : s_) s = splitmix64(x);
  }

  uint64_t next() {
    const uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // True with probability p.
  bool chance(double p) { return p > 0.0 && uniform() < p; }
  // Uniform integer in [0, n).
  unsigned below(unsigned n) { return static_cast<unsigned>(uniform() * n); }
  // Exponentially distributed waiting time for a Poisson process of the given rate (1/s).
  double exponential(double rate) { return -std::log(1.0 - uniform()) / rate; }

 private:
  static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static uint64_t splitmix64(uint64_t& x) {
    uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  uint64_t s_[4];
};

// Stream ids, one per fault site.
enum RngStream : uint64_t {
  kStreamEncLeft = 1,
  kStreamEncRight,
  kStreamUartRx,
  kStreamUartTx,
  kStreamWheels,
  kStreamEeprom,
  kStreamUartBurst,
  kStreamUartBurstBytes,
  kStreamSram = 0x100,  // + a count of power losses: a new pattern each time
};

}  // namespace cart2d
