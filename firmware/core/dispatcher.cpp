#include "dispatcher.hpp"

#include "flash.hpp"           // CORE_FLASH, flash_read_byte
#include "num.hpp"             // is_finite, normalize_angle
#include "protocol_table.hpp"  // proto::Command, proto::Reason

namespace core {

using namespace params::settings;  // setting ids

static const uint8_t kArgCount[proto::kCommandCount] CORE_FLASH = CART2D_ARG_COUNTS;

// The seed's GET/SET pairs (SET = GET + 1, all values or none): GET's code, how many settings,
// their ids. In flash: as a RAM table it cost 19 B of the 2 KiB.
constexpr uint8_t kGroupSize = 6;
static const uint8_t kGroups[][kGroupSize] CORE_FLASH = {
    {proto::COMMAND_KPID_GET, 4, pos_rho_kp, pos_phase_kp, speed_kp, speed_ki},
    {proto::COMMAND_TOL_GET, 1, tol_final_m, 0, 0, 0},
    {proto::COMMAND_MAX_SPEED_GET, 2, v_max_mps, w_max_radps, 0, 0},
};

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
  if (saving_ && !store_.busy()) {
    saving_ = false;
    set_settings_source(record::Verdict::kValid);
  }
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
      if (!is_moderate(request.args[i]) && reason == 0)
        reason = is_finite(request.args[i]) ? proto::REASON_OUT_OF_RANGE : proto::REASON_NOT_FINITE;
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
  reply_length_ = encode_reply(reply_.bytes, packet.seq, status, request.cmd, results.value, results.count);
  last_seq_ = packet.seq;
  last_crc_ = packet.crc;
  last_age_ticks_ = 0;
}

// The argument count is checked first, against the spec's table: ARG_COUNT, and nothing changes.
uint8_t Dispatcher::execute(const Request& r, Results& results) {
  if (r.cmd <= proto::CONTROL_INVALID_COM || r.cmd >= proto::kCommandCount) return kUnknownCommand;
  const uint8_t expected = flash_read_byte(&kArgCount[r.cmd]);
  if (expected != proto::kVariadic && r.argc != expected) return proto::REASON_ARG_COUNT;
  uint8_t reason = execute_motion(r, results);
  if (reason == kUnknownCommand) reason = execute_settings(r, results);
  if (reason == kUnknownCommand) reason = execute_system(r, results);
  return reason;
}

uint8_t Dispatcher::execute_motion(const Request& r, Results& results) {
  const float* a = r.args;
  switch (r.cmd) {
    case proto::COMMAND_RESET:
      cart_.set_pose(Pose());
      return 0;
    case proto::COMMAND_SET_POSE:
      if (fabsf(a[2]) > kMaxAngle_rad) return proto::REASON_OUT_OF_RANGE;
      cart_.set_pose(Pose{a[0], a[1], normalize_angle(a[2])});
      return 0;
    case proto::COMMAND_POSE: {
      const Pose& p = cart_.odometry().pose();
      results.add(p.x_m);
      results.add(p.y_m);
      results.add(p.theta_rad);
      return 0;
    }
    case proto::COMMAND_GOTO:
      cart_.go_to(Point{a[0], a[1]});
      return 0;
    case proto::COMMAND_WAIT_XY_ARRAY:
    case proto::COMMAND_XY_APPEND: {
      // count or index, then whole (x, y) pairs; an append carries at least one
      if (r.argc % 2 == 0 || (r.cmd == proto::COMMAND_XY_APPEND && r.argc < 3)) return proto::REASON_ARG_COUNT;
      const uint8_t n = (r.argc - 1) / 2;
      const uint8_t reason = r.cmd == proto::COMMAND_WAIT_XY_ARRAY ? cart_.begin_path(a[0], a + 1, n)
                                                                   : cart_.append_path(a[0], a + 1, n);
      if (reason == 0) pacing(results);
      return reason;
    }
    case proto::COMMAND_START:
      cart_.start();
      return 0;
    case proto::COMMAND_STOP:
      cart_.stop();
      return 0;
    case proto::COMMAND_VELOCITY:
      return cart_.drive(a[0], a[1]);
    case proto::COMMAND_RESET_ROUTINE:
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
  for (const auto& row : kGroups) {
    uint8_t group[kGroupSize];
    for (uint8_t i = 0; i < kGroupSize; ++i) group[i] = flash_read_byte(&row[i]);
    const uint8_t get_cmd = group[0], n = group[1];
    const uint8_t* ids = group + 2;
    if (r.cmd == get_cmd) {
      get_all(ids, n, results);
      return 0;
    }
    if (r.cmd == get_cmd + 1) return set_all(ids, r.args, n, results);
  }
  switch (r.cmd) {
    case proto::COMMAND_PARAM_GET: {
      if (!is_whole(r.args[0], 0, kCount - 1)) return proto::REASON_OUT_OF_RANGE;
      const uint8_t id = static_cast<uint8_t>(r.args[0]);
      results.add(id);
      results.add(settings_.get(id));
      results.add(Settings::min_value(id));
      results.add(Settings::max_value(id));
      return 0;
    }
    case proto::COMMAND_PARAM_SET: {
      if (!is_whole(r.args[0], 0, kCount - 1)) return proto::REASON_OUT_OF_RANGE;
      const uint8_t id = static_cast<uint8_t>(r.args[0]);
      results.add(id);
      return set_all(&id, r.args + 1, 1, results);
    }
    case proto::COMMAND_TELEMETRY: {
      const uint8_t id = telemetry_hz;
      const uint8_t reason = settings_.set(id, r.args[0]);
      if (reason == 0) results.add(telemetry_rate_hz(settings_.get(id)));
      return reason;
    }
    case proto::COMMAND_SAVE:
      store_.save(settings_);
      saving_ = true;  // the EEPROM becomes the settings' source once the record has landed (tick)
      return 0;
    case proto::COMMAND_LOAD:
      if (store_.load(settings_) != record::Verdict::kValid) return proto::REASON_EEPROM_INVALID;
      set_settings_source(record::Verdict::kValid);
      return 0;
    default:
      return kUnknownCommand;
  }
}

uint8_t Dispatcher::execute_system(const Request& r, Results& results) {  // none of these takes arguments
  switch (r.cmd) {
    case proto::COMMAND_VERSION:
      results.add(proto::kVersion);
      results.add(kFirmwareMajor * 10000.0f + kFirmwareMinor * 100.0f + kFirmwarePatch);
      results.add(proto::kDictionaryHash);
      results.add(kLayoutHash);
      results.add(kWindow);
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

// What a host streaming a path needs to pace itself (docs/protocol.md, Paths and the waypoint
// window): received, the current waypoint's index, and the room left in the window.
void Dispatcher::pacing(Results& results) const {
  const Path& path = cart_.path();
  const uint16_t values[] = {path.received(), path.index(), path.room()};
  for (uint16_t v : values) results.add(v);
}

void Dispatcher::status(Results& results) const {
  // Whole numbers first, converted in one loop (12 separate conversions cost ~150 B of flash).
  const uint16_t counts[] = {cart_.mode(),          cart_.flags(),          cart_.path().index(),
                             cart_.path().count(),  health_.loop_overruns,  health_.cpu_load_pct,
                             health_.cpu_max_pct,   health_.rx_errors,      settings_source_,
                             eeprom_busy()};
  for (uint16_t n : counts) results.add(n);
  results.add(health_.ticks * kTickPeriod_s);
  results.add(last_error_);
  results.add(health_.reset_cause);
  results.add(health_.boot_count);
  results.add(health_.replies_dropped);
  results.add(cart_.path().received());
}

}  // namespace core
