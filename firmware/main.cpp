// cart2d Nano firmware: wires the ATmega328P drivers (board/) to the portable control core
// (core/). The loop sleeps until an interrupt; every 8 ms tick runs odometry and control; in
// between it parses request packets. Nothing here waits for the line or the EEPROM.

#include <avr/interrupt.h>  // sei

#include "board/encoders.hpp"
#include "board/eeprom.hpp"
#include "board/motors.hpp"
#include "board/switches.hpp"
#include "board/system.hpp"
#include "board/tick_timer.hpp"
#include "board/uart.hpp"
#include "core/cart.hpp"
#include "core/dispatcher.hpp"
#include "core/packet.hpp"
#include "core/retained.hpp"
#include "core/settings_store.hpp"
#include "core/telemetry.hpp"

using namespace board;

namespace {

core::Settings settings;
core::SettingsStore store(eeprom::kPort);
core::Path path;
core::Cart cart(settings, path);
core::Health health;
core::ReplyBuffer reply;
core::Dispatcher dispatcher(cart, settings, store, health, reply);
core::PacketReceiver receiver;

uint8_t telemetry_countdown = 1;  // ticks until the next frame is due (1: due at this tick)
uint8_t telemetry_late = 0;       // ticks the due frame has waited
uint16_t busy_counts_sum = 0;   // Timer2 counts spent busy in the current second
uint8_t busy_counts_max = 0;
uint8_t ticks_in_second = 0;
bool measuring_tick = false;    // a tick ran since the loop last went to sleep
// The tick being handled ran the position loop: a request that completes before the loop has
// caught up with it waits for the next tick (at most 8 ms), a light one. Handled at once, an
// XY_APPEND of a streamed path on top of the heaviest ticks took them to 31-36 % of the period
// (make bench-firmware). Requests that complete later are served at once, as ever.
bool requests_wait = false;

// The rate is looked up once per frame (it costs a division), not at every tick; with
// telemetry off it is looked up again every kTelemetryRecheckTicks.
constexpr uint8_t kTelemetryRecheckTicks = 25;
// A due frame waits at most this many ticks for a free transmitter and a light tick: a 72-byte
// reply takes 6.3 ms (under a tick) on the wire at 115200 baud.
constexpr uint8_t kTelemetryMaxLateTicks = 3;

void send_telemetry() {
  if (telemetry_countdown > 1) {
    --telemetry_countdown;
    return;
  }
  // Due. A frame goes at a tick that did not run the position loop (the two together made the
  // heaviest ticks, 31 % of the tick while turning at speed) and only with room left for the
  // longest reply behind it (telemetry is lossy by design: it never delays a reply). It waits up
  // to kTelemetryMaxLateTicks for both, then goes if it can or is skipped; the next one is due
  // that much sooner, so the rate stays the set one. (Skipped at once, a frame due while a
  // 72-byte reply was on the wire was lost: 11 % of them under 12 commands a second.)
  const bool no_room = uart::tx_free() < core::wire::kTelemetrySize + core::wire::kMaxReply;
  if ((no_room || cart.position_loop_ran()) && telemetry_late < kTelemetryMaxLateTicks) {
    ++telemetry_late;
    return;
  }
  const uint8_t late = telemetry_late;
  telemetry_late = 0;
  const uint8_t divider = core::telemetry_divider(settings.get(params::settings::telemetry_hz));
  telemetry_countdown = divider == 0 ? kTelemetryRecheckTicks : (divider > late ? divider - late : 1);
  if (divider == 0 || no_room) return;
  uint8_t frame[core::wire::kTelemetrySize];
  core::encode_cart_telemetry(cart, health.ticks, frame);
  uart::write(frame, sizeof frame);
}

void account_busy_time() {
  if (!measuring_tick) return;
  measuring_tick = false;
  const uint8_t counts = tick_timer::elapsed_counts();
  busy_counts_sum += counts;
  if (counts > busy_counts_max) busy_counts_max = counts;
  if (++ticks_in_second < params::control::tick_hz) return;
  // Shares of the second and of one tick, in percent. Float multiplies: the float routines are
  // linked anyway, integer division would add ~110 B of library code for this alone.
  constexpr float kPctPerCountSecond = 100.0f / (tick_timer::kCountsPerTick * params::control::tick_hz);
  constexpr float kPctPerCountTick = 100.0f / tick_timer::kCountsPerTick;
  health.cpu_load_pct = static_cast<uint8_t>(busy_counts_sum * kPctPerCountSecond + 0.5f);
  health.cpu_max_pct = static_cast<uint8_t>(busy_counts_max * kPctPerCountTick + 0.5f);
  busy_counts_sum = 0;
  busy_counts_max = 0;
  ticks_in_second = 0;
}

void run_tick() {
  core::TickInput in;
  encoders::take_counts(in.counts_left, in.counts_right);
  in.switch_left = switches::left_pressed();
  in.switch_right = switches::right_pressed();
  motors::apply(cart.tick(in));
  core::retain_pose(system::retained(), cart.odometry().pose());

  ++health.ticks;
  health.loop_overruns = tick_timer::overruns();
  health.rx_errors = receiver.errors() + uart::rx_overflows();
  dispatcher.tick();
  receiver.tick(uart::rx_available());
  send_telemetry();
  measuring_tick = true;
  requests_wait = cart.position_loop_ran();
}

// A request is only taken while its reply has room: a host that sends faster than the replies
// can leave (100 back-to-back HEARTBEATs) finds its requests waiting in the RX ring instead of
// its replies dropped. The receiver is polled before any new byte, so a packet that a quiet-line
// expiry uncovered (run_tick) is answered at once.
bool reply_fits() { return uart::tx_free() >= core::wire::kMaxReply; }

void serve_requests() {
  for (;;) {
    core::PacketView packet;
    if (requests_wait && receiver.complete()) return;  // the next bytes wait in the RX ring
    while (!requests_wait && reply_fits() && receiver.poll(packet)) {
      dispatcher.handle(packet);
      if (!uart::write(dispatcher.reply(), dispatcher.reply_length())) ++health.replies_dropped;
    }
    uint8_t byte;
    if (!reply_fits() || !uart::read(byte)) return;
    receiver.push(byte);
  }
}

// Bytes to parse while a reply has room. A packet left unpolled for lack of room is taken up
// when the transmit interrupts have drained the buffer (each of them wakes the loop).
bool work_pending() {
  return tick_timer::pending() ||
         (reply_fits() && uart::rx_available() && !(requests_wait && receiver.complete()));
}

}  // namespace

int main() {
  motors::init();  // first: the H-bridges must see "off" as early as possible
  encoders::init();
  switches::init();
  tick_timer::init();
  uart::init(params::control::baud);

  const core::record::Verdict verdict = store.load(settings);
  if (verdict != core::record::Verdict::kValid) settings.reset_to_defaults();
  dispatcher.set_settings_source(verdict);
  const core::BootInfo boot = core::boot(system::retained(), system::reset_flags());
  health.reset_cause = boot.reset_cause;
  health.boot_count = boot.boot_count;
  if (boot.pose_restored) cart.restore_pose(boot.pose);
  system::watchdog_start();
  sei();

  for (;;) {
    if (tick_timer::take_tick()) {
      run_tick();
      system::watchdog_feed();  // only a completed tick keeps the MCU out of reset
    }
    serve_requests();
    store.poll();
    if (dispatcher.reboot_requested() && uart::tx_done()) {
      core::mark_reboot(system::retained());
      system::reboot();
    }
    account_busy_time();
    system::sleep_unless(work_pending);
    if (!receiver.complete()) requests_wait = false;  // caught up: only a waiting request waits on
  }
}
