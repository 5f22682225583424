// Settings (core/settings) and their EEPROM record (core/settings_store): defaults from
// config/robot.toml, range checks, and save/load through a fake EEPROM with write latency.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "crc16.hpp"
#include "protocol_table.hpp"
#include "settings.hpp"
#include "settings_store.hpp"

namespace {

using core::record::Verdict;
namespace id = params::settings;

// ---- A 1 KiB EEPROM whose writes take `g_latency` ready() polls to complete. ----
std::array<uint8_t, 1024> g_memory;
int g_busy_polls = 0;
int g_latency = 3;
int g_writes = 0;
int g_writes_while_busy = 0;
uint16_t g_last_address = 0;  // the byte written last, and what it held before
uint8_t g_last_old = 0;

bool fake_ready() {
  if (g_busy_polls == 0) return true;
  --g_busy_polls;
  return false;
}
uint8_t fake_read(uint16_t address) { return g_memory.at(address); }
void fake_write(uint16_t address, uint8_t value) {
  if (g_busy_polls > 0) ++g_writes_while_busy;  // a real EEPROM would lose this byte
  g_last_address = address;
  g_last_old = g_memory.at(address);
  g_memory.at(address) = value;
  g_busy_polls = g_latency;
  ++g_writes;
}
const core::EepromPort kFakePort{fake_ready, fake_read, fake_write};

class SettingsEeprom : public ::testing::Test {
 protected:
  void SetUp() override {
    g_memory.fill(0xFF);  // a blank (erased) EEPROM
    g_busy_polls = 0;
    g_latency = 3;
    g_writes = 0;
    g_writes_while_busy = 0;
  }
  void TearDown() override { EXPECT_EQ(g_writes_while_busy, 0) << "wrote while the EEPROM was busy"; }

  // Polls until the store is idle; returns the number of polls (bounded).
  static int finish(core::SettingsStore& store) {
    int polls = 0;
    while (store.busy() && polls < 100000) {
      store.poll();
      ++polls;
    }
    EXPECT_FALSE(store.busy());
    return polls;
  }
};

// Settings that differ from the defaults in every value we touch (all within range).
core::Settings custom() {
  core::Settings s;
  EXPECT_EQ(s.set(id::pos_rho_kp, 2.5f), 0);
  EXPECT_EQ(s.set(id::speed_kp, 1234.5f), 0);
  EXPECT_EQ(s.set(id::speed_ki, 4321.0f), 0);
  EXPECT_EQ(s.set(id::tol_final_m, 0.0125f), 0);
  EXPECT_EQ(s.set(id::reset_theta_rad, -1.5f), 0);
  EXPECT_EQ(s.set(id::enc_track_m, 0.3021f), 0);
  return s;
}

void expect_same_values(const core::Settings& a, const core::Settings& b) {
  for (uint8_t i = 0; i < id::kCount; ++i) EXPECT_EQ(a.get(i), b.get(i)) << "setting " << int(i);
}

std::vector<uint8_t> slot_bytes(uint8_t slot) {
  const uint16_t at = core::record::slot_address(slot);
  return std::vector<uint8_t>(g_memory.begin() + at, g_memory.begin() + at + core::record::kSize);
}

void put_slot(uint8_t slot, const std::vector<uint8_t>& bytes) {
  std::copy(bytes.begin(), bytes.end(), g_memory.begin() + core::record::slot_address(slot));
}

// The record bytes of `settings` with sequence `seq`.
std::vector<uint8_t> record_of(const core::Settings& settings, uint8_t seq) {
  const uint16_t crc = core::record::crc_of(settings, seq);
  std::vector<uint8_t> out;
  for (uint8_t i = 0; i < core::record::kSize; ++i) out.push_back(core::record::byte_at(settings, seq, crc, i));
  return out;
}

core::Settings loaded_after_reboot(Verdict expected = Verdict::kValid) {
  core::SettingsStore store(kFakePort);
  core::Settings loaded;
  EXPECT_EQ(store.load(loaded), expected);
  return loaded;
}

// ---- Defaults -------------------------------------------------------------------------------

TEST(SettingsDefaults, AFewKnownDefaultsFromRobotToml) {
  // config/robot.toml: speed_kp = 1000, speed_ki = 3000, tol_final_m = 0.005 (not the seed's
  // 0.1), v_max 0.5 m/s, w_max pi rad/s, manual_timeout_s 0.5.
  const core::Settings s;
  EXPECT_EQ(s.get(id::speed_kp), 1000.0f);
  EXPECT_EQ(s.get(id::speed_ki), 3000.0f);
  EXPECT_EQ(s.get(id::tol_final_m), 0.005f);
  EXPECT_EQ(s.get(id::v_max_mps), 0.5f);
  EXPECT_FLOAT_EQ(s.get(id::w_max_radps), 3.14159265f);
  EXPECT_EQ(s.get(id::manual_timeout_s), 0.5f);
  EXPECT_EQ(s.get(id::enc_radius_left_m), 0.021f);
  EXPECT_EQ(s.get(id::enc_track_m), 0.305f);
}

// Reads every [[setting]] block of config/robot.toml (the repository root is two levels above
// the protocol spec path the build passes in).
struct TomlSetting {
  std::map<std::string, std::string> fields;
};

std::vector<TomlSetting> read_toml_settings() {
  std::string path = PROTOCOL_SPEC;
  const std::string tail = "docs/protocol.md";
  path = path.substr(0, path.size() - tail.size()) + "config/robot.toml";
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<TomlSetting> out;
  bool in_setting = false;
  std::string line;
  while (std::getline(in, line)) {
    const std::string trimmed = line.substr(0, line.find_last_not_of(" \t\r") + 1);
    if (!trimmed.empty() && trimmed[0] == '[') {
      in_setting = trimmed == "[[setting]]";
      if (in_setting) out.emplace_back();
      continue;
    }
    const size_t eq = line.find('=');
    if (!in_setting || eq == std::string::npos) continue;
    std::string key = line.substr(0, eq);
    key = key.substr(0, key.find_last_not_of(' ') + 1);
    std::string value = line.substr(eq + 1);
    value = value.substr(value.find_first_not_of(' '));
    out.back().fields[key] = value;
  }
  return out;
}

TEST(SettingsDefaults, EveryDefaultAndRangeMatchesRobotToml) {
  const std::vector<TomlSetting> toml = read_toml_settings();
  ASSERT_EQ(toml.size(), id::kCount);
  const core::Settings s;
  for (const TomlSetting& t : toml) {
    const int i = std::atoi(t.fields.at("id").c_str());
    ASSERT_LT(i, id::kCount);
    SCOPED_TRACE(t.fields.at("name"));
    const float def = std::strtof(t.fields.at("default").c_str(), nullptr);
    EXPECT_FLOAT_EQ(s.get(static_cast<uint8_t>(i)), def);
    EXPECT_FLOAT_EQ(core::Settings::default_value(static_cast<uint8_t>(i)), def);
    EXPECT_FLOAT_EQ(core::Settings::min_value(static_cast<uint8_t>(i)), std::strtof(t.fields.at("min").c_str(), nullptr));
    EXPECT_FLOAT_EQ(core::Settings::max_value(static_cast<uint8_t>(i)), std::strtof(t.fields.at("max").c_str(), nullptr));
  }
}

TEST(SettingsDefaults, ResetToDefaultsUndoesChanges) {
  core::Settings s = custom();
  s.reset_to_defaults();
  expect_same_values(s, core::Settings());
}

// ---- set() ----------------------------------------------------------------------------------

TEST(SettingsSet, AcceptsValuesInRangeIncludingTheBounds) {
  core::Settings s;
  EXPECT_EQ(s.set(id::v_max_mps, 1.0f), 0);  // max 1.0
  EXPECT_EQ(s.get(id::v_max_mps), 1.0f);
  EXPECT_EQ(s.set(id::tol_final_m, 0.001f), 0);  // min 0.001
  EXPECT_EQ(s.get(id::tol_final_m), 0.001f);
  EXPECT_EQ(s.set(id::reset_y_m, -100.0f), 0);
  EXPECT_EQ(s.get(id::reset_y_m), -100.0f);
}

TEST(SettingsSet, RefusalLeavesTheValueAndVersion) {
  struct Case {
    uint8_t setting;
    float value;
    uint8_t reason;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const Case cases[] = {
      {id::speed_kp, -1.0f, proto::REASON_OUT_OF_RANGE},       // min 0
      {id::speed_kp, 20000.5f, proto::REASON_OUT_OF_RANGE},    // max 20000
      {id::tol_final_m, 0.0f, proto::REASON_OUT_OF_RANGE},     // min 0.001
      {id::tol_final_m, 0.6f, proto::REASON_OUT_OF_RANGE},     // max 0.5
      {id::v_max_mps, 1.01f, proto::REASON_OUT_OF_RANGE},      // max 1.0
      {id::v_max_mps, nan, proto::REASON_NOT_FINITE},
      {id::speed_ki, inf, proto::REASON_NOT_FINITE},
      {id::speed_ki, -inf, proto::REASON_NOT_FINITE},
      {id::kCount, 1.0f, proto::REASON_OUT_OF_RANGE},          // no such setting
      {255, 1.0f, proto::REASON_OUT_OF_RANGE},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(testing::Message() << "id " << int(c.setting) << " value " << c.value);
    core::Settings s;
    const uint8_t version = s.version();
    EXPECT_EQ(s.set(c.setting, c.value), c.reason);
    EXPECT_EQ(s.version(), version);
    expect_same_values(s, core::Settings());
  }
}

TEST(SettingsSet, AcceptedChangeBumpsTheVersion) {
  core::Settings s;
  const uint8_t version = s.version();
  ASSERT_EQ(s.set(id::speed_kp, 500.0f), 0);
  EXPECT_NE(s.version(), version);
}

// ---- EEPROM record --------------------------------------------------------------------------

TEST_F(SettingsEeprom, SaveThenLoadGivesTheSameValues) {
  const core::Settings saved = custom();
  core::SettingsStore store(kFakePort);
  store.save(saved);
  EXPECT_TRUE(store.busy());
  const int polls = finish(store);
  // Every byte of a blank EEPROM differs (0xFF) except by chance: at least most bytes are
  // written, each followed by g_latency busy polls.
  EXPECT_GE(g_writes, core::record::kSize / 2);
  EXPECT_GE(polls, g_writes);

  core::SettingsStore after_reboot(kFakePort);
  core::Settings loaded;
  EXPECT_EQ(after_reboot.load(loaded), Verdict::kValid);
  expect_same_values(loaded, saved);
}

TEST_F(SettingsEeprom, SaveWritesAtMostOneBytePerPoll) {
  g_latency = 0;  // always ready: only the one-byte-per-poll rule limits the pace
  const core::Settings saved = custom();
  core::SettingsStore store(kFakePort);
  store.save(saved);
  int polls = 0;
  while (store.busy()) {
    const int before = g_writes;
    store.poll();
    ++polls;
    ASSERT_LE(g_writes - before, 1);
    ASSERT_LT(polls, 1000);
  }
  EXPECT_LE(g_writes, core::record::kSize);
}

TEST_F(SettingsEeprom, BlankEepromIsReportedAsBlank) {
  core::SettingsStore store(kFakePort);
  core::Settings target = custom();
  EXPECT_EQ(store.load(target), Verdict::kBlank);
  expect_same_values(target, custom());
}

TEST_F(SettingsEeprom, AnySingleFlippedBitIsCorruptAndChangesNothing) {
  core::SettingsStore store(kFakePort);
  const core::Settings saved = custom();  // the store reads the live object: keep it alive
  store.save(saved);
  finish(store);
  const std::vector<uint8_t> good = slot_bytes(0);
  ASSERT_EQ(good, record_of(saved, 1));  // the first record: slot 0, sequence 1
  // Target values distinct from both the record and the defaults.
  core::Settings target;
  ASSERT_EQ(target.set(id::speed_kp, 777.0f), 0);
  ASSERT_EQ(target.set(id::tol_pass_m, 0.033f), 0);
  const core::Settings before = target;
  for (size_t bit = 0; bit < good.size() * 8; ++bit) {
    std::vector<uint8_t> bad = good;
    bad[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    put_slot(0, bad);
    ASSERT_EQ(store.load(target), Verdict::kCorrupt) << "bit " << bit;
    for (uint8_t i = 0; i < id::kCount; ++i) ASSERT_EQ(target.get(i), before.get(i)) << "bit " << bit;
  }
  // The unflipped record still loads (the loop above really was testing corruption).
  put_slot(0, good);
  EXPECT_EQ(store.load(target), Verdict::kValid);
  expect_same_values(target, custom());
}

TEST_F(SettingsEeprom, RecordWithAValidCrcButAnOutOfRangeValueIsCorrupt) {
  // The seed loaded whatever was there; a record whose checksum is right but whose gain is NaN
  // (or out of range) must not reach the controller.
  const float bad_values[] = {std::numeric_limits<float>::quiet_NaN(), -5.0f, 1e9f};
  for (const float bad : bad_values) {
    SCOPED_TRACE(bad);
    std::vector<uint8_t> rec = record_of(core::Settings(), 1);
    std::memcpy(&rec[core::record::kHeaderSize + 4 * id::speed_kp], &bad, 4);
    const uint16_t crc = core::crc16_mcrf4xx(rec.data(), core::record::kSize - 2);
    rec[core::record::kSize - 2] = crc & 0xFF;
    rec[core::record::kSize - 1] = crc >> 8;
    put_slot(0, rec);
    core::SettingsStore store(kFakePort);
    core::Settings target = custom();
    EXPECT_EQ(store.load(target), Verdict::kCorrupt);
    expect_same_values(target, custom());
  }
}

TEST_F(SettingsEeprom, SavesAlternateBetweenTheSlotsWithRisingSequenceNumbers) {
  core::SettingsStore store(kFakePort);
  core::Settings live = custom();
  store.save(live);
  finish(store);
  EXPECT_EQ(slot_bytes(0), record_of(live, 1));
  ASSERT_EQ(live.set(id::speed_kp, 2000.0f), 0);
  store.save(live);
  finish(store);
  EXPECT_EQ(slot_bytes(1), record_of(live, 2));
  ASSERT_EQ(live.set(id::speed_kp, 3000.0f), 0);
  store.save(live);
  finish(store);
  EXPECT_EQ(slot_bytes(0), record_of(live, 3));
  EXPECT_EQ(3000.0f, loaded_after_reboot().get(id::speed_kp));
}

// A reset may come at any moment of a save (every byte takes 3.4 ms on the chip): whatever the
// moment, the next boot finds the previous settings, or once the last byte is in the new ones;
// never defaults. The byte being programmed when the reset came is left half erased.
TEST_F(SettingsEeprom, AResetAtAnyMomentOfASaveLeavesThePreviousRecord) {
  const core::Settings previous = custom();
  core::Settings next = custom();
  ASSERT_EQ(next.set(id::enc_track_m, 0.31f), 0);
  ASSERT_EQ(next.set(id::speed_ki, 5000.0f), 0);
  int writes_in_a_save = 0;
  for (int cut = 1; writes_in_a_save == 0; ++cut) {
    SetUp();
    {
      core::SettingsStore first(kFakePort);
      first.save(previous);
      finish(first);
    }
    g_writes = 0;
    core::SettingsStore store(kFakePort);
    core::Settings booted;
    ASSERT_EQ(store.load(booted), Verdict::kValid);
    store.save(next);
    while (store.busy() && g_writes < cut) store.poll();
    if (g_writes < cut) {  // the save finished before this cut: it is the new record now
      writes_in_a_save = g_writes;
      const core::Settings after = loaded_after_reboot();
      expect_same_values(after, next);
      break;
    }
    g_memory[g_last_address] = g_last_old | 0xF0;  // reset during write number `cut`
    const core::Settings after = loaded_after_reboot();
    expect_same_values(after, previous);
    ASSERT_LT(cut, 200);
  }
  EXPECT_GT(writes_in_a_save, 10);  // the loop above really cut a save short many times
}

TEST_F(SettingsEeprom, TheNewerRecordWinsAcrossTheSequenceWrap) {
  core::Settings older = custom(), newer = custom();
  ASSERT_EQ(newer.set(id::speed_kp, 2500.0f), 0);
  put_slot(1, record_of(older, 255));
  put_slot(0, record_of(newer, 0));
  EXPECT_EQ(2500.0f, loaded_after_reboot().get(id::speed_kp));
  put_slot(0, record_of(older, 254));
  put_slot(1, record_of(newer, 255));
  EXPECT_EQ(2500.0f, loaded_after_reboot().get(id::speed_kp));
}

TEST_F(SettingsEeprom, AnOldFirmwaresRecordIsLoadedUntilTheFirstSave) {
  // Format 1: magic C2D2, layout hash, count, values, CRC at address 0.
  const core::Settings old = custom();
  std::vector<uint8_t> rec = {0xD2, 0xC2, params::settings::kLayoutHash & 0xFF, params::settings::kLayoutHash >> 8,
                              params::settings::kCount};
  const uint8_t* values = reinterpret_cast<const uint8_t*>(old.raw());
  rec.insert(rec.end(), values, values + 4 * params::settings::kCount);
  const uint16_t crc = core::crc16_mcrf4xx(rec.data(), static_cast<uint16_t>(rec.size()));
  rec.push_back(crc & 0xFF);
  rec.push_back(crc >> 8);
  ASSERT_EQ(core::record::kLegacySize, rec.size());
  std::copy(rec.begin(), rec.end(), g_memory.begin() + core::record::kLegacyAddress);
  expect_same_values(loaded_after_reboot(), old);

  core::Settings changed = old;
  ASSERT_EQ(changed.set(id::speed_kp, 900.0f), 0);
  core::SettingsStore store(kFakePort);
  core::Settings booted;
  store.load(booted);
  store.save(changed);
  finish(store);
  expect_same_values(loaded_after_reboot(), changed);
}

TEST_F(SettingsEeprom, ValueChangedMidSaveRestartsTheSave) {
  core::Settings live = custom();
  core::SettingsStore store(kFakePort);
  store.save(live);
  // Let about 30 bytes reach the EEPROM: the speed_kp bytes (record bytes 14..17) are written.
  while (g_writes < 30) store.poll();
  ASSERT_TRUE(store.busy());
  ASSERT_EQ(live.set(id::speed_kp, 2222.0f), 0);
  ASSERT_EQ(live.set(id::tol_pass_m, 0.02f), 0);
  finish(store);
  const core::Settings loaded = loaded_after_reboot();
  expect_same_values(loaded, live);
  EXPECT_EQ(loaded.get(id::speed_kp), 2222.0f);
}

TEST_F(SettingsEeprom, ValueChangedJustBeforeTheLastByteStillEndsConsistent) {
  core::Settings live = custom();
  core::SettingsStore store(kFakePort);
  store.save(live);
  while (g_writes < core::record::kSize - 1) store.poll();
  ASSERT_EQ(live.set(id::pos_rho_kp, 7.0f), 0);
  finish(store);
  expect_same_values(loaded_after_reboot(), live);
}

TEST_F(SettingsEeprom, LoadWhileASaveIsPendingReturnsTheValuesBeingSaved) {
  core::SettingsStore store(kFakePort);
  // An older record on the chip first.
  const core::Settings defaults;  // the store reads the live object: keep it alive
  store.save(defaults);
  finish(store);

  const core::Settings saving = custom();
  store.save(saving);
  // Before any byte and half-way through, LOAD must give what the EEPROM is about to hold,
  // never the half-old, half-new mixture on the chip.
  core::Settings early;
  EXPECT_EQ(store.load(early), Verdict::kValid);
  expect_same_values(early, saving);
  for (int i = 0; i < 20; ++i) store.poll();
  ASSERT_TRUE(store.busy());
  core::Settings midway;
  EXPECT_EQ(store.load(midway), Verdict::kValid);
  expect_same_values(midway, saving);
  finish(store);
}

TEST_F(SettingsEeprom, UnchangedBytesAreNotRewritten) {
  core::Settings s = custom();
  core::SettingsStore store(kFakePort);
  store.save(s);
  finish(store);
  ASSERT_GT(g_writes, 0);

  // Saving what the newest record holds writes nothing.
  g_writes = 0;
  store.save(s);
  finish(store);
  EXPECT_EQ(g_writes, 0);

  // Two changes later the slot written first gets its turn again: only the bytes of the values
  // changed since, the sequence number and the CRC are written.
  ASSERT_EQ(s.set(id::speed_ki, 4000.0f), 0);
  store.save(s);
  finish(store);
  ASSERT_EQ(s.set(id::speed_ki, 4100.0f), 0);
  g_writes = 0;
  store.save(s);
  finish(store);
  EXPECT_GT(g_writes, 0);
  EXPECT_LE(g_writes, 4 + 1 + 2);
  expect_same_values(loaded_after_reboot(), s);
}

TEST_F(SettingsEeprom, BusyLastsUntilTheLastWriteHasFinished) {
  const core::Settings s = custom();
  core::SettingsStore store(kFakePort);
  g_latency = 5;
  store.save(s);
  const std::vector<uint8_t> rec = record_of(s, 1);
  const int bytes_to_write = static_cast<int>(std::count_if(rec.begin(), rec.end(), [](uint8_t b) { return b != 0xFF; }));
  while (g_writes < bytes_to_write) store.poll();
  // The record is complete in the store's eyes, but the chip is still writing its last byte.
  EXPECT_TRUE(store.busy());
  finish(store);
  EXPECT_EQ(g_writes, bytes_to_write);
  expect_same_values(loaded_after_reboot(), s);
}

}  // namespace
