#include "quadrature.hpp"

#include <algorithm>  // std::sort
#include <cmath>      // std::floor

namespace cart2d {

QuadratureEncoder::QuadratureEncoder(long pulses_per_rev, bool b_high_on_rise_is_forward, double cycles_per_s)
    : quarters_per_rad_(4.0 * pulses_per_rev / (2.0 * 3.14159265358979323846)),
      b_leads_(b_high_on_rise_is_forward),
      cycles_per_s_(cycles_per_s) {
  levels(0, &out_a_, &out_b_);
}

void QuadratureEncoder::levels(int64_t state, bool* a, bool* b) const {
  // Gray sequence with A leading: 00, 10, 11, 01. B leading swaps the channels.
  static const bool kFirst[4] = {false, true, true, false};
  static const bool kSecond[4] = {false, false, true, true};
  const int s = static_cast<int>(((state % 4) + 4) % 4);
  *a = b_leads_ ? kSecond[s] : kFirst[s];
  *b = b_leads_ ? kFirst[s] : kSecond[s];
}

void QuadratureEncoder::emit(uint64_t cycle, std::vector<QuadratureEdge>* out) {
  bool a, b;
  levels(state_, &a, &b);
  a = (a && !suppressed_) != glitch_;
  if (a == out_a_ && b == out_b_) return;
  out_a_ = a;
  out_b_ = b;
  out->push_back({cycle, a, b});
}

void QuadratureEncoder::advance(double delta_rad, uint64_t c0, uint64_t n, const QuadratureFaults& faults, Rng& rng,
                                std::vector<QuadratureEdge>* out) {
  if (n == 0) n = 1;
  const double e0 = e_;
  const double e1 = e_ + delta_rad * quarters_per_rad_;
  e_ = e1;

  // Things that happen in this step, in time order: state crossings and noise spikes.
  struct Happening {
    uint64_t cycle;
    int kind;  // 0 = state change to `state`, 1 = spike on, 2 = spike off
    int64_t state;
  };
  std::vector<Happening> todo;
  auto at = [&](double frac) {
    const double c = frac * static_cast<double>(n);
    const uint64_t off = c <= 0.0 ? 0 : static_cast<uint64_t>(c);
    return c0 + (off >= n ? n - 1 : off);
  };
  const int64_t s0 = static_cast<int64_t>(std::floor(e0));
  const int64_t s1 = static_cast<int64_t>(std::floor(e1));
  if (s1 > s0) {
    for (int64_t k = s0 + 1; k <= s1; ++k) todo.push_back({at((k - e0) / (e1 - e0)), 0, k});
  } else if (s1 < s0) {
    for (int64_t k = s0; k > s1; --k) todo.push_back({at((e0 - k) / (e0 - e1)), 0, k - 1});
  }
  if (faults.noise_hz > 0.0) {
    const double t0 = static_cast<double>(c0) / cycles_per_s_;
    const double t1 = static_cast<double>(c0 + n) / cycles_per_s_;
    if (next_glitch_s_ < t0) next_glitch_s_ = t0 + rng.exponential(faults.noise_hz);
    while (next_glitch_s_ < t1) {
      uint64_t on = static_cast<uint64_t>(next_glitch_s_ * cycles_per_s_);
      if (on < c0) on = c0;
      // Keep the whole spike inside this step so that no state is carried over.
      const uint64_t width = faults.glitch_cycles < n ? faults.glitch_cycles : n - 1;
      if (on + width > c0 + n - 1) on = c0 + n - 1 - width;
      todo.push_back({on, 1, 0});
      todo.push_back({on + width, 2, 0});
      next_glitch_s_ += rng.exponential(faults.noise_hz);
    }
  } else {
    next_glitch_s_ = -1.0;
  }
  std::stable_sort(todo.begin(), todo.end(), [](const Happening& x, const Happening& y) { return x.cycle < y.cycle; });

  for (const Happening& h : todo) {
    if (h.kind == 0) {
      bool a_before, b_unused, a_after;
      levels(state_, &a_before, &b_unused);
      levels(h.state, &a_after, &b_unused);
      state_ = h.state;
      // Missed pulse: decided when A would rise (from either side), held until it would fall.
      if (!a_before && a_after) suppressed_ = rng.chance(faults.miss_prob);
      if (a_before && !a_after) suppressed_ = false;
    } else {
      glitch_ = h.kind == 1;
    }
    emit(h.cycle, out);
  }
}

}  // namespace cart2d
