#include "dispatcher.hpp"

#include "num.hpp"             // is_finite, normalize_angle
#include "protocol_table.hpp"  // proto::Command, proto::Reason

namespace core {

using namespace params::settings;  // setting ids

static const uint8_t kKpidIds[] = {pos_rho_kp, pos_phase_kp, speed_kp, speed_ki};
static const uint8_t kTolIds[] = {tol_final_m};
static const uint8_t kMaxSpeedIds[] = {v_max_mps, w_max_radps};

// Coordinates beyond this are refused: squared distances would overflow a float.
constexpr float kMaxCoordinate_m = 1000.0f;

static bool coordinates_ok(const float* xy, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i)
    if (xy[i] > kMaxCoordinate_m || xy[i] < -kMaxCoordinate_m) return false;
  return true;
}

static bool is_whole(float v, float lo, float hi) {
  return v >= lo && v <= hi && v == static_cast<float>(static_cast<int16_t>(v));
}

void Dispatcher::Results::add(float v) {
  if (count < wire::kMaxResults) value[count++] = v;
}

void Dispatcher::set_settings_source(record::Verdict verdict) {
  settings_source_ = static_cast<uint8_t>(verdict);
  cart_.set_settings_defaulted(verdict != record::Verdict::kValid);
}

void Dispatcher::tick() {
  if (last_age_ticks_ < kDuplicateWindowTicks) ++last_age_ticks_;
}

bool Dispatcher::is_duplicate(const PacketView& packet) const {
  return last_age_ticks_ < kDuplicateWindowTicks && packet.seq == last_seq_ && packet.crc == last_crc_;
}

void Dispatcher::handle(const PacketView& packet) {
  if (is_duplicate(packet)) return;  // reply_ still holds the answer to it

  Request request;
  request.cmd = packet.body[0];
  request.argc = packet.body[1];
  Results results;
  uint8_t reason;
  if (packet.len != wire::kRequestHeader + 4 * request.argc) {
    reason = proto::REASON_MALFORMED;
  } else {
    reason = 0;
    for (uint8_t i = 0; i < request.argc; ++i) {
      request.args[i] = get_f32(packet.body + wire::kRequestHeader + 4 * i);
      if (!is_finite(request.args[i])) reason = proto::REASON_NOT_FINITE;
    }
    if (reason == 0) reason = execute(request, results);
  }

  uint8_t status = proto::CONTROL_OK;
  if (reason == kUnknownCommand) {
    status = proto::CONTROL_INVALID_COM;
    results.count = 0;
  } else if (reason != 0) {
    status = proto::CONTROL_ERROR;
    last_error_ = reason;
    results.count = 0;
    results.add(reason);
  }
  reply_length_ = encode_reply(reply_, packet.seq, status, request.cmd, results.value, results.count);
  last_seq_ = packet.seq;
  last_crc_ = packet.crc;
  last_age_ticks_ = 0;
}

// Every command checks its argument count first: ARG_COUNT, and nothing changes.
uint8_t Dispatcher::execute(const Request& r, Results& results) {
  if (r.cmd <= proto::CONTROL_INVALID_COM || r.cmd >= proto::kCommandCount) return kUnknownCommand;
  uint8_t reason = execute_motion(r, results);
  if (reason == kUnknownCommand) reason = execute_settings(r, results);
  if (reason == kUnknownCommand) reason = execute_system(r, results);
  return reason;
}

uint8_t Dispatcher::execute_motion(const Request& r, Results& results) {
  const float* a = r.args;
  switch (r.cmd) {
    case proto::COMMAND_RESET:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      cart_.set_pose(Pose());
      return 0;
    case proto::COMMAND_SET_POSE:
      if (r.argc != 3) return proto::REASON_ARG_COUNT;
      if (!coordinates_ok(a, 2)) return proto::REASON_OUT_OF_RANGE;
      cart_.set_pose(Pose{a[0], a[1], normalize_angle(a[2])});
      return 0;
    case proto::COMMAND_POSE: {
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      const Pose& p = cart_.odometry().pose();
      results.add(p.x_m);
      results.add(p.y_m);
      results.add(p.theta_rad);
      return 0;
    }
    case proto::COMMAND_GOTO:
      if (r.argc != 2) return proto::REASON_ARG_COUNT;
      if (!coordinates_ok(a, 2)) return proto::REASON_OUT_OF_RANGE;
      cart_.go_to(Point{a[0], a[1]});
      return 0;
    case proto::COMMAND_WAIT_XY_ARRAY:
      if (r.argc % 2 == 0) return proto::REASON_ARG_COUNT;  // count + whole (x, y) pairs
      if (!coordinates_ok(a + 1, r.argc - 1)) return proto::REASON_OUT_OF_RANGE;
      return cart_.begin_path(a[0], a + 1, (r.argc - 1) / 2);
    case proto::COMMAND_XY_APPEND: {
      if (r.argc < 3 || r.argc % 2 == 0) return proto::REASON_ARG_COUNT;
      if (!coordinates_ok(a + 1, r.argc - 1)) return proto::REASON_OUT_OF_RANGE;
      const uint8_t reason = cart_.append_path(a[0], a + 1, (r.argc - 1) / 2);
      if (reason == 0) results.add(cart_.path().received());
      return reason;
    }
    case proto::COMMAND_START:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      cart_.start();
      return 0;
    case proto::COMMAND_STOP:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      cart_.stop();
      return 0;
    case proto::COMMAND_VELOCITY:
      if (r.argc != 2) return proto::REASON_ARG_COUNT;
      return cart_.drive(a[0], a[1]);
    case proto::COMMAND_RESET_ROUTINE:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      cart_.start_reset_routine();
      return 0;
    default:
      return kUnknownCommand;
  }
}

uint8_t Dispatcher::set_all(const uint8_t* ids, const float* values, uint8_t n, Results& results) {
  for (uint8_t i = 0; i < n; ++i)
    if (!Settings::acceptable(ids[i], values[i])) return proto::REASON_OUT_OF_RANGE;
  for (uint8_t i = 0; i < n; ++i) settings_.set(ids[i], values[i]);
  get_all(ids, n, results);
  return 0;
}

void Dispatcher::get_all(const uint8_t* ids, uint8_t n, Results& results) const {
  for (uint8_t i = 0; i < n; ++i) results.add(settings_.get(ids[i]));
}

uint8_t Dispatcher::execute_settings(const Request& r, Results& results) {
  struct Group {
    uint8_t get_cmd;
    const uint8_t* ids;
    uint8_t n;
  };
  static const Group kGroups[] = {{proto::COMMAND_KPID_GET, kKpidIds, 4},
                                  {proto::COMMAND_TOL_GET, kTolIds, 1},
                                  {proto::COMMAND_MAX_SPEED_GET, kMaxSpeedIds, 2}};
  // The seed's GET/SET pairs: SET = GET + 1, all values or none.
  for (const Group& g : kGroups) {
    if (r.cmd == g.get_cmd) {
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      get_all(g.ids, g.n, results);
      return 0;
    }
    if (r.cmd == g.get_cmd + 1) {
      if (r.argc != g.n) return proto::REASON_ARG_COUNT;
      return set_all(g.ids, r.args, g.n, results);
    }
  }
  switch (r.cmd) {
    case proto::COMMAND_PARAM_GET: {
      if (r.argc != 1) return proto::REASON_ARG_COUNT;
      if (!is_whole(r.args[0], 0, kCount - 1)) return proto::REASON_OUT_OF_RANGE;
      const uint8_t id = static_cast<uint8_t>(r.args[0]);
      results.add(id);
      results.add(settings_.get(id));
      results.add(Settings::min_value(id));
      results.add(Settings::max_value(id));
      return 0;
    }
    case proto::COMMAND_PARAM_SET: {
      if (r.argc != 2) return proto::REASON_ARG_COUNT;
      if (!is_whole(r.args[0], 0, kCount - 1)) return proto::REASON_OUT_OF_RANGE;
      const uint8_t id = static_cast<uint8_t>(r.args[0]);
      results.add(id);
      return set_all(&id, r.args + 1, 1, results);
    }
    case proto::COMMAND_TELEMETRY: {
      if (r.argc != 1) return proto::REASON_ARG_COUNT;
      const uint8_t id = telemetry_hz;
      const uint8_t reason = settings_.set(id, r.args[0]);
      if (reason == 0) results.add(telemetry_rate_hz(settings_.get(id)));
      return reason;
    }
    case proto::COMMAND_SAVE:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      store_.save(settings_);
      return 0;
    case proto::COMMAND_LOAD:
      if (r.argc != 0) return proto::REASON_ARG_COUNT;
      if (store_.load(settings_) != record::Verdict::kValid) return proto::REASON_EEPROM_INVALID;
      set_settings_source(record::Verdict::kValid);
      return 0;
    default:
      return kUnknownCommand;
  }
}

uint8_t Dispatcher::execute_system(const Request& r, Results& results) {
  if (r.argc != 0) return proto::REASON_ARG_COUNT;  // none of these takes arguments
  switch (r.cmd) {
    case proto::COMMAND_VERSION:
      results.add(proto::kVersion);
      results.add(kFirmwareMajor * 10000.0f + kFirmwareMinor * 100.0f + kFirmwarePatch);
      results.add(proto::kDictionaryHash);
      results.add(kLayoutHash);
      results.add(kWaypointCapacity);
      results.add(kCount);
      return 0;
    case proto::COMMAND_STATUS:
      status(results);
      return 0;
    case proto::COMMAND_HEARTBEAT:
      results.add(health_.ticks * kTickPeriod_s);
      return 0;
    case proto::COMMAND_REBOOT:
      reboot_requested_ = true;
      return 0;
    default:
      return kUnknownCommand;
  }
}

void Dispatcher::status(Results& results) const {
  results.add(cart_.mode());
  results.add(cart_.flags());
  results.add(cart_.path().index());
  results.add(cart_.path().count());
  results.add(health_.loop_overruns);
  results.add(health_.cpu_load_pct);
  results.add(health_.cpu_max_pct);
  results.add(health_.rx_errors);
  results.add(settings_source_);
  results.add(store_.busy() ? 1.0f : 0.0f);
  results.add(health_.ticks * kTickPeriod_s);
  results.add(last_error_);
}

}  // namespace core
