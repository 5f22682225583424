// Where simulated time waits for a consumer of the simulator's output (the side channel's "hold",
// sim/README.md "Lockstep"), and the one thing that still runs it on: the host's requests. A
// host that writes to the held MCU is answered as on a live line, so the host's own wall-clock
// time-outs never fire at a frozen firmware: time runs on from the request's arrival until the
// MCU has sent something after it and gone quiet, or for at most a cap. Also counts the wall
// time spent waiting. Cycles throughout; no simavr in here.
#pragma once

#include <cstdint>

namespace cart2d {

class Hold {
 public:
  static constexpr uint64_t kNone = UINT64_MAX;

  void set(uint64_t cycle) { until_ = cycle; }
  void clear() { until_ = kNone; }
  uint64_t until() const { return until_; }

  // The host's bytes reach the MCU by `arrives`: time may run on past the hold until the MCU
  // has answered, or until `limit`.
  void host_wrote(uint64_t arrives, uint64_t limit);
  // The cycle time may run to from `now`, given the MCU's transmitter: its last frame started at
  // `mcu_frame_start` and ended at `mcu_line_free`; an answer is out once the line has been
  // quiet for `quiet` cycles after a frame that started after the request arrived.
  uint64_t stop_cycle(uint64_t now, uint64_t mcu_frame_start, uint64_t mcu_line_free, uint64_t quiet) const;

  // Wall-time accounting, once per loop: whether time waits at the hold now.
  void account(bool waiting, double wall_s);
  bool waiting() const { return waiting_since_s_ >= 0.0; }
  uint64_t waits() const { return waits_; }
  double waited_s(double wall_s) const { return waited_s_ + (waiting() ? wall_s - waiting_since_s_ : 0.0); }

 private:
  uint64_t until_ = kNone;
  uint64_t answer_from_ = 0;   // the host's latest request is at the MCU by then
  uint64_t answer_limit_ = 0;  // and may run time on until then at most
  double waiting_since_s_ = -1.0;
  double waited_s_ = 0.0;
  uint64_t waits_ = 0;
};

}  // namespace cart2d
