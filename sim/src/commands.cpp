// The side channel's control messages: one JSON object per line with a "type" and an optional
// "id", each answered by {"type":"ack","id":...,"ok":true|false[,"error":...][, results]}.
// A rejected message changes nothing.
#include <algorithm>  // std::upper_bound
#include <cmath>      // std::isfinite, std::llround

#include "log.hpp"
#include "robot_params.hpp"  // params::control
#include "simulator.hpp"

namespace cart2d {

namespace {

// A finite number member, or false.
bool number_member(const json::Value& msg, const char* key, double* out) {
  const json::Value* v = msg.find(key);
  if (!v || !v->is_number() || !std::isfinite(v->number)) return false;
  *out = v->number;
  return true;
}

// [a, b] as two finite numbers, or false.
bool pair_of(const json::Value& v, double* a, double* b) {
  if (!v.is_array() || v.array.size() != 2 || !v.array[0].is_number() || !v.array[1].is_number()) return false;
  *a = v.array[0].number;
  *b = v.array[1].number;
  return true;
}

}  // namespace

void Simulator::handle_line(int client, const std::string& line) {
  json::Value msg;
  std::string error;
  std::string extra;
  std::string id = "null";
  if (!json::parse(line, &msg, &error)) {
    error = "bad JSON: " + error;
  } else if (!msg.is_object()) {
    error = "a message must be a JSON object";
  } else {
    if (const json::Value* v = msg.find("id")) id = json::dump(*v);
    const json::Value* type = msg.find("type");
    if (!type || !type->is_string()) error = "missing \"type\"";
    else error = dispatch(client, type->string, msg, &extra);
  }
  json::Object ack;
  ack.add("type", "ack").add_raw("id", id).add("ok", error.empty());
  if (!error.empty()) ack.add("error", error);
  std::string text = ack.str();
  if (!extra.empty()) text.insert(text.size() - 1, "," + extra);
  control_.send(client, text);
  if (!error.empty()) LOG_DEBUG("control client %d: %s", client, error.c_str());
}

std::string Simulator::dispatch(int client, const std::string& type, const json::Value& msg, std::string* extra) {
  if (type == "pause") {
    paused_ = true;
    return "";
  }
  if (type == "resume") {
    paused_ = false;
    pacer_.anchor(rig_.time_s(), wall_now_s());
    return "";
  }
  if (type == "reset") return cmd_reset(msg, extra);
  if (type == "hang") {
    rig_.inject_hang();
    return "";
  }
  if (type == "quit") {
    quit_ = true;
    return "";
  }
  if (type == "place") return cmd_place(msg);
  if (type == "obstacles" || type == "world" || type == "boxes") return cmd_world_change(type, msg, extra);
  if (type == "world_get") {
    *extra = "\"world\":" + world_json();
    return "";
  }
  if (type == "faults") {
    Faults next = rig_.faults();
    std::string error;
    if (!apply_faults(msg, &next, &error)) return error;
    rig_.set_faults(next);
    *extra = "\"faults\":" + faults_json(next);
    return "";
  }
  if (type == "truth_rate") return cmd_truth_rate(client, msg);
  if (type == "truth") {
    *extra = "\"truth\":" + truth_json();
    return "";
  }
  if (type == "speed") return cmd_speed(msg);
  if (type == "camera") return cmd_camera(client, msg, extra);
  if (type == "target") return cmd_target(msg);
  if (type == "look") return cmd_look(msg);
  if (type == "markers") return cmd_markers(msg);
  if (type == "link") return cmd_link(msg, extra);
  if (type == "profile") return cmd_profile(msg, extra);
  if (type == "run") return cmd_run(msg);
  if (type == "hold") return cmd_hold(msg, extra);
  if (type == "stats") {
    *extra = "\"stats\":" + stats_json();
    if (const json::Value* r = msg.find("reset"); r && r->is_bool() && r->boolean) rig_.cpu().reset_total();
    return "";
  }
  return "unknown message type '" + type + "'";
}

// {"type":"reset","cause":"external"|"power"|"brownout"}: the reset button (or DTR); the power
// switched off for off_s, then on; the supply dipped below the brown-out level for dip_s. With
// "at":T (simulated seconds, later than now) it happens at T exactly, so a run is the same at
// any speed; the ack then carries "scheduled":true.
std::string Simulator::cmd_reset(const json::Value& msg, std::string* extra) {
  const json::Value* cause = msg.find("cause");
  if (cause && !cause->is_string()) return "cause must be \"external\", \"power\" or \"brownout\"";
  const std::string name = cause ? cause->string : "external";
  ResetCause c = ResetCause::kExternal;
  const char* duration = nullptr;
  if (name == "power") {
    c = ResetCause::kPowerOn;
    duration = "off_s";
  } else if (name == "brownout") {
    c = ResetCause::kBrownOut;
    duration = "dip_s";
  } else if (name != "external") {
    return "cause must be \"external\", \"power\" or \"brownout\"";
  }
  double off_s = 0.0;
  for (const char* key : {"off_s", "dip_s"}) {
    if (!msg.find(key)) continue;
    if (!duration || std::string(key) != duration) return std::string(key) + " does not go with cause " + name;
    if (!number_member(msg, key, &off_s) || off_s < 0.0 || off_s > 3600.0)
      return std::string(key) + " must be a number of seconds in [0, 3600]";
  }
  double at_s = -1.0;
  if (msg.find("at") && (!number_member(msg, "at", &at_s) || at_s < 0.0 || at_s > 1e9))
    return "at must be simulated seconds in [0, 1e9]";
  const uint64_t cycle = at_s < 0.0 ? 0 : static_cast<uint64_t>(std::llround(at_s * rig_.mcu().frequency_hz()));
  if (cycle > rig_.cycle()) {
    auto later = std::upper_bound(scheduled_resets_.begin(), scheduled_resets_.end(), cycle,
                                  [](uint64_t k, const ScheduledReset& r) { return k < r.cycle; });
    scheduled_resets_.insert(later, ScheduledReset{cycle, c, off_s});
    *extra = "\"scheduled\":true,\"at\":" + json::number(at_s);
    return "";
  }
  reset_now(c, off_s);
  return "";
}

void Simulator::reset_now(ResetCause cause, double off_s) {
  rig_.reset_mcu(cause, off_s);
  mcu_dead_reported_ = false;
  LOG_INFO("MCU reset (%s) at t = %.6f s", reset_cause_name(cause), rig_.time_s());
}

void Simulator::apply_due_resets() {
  while (!scheduled_resets_.empty() && scheduled_resets_.front().cycle <= rig_.cycle()) {
    const ScheduledReset r = scheduled_resets_.front();
    scheduled_resets_.erase(scheduled_resets_.begin());
    reset_now(r.cause, r.off_s);
  }
}

uint64_t Simulator::next_reset_cycle() const {
  return scheduled_resets_.empty() ? UINT64_MAX : scheduled_resets_.front().cycle;
}

// {"type":"profile","enable":true} starts counting the cycles of each instruction executed
// inside control-tick windows (as the CPU meter measures them) from zero; "enable":false stops.
// Every ack carries "profile": [[byte address, cycles], ...] for the addresses that used any.
std::string Simulator::cmd_profile(const json::Value& msg, std::string* extra) {
  const json::Value* enable = msg.find("enable");
  if (enable && !enable->is_bool()) return "enable must be true or false";
  if (enable && enable->boolean) {
    rig_.mcu().set_profile_gate(rig_.cpu().measuring_flag());
    rig_.mcu().clear_profile();
  } else if (enable) {
    rig_.mcu().set_profile_gate(nullptr);
  }
  std::string list = "[";
  const std::vector<uint64_t>& prof = rig_.mcu().profile();
  for (size_t word = 0; word < prof.size(); ++word) {
    if (!prof[word]) continue;
    if (list.size() > 1) list += ",";
    list += "[" + std::to_string(word * 2) + "," + std::to_string(prof[word]) + "]";
  }
  *extra = "\"profile\":" + list + "]";
  return "";
}

// {"type":"run","seconds":S}: resume and pause again after exactly S simulated seconds (then an
// {"type":"event","event":"paused","t":...} follows). With --paused and queued input this makes
// runs that are identical down to the cycle.
std::string Simulator::cmd_run(const json::Value& msg) {
  double seconds = 0.0;
  if (!number_member(msg, "seconds", &seconds) || seconds <= 0.0 || seconds > 1e6)
    return "run needs seconds in (0, 1e6]";
  pause_at_cycle_ = rig_.cycle() + static_cast<uint64_t>(std::llround(seconds * rig_.mcu().frequency_hz()));
  paused_ = false;
  return "";
}

// {"type":"hold","until":T}: simulated time runs on (paced as ever) up to T seconds and waits
// there, the sockets served, until a later hold moves T; "until":null ends holding. A hold at or
// before the time now stops it where it is. The host's requests are still answered (hold.hpp).
// The ack carries "t", the simulated time now, and "hold" (as in stats). A lockstep with a
// consumer of the camera's frames (sim/README.md).
std::string Simulator::cmd_hold(const json::Value& msg, std::string* extra) {
  const json::Value* until = msg.find("until");
  double t = 0.0;
  if (until && until->is_null()) {
    hold_.clear();
  } else if (number_member(msg, "until", &t) && t >= 0.0 && t <= 1e9) {
    hold_.set(static_cast<uint64_t>(std::llround(t * rig_.mcu().frequency_hz())));
  } else {
    return "hold needs until: simulated seconds in [0, 1e9], or null to stop holding";
  }
  *extra = "\"t\":" + json::number(rig_.time_s()) + ",\"hold\":" + hold_json();
  return "";
}

std::string Simulator::cmd_place(const json::Value& msg) {
  Pose p;
  if (!number_member(msg, "x", &p.x_m) || !number_member(msg, "y", &p.y_m)) return "place needs numbers x and y (m)";
  if (msg.find("theta") && !number_member(msg, "theta", &p.theta_rad)) return "theta must be a number (rad)";
  if (const std::string what = footprint_overlap(p); !what.empty()) return "the footprint would overlap " + what;
  rig_.place(p);
  return "";
}

std::string Simulator::cmd_speed(const json::Value& msg) {
  const json::Value* f = msg.find("factor");
  if (f && f->is_string() && f->string == "max") {
    pacer_.set_factor(0.0);
  } else if (f && f->is_number() && f->number > 0.0 && f->number <= 1e6) {
    pacer_.set_factor(f->number);
  } else {
    return "factor must be a positive number or \"max\"";
  }
  pacer_.anchor(rig_.time_s(), wall_now_s());
  return "";
}

// {"type":"link", "host_baud":B, "usb_latency_ms":MS or [TO_MCU, TO_HOST],
//  "ftdi_latency_timer_ms":MS (0 = off), "auto_reset":bool}: the host's end of the serial line,
// any subset, all or nothing. The ack carries "link" with the settings in force.
std::string Simulator::cmd_link(const json::Value& msg, std::string* extra) {
  AdapterSettings next = rig_.uart().adapter();
  bool auto_reset = auto_reset_;
  double v = 0.0;
  if (msg.find("host_baud")) {
    if (!number_member(msg, "host_baud", &v) || v < 300.0 || v > 4e6) return "host_baud must be in [300, 4000000]";
    next.baud = v;
  }
  if (const json::Value* lat = msg.find("usb_latency_ms")) {
    double to_mcu = 0.0, to_host = 0.0;
    if (lat->is_number()) to_mcu = to_host = lat->number;
    else if (!pair_of(*lat, &to_mcu, &to_host)) return "usb_latency_ms must be MS or [TO_MCU_MS, TO_HOST_MS]";
    if (!(to_mcu >= 0.0 && to_mcu <= 1000.0 && to_host >= 0.0 && to_host <= 1000.0))
      return "usb_latency_ms must be in [0, 1000]";
    next.to_mcu_delay_s = to_mcu / 1000.0;
    next.to_host_delay_s = to_host / 1000.0;
  }
  if (msg.find("ftdi_latency_timer_ms")) {
    if (!number_member(msg, "ftdi_latency_timer_ms", &v) || v < 0.0 || v > 255.0)
      return "ftdi_latency_timer_ms must be in [0, 255] (0 = off)";
    next.latency_timer_s = v / 1000.0;
  }
  if (const json::Value* a = msg.find("auto_reset")) {
    if (!a->is_bool()) return "auto_reset must be true or false";
    auto_reset = a->boolean;
  }
  rig_.uart().set_adapter(next);
  auto_reset_ = auto_reset;
  *extra = "\"link\":" + link_json();
  return "";
}

std::string Simulator::link_json() const {
  const AdapterSettings& a = rig_.uart().adapter();
  return json::Object()
      .add("host_baud", a.baud)
      .add_raw("usb_latency_ms", "[" + json::number(a.to_mcu_delay_s * 1000.0) + "," +
                                     json::number(a.to_host_delay_s * 1000.0) + "]")
      .add("ftdi_latency_timer_ms", a.latency_timer_s * 1000.0)
      .add("auto_reset", auto_reset_)
      .add("host_open", rig_.uart().host_attached())
      .add("mcu_baud", rig_.uart().mcu_baud())
      .str();
}

std::string Simulator::cmd_truth_rate(int client, const json::Value& msg) {
  double hz = 0.0;
  if (!number_member(msg, "hz", &hz) || hz < 0.0 || hz > 4000.0) return "hz must be a rate in [0, 4000] (0 = off)";
  ControlChannel::Client* c = control_.find(client);
  if (!c) return "client gone";
  c->truth_hz = hz;
  c->next_truth_cycle = rig_.cycle();
  return "";
}

std::string Simulator::stats_json() const {
  auto cpu_json = [](const CpuMeter::Summary& s, uint64_t period) {
    return json::Object()
        .add("ticks", static_cast<unsigned long long>(s.ticks))
        .add("mean", s.mean)
        .add("max", s.max)
        .add("max_cycles", static_cast<unsigned long long>(s.max_cycles))
        .add("overruns", static_cast<unsigned long long>(s.overruns))
        .add("period_cycles", static_cast<unsigned long long>(period))
        .str();
  };
  const uint64_t period = rig_.mcu().frequency_hz() / static_cast<uint64_t>(params::control::tick_hz);
  const UartLink::Stats u = rig_.uart().stats();
  json::Object o;
  o.add("t", rig_.time_s())
      .add("cycles", static_cast<unsigned long long>(rig_.cycle()))
      .add("physics_steps", static_cast<unsigned long long>(rig_.physics_steps()))
      .add("wall_s", wall_now_s() - wall_start_s_)
      .add("rtf", pacer_.rtf());
  if (pacer_.unlimited()) o.add("speed", "max");
  else o.add("speed", pacer_.factor());
  o.add("paused", paused_)
      .add_raw("hold", hold_json())
      .add("mcu", rig_.mcu().state_name())
      .add_raw("cpu", cpu_json(rig_.cpu().total(), period))
      .add_raw("cpu_window", cpu_json(rig_.cpu().window(), period))
      .add_raw("uart", json::Object()
                           .add("rx_bytes", static_cast<unsigned long long>(u.rx_bytes))
                           .add("rx_line_bytes", static_cast<unsigned long long>(u.rx_line_bytes))
                           .add("rx_dropped", static_cast<unsigned long long>(u.rx_dropped))
                           .add("rx_corrupted", static_cast<unsigned long long>(u.rx_corrupted))
                           .add("rx_overruns", static_cast<unsigned long long>(u.rx_overruns))
                           .add("rx_frame_errors", static_cast<unsigned long long>(u.rx_frame_errors))
                           .add("rx_parity_errors", static_cast<unsigned long long>(u.rx_parity_errors))
                           .add("tx_bytes", static_cast<unsigned long long>(u.tx_bytes))
                           .add("tx_dropped", static_cast<unsigned long long>(u.tx_dropped))
                           .add("tx_corrupted", static_cast<unsigned long long>(u.tx_corrupted))
                           .add("rx_burst_dropped", static_cast<unsigned long long>(u.rx_burst_dropped))
                           .add("tx_burst_dropped", static_cast<unsigned long long>(u.tx_burst_dropped))
                           .add("tx_frame_errors", static_cast<unsigned long long>(u.tx_frame_errors))
                           .add("tx_no_host", static_cast<unsigned long long>(u.tx_no_host))
                           .add("host_overflow", static_cast<unsigned long long>(u.host_overflow))
                           .add("host_opens", static_cast<unsigned long long>(u.host_opens))
                           .str())
      .add_raw("link", link_json())
      .add_raw("encoders", json::Object()
                               .add("edges_l", static_cast<unsigned long long>(rig_.encoder_left().edges_emitted()))
                               .add("edges_r", static_cast<unsigned long long>(rig_.encoder_right().edges_emitted()))
                               .add("a_edges_l", static_cast<unsigned long long>(rig_.encoder_left().a_edges_emitted()))
                               .add("a_edges_r", static_cast<unsigned long long>(rig_.encoder_right().a_edges_emitted()))
                               .add("states_l", static_cast<long long>(rig_.encoder_left().state_count()))
                               .add("states_r", static_cast<long long>(rig_.encoder_right().state_count()))
                               .str())
      .add("collisions", static_cast<long long>(rig_.contacts().collisions()))
      .add("wall_contacts", static_cast<long long>(rig_.contacts().wall_contacts()))
      .add("box_contacts", static_cast<long long>(rig_.contacts().box_contacts()))
      .add("obstacles", static_cast<unsigned long long>(rig_.world().obstacles().size()))
      .add("boxes", static_cast<unsigned long long>(rig_.world().count(BoxKind::kBox)))
      .add("walls", static_cast<unsigned long long>(rig_.world().count(BoxKind::kWall)))
      .add("world_version", static_cast<unsigned long long>(rig_.world().version()))
      .add("scheduled_changes", static_cast<unsigned long long>(scheduled_.size()))
      .add_raw("faults", faults_json(rig_.faults()))
      .add("eeprom", eeprom_.path())
      .add_raw("resets", resets_json())
      .add_raw("eeprom_ops", eeprom_ops_json());
  return o.str();
}

std::string Simulator::resets_json() const {
  json::Object o;
  for (int i = 0; i < kResetCauseCount; ++i) {
    const ResetCause c = static_cast<ResetCause>(i);
    o.add(reset_cause_name(c), static_cast<unsigned long long>(rig_.mcu().reset_count(c)));
  }
  return o.str();
}

std::string Simulator::eeprom_ops_json() const {
  const EepromPart::Stats& e = rig_.eeprom().stats();
  return json::Object()
      .add("busy", rig_.eeprom().busy())
      .add("writes_started", static_cast<unsigned long long>(e.writes_started))
      .add("writes_done", static_cast<unsigned long long>(e.writes_done))
      .add("writes_aborted", static_cast<unsigned long long>(e.writes_aborted))
      .add("reads", static_cast<unsigned long long>(e.reads))
      .add("reads_while_busy", static_cast<unsigned long long>(e.reads_while_busy))
      .add("strobes_ignored", static_cast<unsigned long long>(e.strobes_ignored))
      .add("address_writes_ignored", static_cast<unsigned long long>(e.address_writes_ignored))
      .str();
}

}  // namespace cart2d
