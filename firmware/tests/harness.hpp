// The firmware's core wired as main.cpp wires it, with a RAM EEPROM, for tests and the fuzzer.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "cart.hpp"
#include "dispatcher.hpp"
#include "packet.hpp"
#include "settings_store.hpp"

namespace harness {

// A 1 KiB EEPROM that is ready again `latency` polls after each write.
struct RamEeprom {
  static std::array<uint8_t, 1024> memory;
  static int busy_polls;
  static int latency;
  static int writes;
  static void erase() {
    memory.fill(0xFF);
    busy_polls = 0;
    writes = 0;
  }
  static bool ready() {
    if (busy_polls == 0) return true;
    --busy_polls;
    return false;
  }
  static uint8_t read(uint16_t address) { return memory.at(address); }
  static void write(uint16_t address, uint8_t value) {
    memory.at(address) = value;
    busy_polls = latency;
    ++writes;
  }
  static const core::EepromPort port;
};

// One booted MCU: settings loaded from the RAM EEPROM (defaults if blank or corrupt).
struct Firmware {
  core::Settings settings;
  core::Path path;
  core::Cart cart{settings, path};
  core::Health health;
  core::SettingsStore store{RamEeprom::port};
  core::ReplyBuffer reply;
  core::Dispatcher dispatcher{cart, settings, store, health, reply};
  core::PacketReceiver receiver;

  Firmware() { boot(); }

  void boot() {
    const core::record::Verdict verdict = store.load(settings);
    if (verdict != core::record::Verdict::kValid) settings.reset_to_defaults();
    dispatcher.set_settings_source(verdict);
  }

  // Feeds bytes as the UART would; returns every reply sent, concatenated.
  std::vector<uint8_t> send(const std::vector<uint8_t>& bytes) {
    std::vector<uint8_t> out;
    for (uint8_t b : bytes) {
      receiver.push(b);
      core::PacketView packet;
      while (receiver.poll(packet)) {
        dispatcher.handle(packet);
        out.insert(out.end(), dispatcher.reply(), dispatcher.reply() + dispatcher.reply_length());
      }
    }
    return out;
  }

  core::MotorOutput tick(const core::TickInput& in = core::TickInput()) {
    const core::MotorOutput out = cart.tick(in);
    ++health.ticks;
    dispatcher.tick();
    store.poll();
    return out;
  }
};

// Request bytes for a command with float arguments.
std::vector<uint8_t> request(uint8_t seq, uint8_t cmd, const std::vector<float>& args);

struct Reply {
  uint8_t seq = 0;
  uint8_t status = 0xFF;
  uint8_t cmd = 0;
  std::vector<float> results;
};
// Decodes the replies in `bytes` (they must all be valid packets).
std::vector<Reply> replies(const std::vector<uint8_t>& bytes);

}  // namespace harness
