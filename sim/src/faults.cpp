#include "faults.hpp"

namespace cart2d {

namespace {

struct Field {
  const char* name;
  double Faults::*member;
  double min, max;
  bool whole = false;  // only the whole numbers in [min, max]
};

// One row per fault: its message key, where it lives and its valid range.
const Field kFields[] = {
    {"enc_radius_scale_l", &Faults::enc_radius_scale_l, 0.5, 2.0},
    {"enc_radius_scale_r", &Faults::enc_radius_scale_r, 0.5, 2.0},
    {"enc_track_error_m", &Faults::enc_track_error_m, -0.1, 0.1},
    {"enc_slip_l", &Faults::enc_slip_l, 0.0, 0.99},
    {"enc_slip_r", &Faults::enc_slip_r, 0.0, 0.99},
    {"enc_miss_prob", &Faults::enc_miss_prob, 0.0, 1.0},
    {"enc_noise_hz", &Faults::enc_noise_hz, 0.0, 100000.0},
    {"uart_rx_drop", &Faults::uart_rx_drop, 0.0, 1.0},
    {"uart_rx_corrupt", &Faults::uart_rx_corrupt, 0.0, 1.0},
    {"uart_tx_drop", &Faults::uart_tx_drop, 0.0, 1.0},
    {"uart_tx_corrupt", &Faults::uart_tx_corrupt, 0.0, 1.0},
    {"uart_burst_hz", &Faults::uart_burst_hz, 0.0, 100.0},
    {"uart_burst_ms", &Faults::uart_burst_ms, 0.0, 10000.0},
    {"uart_burst_drop", &Faults::uart_burst_drop, 0.0, 1.0},
    {"hbridge_pulldowns", &Faults::hbridge_pulldowns, 0.0, 1.0, true},
};

}  // namespace

void BurstSchedule::reseed(uint64_t seed) {
  times_.reseed(seed, kStreamUartBurst);
  bytes_.reseed(seed, kStreamUartBurstBytes);
  bursts_.clear();
  next_from_s_ = 0.0;
}

void BurstSchedule::configure(double hz, double ms, double now_s) {
  if (hz == hz_ && ms / 1000.0 == length_s_) return;
  hz_ = hz;
  length_s_ = ms / 1000.0;
  bursts_.clear();
  next_from_s_ = now_s;
}

bool BurstSchedule::in_burst(double t_s) {
  if (hz_ <= 0.0 || length_s_ <= 0.0) return false;
  while (bursts_.empty() || bursts_.back().end_s <= t_s) {
    const double start = next_from_s_ + times_.exponential(hz_);
    next_from_s_ = start + length_s_;
    bursts_.push_back({start, next_from_s_});
    while (bursts_.size() > 1 && bursts_.front().end_s < t_s - 1.0) bursts_.pop_front();
  }
  for (const Burst& b : bursts_)
    if (t_s >= b.start_s && t_s < b.end_s) return true;
  return false;
}

bool apply_faults(const json::Value& msg, Faults* faults, std::string* error) {
  Faults next = *faults;
  if (const json::Value* clear = msg.find("clear"); clear && clear->is_bool() && clear->boolean) next = Faults();
  for (const auto& [key, value] : msg.object) {
    if (key == "type" || key == "id" || key == "clear") continue;
    const Field* field = nullptr;
    for (const Field& f : kFields)
      if (key == f.name) field = &f;
    if (!field) {
      *error = "unknown fault '" + key + "'";
      return false;
    }
    if (!value.is_number() || value.number < field->min || value.number > field->max) {
      *error = key + " must be a number in [" + json::number(field->min) + ", " + json::number(field->max) + "]";
      return false;
    }
    if (field->whole && value.number != static_cast<double>(static_cast<long long>(value.number))) {
      *error = key + " must be a whole number in [" + json::number(field->min) + ", " + json::number(field->max) + "]";
      return false;
    }
    next.*(field->member) = value.number;
  }
  *faults = next;
  return true;
}

std::string faults_json(const Faults& faults) {
  json::Object o;
  for (const Field& f : kFields) o.add(f.name, faults.*(f.member));
  return o.str();
}

}  // namespace cart2d
