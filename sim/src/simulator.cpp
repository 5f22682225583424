#include "simulator.hpp"

#include <algorithm>  // std::min
#include <cerrno>   // errno
#include <climits>  // PATH_MAX
#include <cstdio>   // std::rename
#include <cstdlib>  // realpath
#include <cstring>  // std::strerror
#include <poll.h>   // ppoll
#include <unistd.h>  // symlink, unlink
#include <vector>

#include "log.hpp"
#include "robot_params.hpp"  // params::body

namespace cart2d {

constexpr double kSliceS = 0.001;          // simulated time between two looks at the sockets
constexpr double kEepromCheckS = 0.25;     // wall time between two EEPROM change checks
// A hold runs time on for the host's request (hold.hpp): until its answer has gone out and the
// line from the MCU has been quiet this long (a reply goes out whole), within a tick and the
// longest reply's time on the wire at most.
constexpr double kAnswerQuietS = 0.001;
constexpr double kAnswerLimitS = 0.008 + 0.0063;

uint64_t Simulator::cycles_of(double seconds) const {
  return static_cast<uint64_t>(seconds * rig_.mcu().frequency_hz() + 0.5);
}

Simulator::Simulator(const Options& opts)
    : opts_(opts), eeprom_(opts.eeprom.empty() ? EepromStore::default_path() : opts.eeprom) {
  pacer_.set_factor(opts.speed);
  paused_ = opts.start_paused;
  auto_reset_ = opts.auto_reset;
}

bool Simulator::init(std::string* error) {
  char resolved[PATH_MAX];
  firmware_path_ = realpath(opts_.firmware.c_str(), resolved) ? resolved : opts_.firmware;

  RigConfig rc;
  rc.firmware = opts_.firmware;
  rc.bootloader = opts_.bootloader;
  rc.seed = opts_.seed;
  rc.start = opts_.start;
  rc.arena_margin_m = opts_.arena_margin_m;
  rc.grid_nodes = opts_.grid_nodes;
  rc.grid_step_m = opts_.grid_step_m;
  if (!rig_.init(rc, error)) return false;
  AdapterSettings adapter;
  adapter.baud = opts_.host_baud;
  adapter.to_mcu_delay_s = opts_.usb_to_mcu_ms / 1000.0;
  adapter.to_host_delay_s = opts_.usb_to_host_ms / 1000.0;
  adapter.latency_timer_s = opts_.ftdi_latency_timer_ms / 1000.0;
  rig_.uart().set_adapter(adapter);

  if (const std::string what = footprint_overlap(opts_.start); !what.empty()) {
    *error = "--start puts the cart's footprint over " + what;
    return false;
  }
  const double r = params::body::footprint_radius_m;
  if (opts_.arena_margin_m < r)
    LOG_WARN("arena margin %.3f m is below the footprint radius %.3f m: edge nodes are unreachable", opts_.arena_margin_m, r);

  // EEPROM after the ELF: loading the ELF wrote its .eeprom section.
  if (eeprom_.load(rig_.mcu().avr())) LOG_INFO("EEPROM restored from %s", eeprom_.path().c_str());
  else LOG_INFO("no EEPROM file yet at %s: starting from the firmware's image", eeprom_.path().c_str());

  if (!control_.listen(static_cast<uint16_t>(opts_.control_port), error)) return false;
  if (!opts_.pty_link.empty()) {
    // Replace atomically: a client reopening the name never finds it missing or stale.
    const std::string tmp = opts_.pty_link + ".new";
    ::unlink(tmp.c_str());
    if (::symlink(rig_.uart().pty_path().c_str(), tmp.c_str()) != 0 || std::rename(tmp.c_str(), opts_.pty_link.c_str()) != 0) {
      *error = "--pty-link " + opts_.pty_link + ": " + std::strerror(errno);
      return false;
    }
  }
  camera_ = std::make_unique<SimCamera>(rig_.mcu().frequency_hz(), opts_.seed);
  rig_.set_step_hook([this](uint64_t end) { on_physics_step(end); });
  return true;
}

std::string Simulator::ready_line() const {
  return json::Object()
      .add("event", "ready")
      .add("pty", opts_.pty_link.empty() ? rig_.uart().pty_path() : opts_.pty_link)
      .add("pty_device", rig_.uart().pty_path())
      .add("control", "127.0.0.1:" + std::to_string(control_.port()))
      .add("firmware", firmware_path_)
      .add("eeprom", eeprom_.path())
      .str();
}

void Simulator::on_physics_step(uint64_t end_cycle) {
  // Ground truth is sampled here, on the physics grid in simulated time, so its content does not
  // depend on how fast the host runs.
  std::string line;
  const uint32_t f = rig_.mcu().frequency_hz();
  for (auto& c : control_.clients()) {
    if (c.dead || c.truth_hz <= 0.0 || c.next_truth_cycle > end_cycle) continue;
    if (line.empty()) line = truth_json();
    control_.send(c.id, line, true);
    const uint64_t period = static_cast<uint64_t>(f / c.truth_hz);
    c.next_truth_cycle += period > 0 ? period : 1;
    if (c.next_truth_cycle <= end_cycle) c.next_truth_cycle = end_cycle + period;  // fell behind: skip
  }
  camera_step(end_cycle);
}

// With --exit-with-parent, stdin is a pipe the launcher holds open: end of file (or a hang-up)
// means the launcher is gone, however it ended (PR_SET_PDEATHSIG would fire when the launching
// THREAD ends, which is not the same).
bool Simulator::parent_gone() {
  pollfd fd = {STDIN_FILENO, POLLIN, 0};
  if (poll(&fd, 1, 0) <= 0) return false;
  if (fd.revents & (POLLHUP | POLLERR | POLLNVAL)) return true;
  char byte;
  return ::read(STDIN_FILENO, &byte, 1) == 0;
}

// Runs one slice, or less if a "run" message asked to pause, a world change or a reset is due or a
// hold stands, earlier.
void Simulator::run_slice(uint64_t slice) {
  const uint64_t now = rig_.cycle();
  const uint64_t stop = std::min({pause_at_cycle_, next_change_cycle(), next_reset_cycle(), hold_stop()});
  const uint64_t left = stop > now ? stop - now : 0;
  rig_.run_cycles(left < slice ? left : slice);
  apply_due_changes();
  apply_due_resets();
  if (rig_.cycle() < pause_at_cycle_) return;
  paused_ = true;
  pause_at_cycle_ = UINT64_MAX;
  control_.broadcast(json::Object().add("type", "event").add("event", "paused").add("t", rig_.time_s()).str());
}

void Simulator::note_host_request() {
  // The firmware serves a request within a control tick (8 ms) and its longest reply takes 6.3 ms
  // on the wire; the adapter's USB delay and FTDI timer come on top before the host reads it.
  const AdapterSettings& a = rig_.uart().adapter();
  const double to_host_s = a.to_host_delay_s + a.latency_timer_s;
  const uint64_t arrives = rig_.uart().to_mcu_idle_cycle();
  hold_.host_wrote(arrives, arrives + cycles_of(kAnswerLimitS + to_host_s));
}

uint64_t Simulator::hold_stop() const {
  const AdapterSettings& a = rig_.uart().adapter();
  const uint64_t quiet = cycles_of(kAnswerQuietS + a.to_host_delay_s + a.latency_timer_s);
  const UartLink& u = rig_.uart();
  return hold_.stop_cycle(rig_.cycle(), u.mcu_frame_start_cycle(), u.mcu_line_free_cycle(), quiet);
}

bool Simulator::at_hold(double wall_s) {
  const bool held = !paused_ && rig_.mcu().alive() && rig_.cycle() >= hold_stop();
  hold_.account(held, wall_s);
  return held;
}

std::string Simulator::hold_json() const {
  return json::Object()
      .add_raw("until", hold_.until() == Hold::kNone
                            ? "null"
                            : json::number(static_cast<double>(hold_.until()) / rig_.mcu().frequency_hz()))
      .add("held", hold_.waiting())
      .add("waits", static_cast<unsigned long long>(hold_.waits()))
      .add("wait_s", hold_.waited_s(wall_now_s()))
      .str();
}

void Simulator::publish_events() {
  for (const auto& e : rig_.contacts().take_events()) {
    json::Object event;
    event.add("type", "event").add("event", e.kind).add("t", e.t_s).add("x", e.x_m).add("y", e.y_m);
    if (!e.id.empty()) event.add("id", e.id);
    control_.broadcast(event.str());
  }
  for (const Rig::ResetEvent& r : rig_.take_reset_events()) {
    control_.broadcast(json::Object()
                           .add("type", "event")
                           .add("event", "mcu_reset")
                           .add("cause", reset_cause_name(r.cause))
                           .add("t", r.t_s)
                           .str());
  }
  uint64_t hang_cycle = 0;
  if (rig_.mcu().take_hang_began(&hang_cycle)) {
    control_.broadcast(json::Object()
                           .add("type", "event")
                           .add("event", "hang")
                           .add("t", static_cast<double>(hang_cycle) / rig_.mcu().frequency_hz())
                           .str());
  }
  if (!rig_.mcu().alive() && !mcu_dead_reported_) {
    mcu_dead_reported_ = true;
    LOG_WARN("the MCU stopped (%s) at t = %.6f s; send {\"type\":\"reset\"} to restart it", rig_.mcu().state_name(),
             rig_.time_s());
    control_.broadcast(json::Object()
                           .add("type", "event")
                           .add("event", "mcu_stopped")
                           .add("t", rig_.time_s())
                           .add("state", rig_.mcu().state_name())
                           .str());
  }
}

void Simulator::serve_host_port() {
  const std::vector<PtyPort::Change> changes = rig_.uart().poll_host();
  uint64_t opens = rig_.uart().stats().host_opens;
  for (const PtyPort::Change c : changes) opens -= c == PtyPort::Change::kOpened;
  for (const PtyPort::Change c : changes) {
    const bool opened = c == PtyPort::Change::kOpened;
    LOG_INFO("host %s the serial port at t = %.6f s", opened ? "opened" : "closed", rig_.time_s());
    json::Object event;
    event.add("type", "event").add("event", opened ? "host_open" : "host_close").add("t", rig_.time_s());
    if (opened) {
      if (auto_reset_) dtr_reset();
      event.add("opens", static_cast<unsigned long long>(++opens)).add("reset", auto_reset_);
    }
    control_.broadcast(event.str());
  }
}

// A Nano's USB-serial chip drives RESET through a 100 nF capacitor from DTR, which the host
// raises when it opens the port: the MCU restarts (in Optiboot with --bootloader, which then waits
// for a programmer).
void Simulator::dtr_reset() {
  rig_.reset_mcu();
  mcu_dead_reported_ = false;
  LOG_INFO("MCU reset by DTR at t = %.6f s", rig_.time_s());
}

void Simulator::save_eeprom(const char* why) {
  std::string error;
  if (eeprom_.save(rig_.mcu().avr(), &error)) LOG_DEBUG("EEPROM saved (%s)", why);
  else LOG_WARN("EEPROM not saved: %s", error.c_str());
}

void Simulator::wait_for_io(double timeout_s) {
  std::vector<pollfd> fds;
  control_.add_poll_fds(&fds);
  // Without a host the master reports POLLHUP at once: the timeout paces the next look instead,
  // and the host opening the port wakes us through its inotify descriptor.
  if (rig_.uart().host_fd() >= 0 && rig_.uart().host_attached())
    fds.push_back({rig_.uart().host_fd(), static_cast<short>(POLLIN | (rig_.uart().host_output_pending() ? POLLOUT : 0)), 0});
  if (rig_.uart().host_change_fd() >= 0) fds.push_back({rig_.uart().host_change_fd(), POLLIN, 0});
  timespec ts;
  ts.tv_sec = static_cast<time_t>(timeout_s);
  ts.tv_nsec = static_cast<long>((timeout_s - static_cast<double>(ts.tv_sec)) * 1e9);
  ppoll(fds.data(), fds.size(), &ts, nullptr);
}

int Simulator::run(volatile std::sig_atomic_t* stop) {
  const uint64_t slice = static_cast<uint64_t>(kSliceS * rig_.mcu().frequency_hz());
  wall_start_s_ = wall_now_s();
  pacer_.anchor(rig_.time_s(), wall_start_s_);
  next_eeprom_check_s_ = wall_start_s_ + kEepromCheckS;

  unsigned iteration = 0;
  while (!quit_ && !*stop) {
    if (opts_.exit_with_parent && (++iteration & 63) == 0 && parent_gone()) {
      LOG_INFO("the launching process is gone: stopping");
      break;
    }
    serve_host_port();
    if (rig_.uart().read_host() > 0) note_host_request();
    control_.poll_input(opts_.truth_hz, [this](int client, const std::string& line) { handle_line(client, line); });
    if (quit_) break;

    // Waiting at a hold is not running: the sockets are served and the pacing starts again from
    // where it stands once the hold moves on (no sprint to catch up with the wall clock).
    const bool held = at_hold(wall_now_s());
    const bool running = !paused_ && rig_.mcu().alive() && !held;
    if (running) run_slice(slice);
    rig_.uart().write_host(rig_.cycle());
    publish_events();
    control_.flush();

    const double now = wall_now_s();
    if (now >= next_eeprom_check_s_) {
      next_eeprom_check_s_ = now + kEepromCheckS;
      if (eeprom_.changed(rig_.mcu().avr())) save_eeprom("changed");
    }
    if (!running) {
      wait_for_io(0.02);
      pacer_.anchor(rig_.time_s(), wall_now_s());
      continue;
    }
    pacer_.sample(rig_.time_s(), now);
    const double delay = pacer_.delay_s(rig_.time_s(), now);
    if (delay > 0.0) wait_for_io(delay);
  }
  control_.flush();
  save_eeprom("exit");
  const CpuMeter::Summary cpu = rig_.cpu().total();
  LOG_INFO("stopped at t = %.3f s simulated after %.3f s wall; CPU per tick mean %.2f %% max %.2f %% over %llu ticks",
           rig_.time_s(), wall_now_s() - wall_start_s_, 100.0 * cpu.mean, 100.0 * cpu.max,
           static_cast<unsigned long long>(cpu.ticks));
  return 0;
}

}  // namespace cart2d
