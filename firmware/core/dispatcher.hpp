// Executes request packets (docs/protocol.md) on the cart and the settings, and keeps the reply
// to the last request so that a retransmission is answered without executing it twice.
#pragma once

#include <stdint.h>

#include "cart.hpp"
#include "health.hpp"
#include "packet.hpp"
#include "settings.hpp"
#include "settings_store.hpp"
#include "telemetry.hpp"

namespace core {

// The last reply, kept for retransmissions. A separate object so that on the AVR it sits in
// .bss (zero-filled) and not in the dispatcher's .data image (copied from flash).
struct ReplyBuffer {
  uint8_t bytes[wire::kMaxReply];
};

class Dispatcher {
 public:
  constexpr Dispatcher(Cart& cart, Settings& settings, SettingsStore& store, const Health& health,
                       ReplyBuffer& reply)
      : cart_(cart), settings_(settings), store_(store), health_(health), reply_(reply) {}

  // Where the settings in use came from: at boot, after a LOAD, once a SAVE has been written
  // (COMMAND_STATUS reports it, flag SETTINGS_DEFAULTED unless the EEPROM).
  void set_settings_source(record::Verdict verdict);

  // Executes `packet`; the reply is then in reply()/reply_length().
  void handle(const PacketView& packet);
  const uint8_t* reply() const { return reply_.bytes; }
  uint8_t reply_length() const { return reply_length_; }

  // One control tick: ages the memory of the last request; a SAVE whose record has been written
  // makes the EEPROM the settings' source.
  void tick();
  bool reboot_requested() const { return reboot_requested_; }

 private:
  struct Request {
    uint8_t cmd;
    uint8_t argc;
    float args[wire::kMaxArgs];
  };
  struct Results {
    float value[wire::kMaxResults];
    uint8_t count = 0;
    // Out of line: inlined at its ~40 call sites it cost 1.3 KB of the AVR's flash.
    __attribute__((noinline)) void add(float v);
  };
  static constexpr uint8_t kUnknownCommand = 0xFF;
  // 2 s: longer than a host's retransmissions may go on (1.5 s, docs/protocol.md).
  static constexpr uint8_t kDuplicateWindowTicks = 250;

  bool is_duplicate(const PacketView& packet) const;
  uint8_t execute(const Request& request, Results& results);
  uint8_t execute_motion(const Request& request, Results& results);
  uint8_t execute_settings(const Request& request, Results& results);
  uint8_t execute_system(const Request& request, Results& results);
  uint8_t set_all(const uint8_t* ids, const float* values, uint8_t n, Results& results);
  void get_all(const uint8_t* ids, uint8_t n, Results& results) const;
  void pacing(Results& results) const;
  void status(Results& results) const;

  Cart& cart_;
  Settings& settings_;
  SettingsStore& store_;
  const Health& health_;
  ReplyBuffer& reply_;
  uint8_t reply_length_ = 0;
  uint8_t last_seq_ = 0;
  uint16_t last_crc_ = 0;
  uint8_t last_age_ticks_ = kDuplicateWindowTicks;
  uint8_t settings_source_ = 0;
  uint8_t last_error_ = 0;  // reason of the last refused request
  bool reboot_requested_ = false;
  bool saving_ = false;  // a SAVE is being written
  // Busy until the tick after the record landed has made the EEPROM the settings' source: STATUS
  // never shows a SAVE done with the settings still from defaults.
  bool eeprom_busy() const { return saving_ || store_.busy(); }
};

}  // namespace core
