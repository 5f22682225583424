"""## Serial line: bursts through the strict UART, and the round trip through USB adapters

- **Bursts**: the host streams at 115 200 baud with no flow control into the Nano's two-byte
  receive buffer (sim/README.md, "UART model"). For each burst: what USART0 received and lost
  (data overruns), the packets the firmware counted as bad, the replies that came back and the
  replies the firmware counted as dropped. Target: nothing lost silently (every missing reply
  shows in a counter) and no reply dropped for lack of room (the firmware takes a request only
  when its reply fits). Each run: a paused simulator, the port opened (the DTR reset) and 0.2 s
  of boot, optionally a GOTO under way (the heaviest control ticks), then the whole burst
  written at once and 1 s of simulated time read 1 ms at a time.
- **Round trip** of STATUS (7 bytes out, 68 back) in simulated time, from writing the request to
  reading the whole reply, for a direct line and two kinds of USB-serial adapter (the
  simulator's `--usb-latency` and `--ftdi-latency-timer`).

`python -m bench.serial [--quick]`.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.common import Section, section_main, spread, table
from bench.firmware import F_CPU, Port, call, paused_sim
from cart2d.link.protocol import encode_request
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.spec import load_spec


@dataclass
class Burst:
    name: str
    requests: list[tuple[str, tuple[float, ...]]]
    driving: bool = False


def bursts() -> list[Burst]:
    heartbeats: list[tuple[str, tuple[float, ...]]] = [("HEARTBEAT", ())] * 100
    points = tuple(v for i in range(15) for v in (0.1 * (i + 1), 0.4 + 0.2 * (i % 2)))
    path = [("WAIT_XY_ARRAY", (15.0, *points))]
    return [
        Burst("100 HEARTBEAT, idle", heartbeats),
        Burst("100 HEARTBEAT, driving", heartbeats, driving=True),
        Burst("WAIT_XY_ARRAY, 31 args, idle", path),
        Burst("WAIT_XY_ARRAY, 31 args, driving", path, driving=True),
        Burst("10 x WAIT_XY_ARRAY, driving", path * 10, driving=True),
    ]


def run_burst(burst: Burst) -> dict[str, Any]:
    spec = load_spec()
    with tempfile.TemporaryDirectory() as tmp, paused_sim(tmp) as sim:
        port = Port(sim.pty, seed=0)  # the open resets the MCU (DTR), at t = 0 while paused
        sim.run_for(sim.boot_s() + 0.1)
        if burst.driving:
            call(sim, port, "GOTO", 1.5, 0.3)
            sim.run_for(0.3)
        before_status = call(sim, port, "STATUS")
        before = sim.control("stats")["stats"]["uart"]
        # Written while paused: the simulator reads it all at one instant and the adapter sends
        # it back to back.
        seqs = [port.send(command, *args) for command, args in burst.requests]
        data = b"".join(encode_request(0, spec.code(c), a) for c, a in burst.requests)  # for its length
        sim.run_for(0.001)
        for _ in range(1000):
            sim.run_for(0.001)
            port.poll()
        answered = sum(1 for s in set(seqs) if s in port.replies)
        after = sim.control("stats")["stats"]["uart"]
        status = call(sim, port, "STATUS")
        port.close()
    return {
        "burst": burst.name,
        "bytes": len(data),
        "line_ms": len(data) * 10 / 115200 * 1000,  # at the host's 115 200 baud
        "usart_received": after["rx_bytes"] - before["rx_bytes"],
        "overruns": after["rx_overruns"] - before["rx_overruns"],
        "frame_errors": after["rx_frame_errors"] - before["rx_frame_errors"],
        "bad_packets": int(status[7] - before_status[7]),
        "replies": f"{answered}/{len(set(seqs))}",
        "replies_dropped": int(status[14] - before_status[14]) if len(status) > 14 else "n/a",
        "cpu_max_pct": int(status[6]),
    }


ADAPTERS: dict[str, dict[str, Any]] = {
    "none (0 ms)": {},
    "CH340-like, 1 ms each way": {"usb_latency_ms": (1.0, 1.0)},
    "FT232R, 16 ms latency timer, 1 ms each way": {
        "usb_latency_ms": (1.0, 1.0),
        "ftdi_latency_timer_ms": 16.0,
    },
}


def round_trip_ms(adapter: dict[str, Any], command: str = "STATUS", tries: int = 10) -> list[float]:
    """Simulated ms from writing a request to reading its whole reply (CPU cycles from the
    stats; stepped 0.1 ms at a time, and a sleeping MCU runs on to its next event, so each
    figure may be up to one 0.25 ms physics step late)."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin", quiet=True, paused=True, **adapter)
        with Simulator(options) as sim:
            port = Port(sim.pty, seed=0)
            sim.run_for(sim.boot_s() + 0.1)
            for k in range(tries):
                sim.run_for(0.0037 * (k + 1))  # a different phase of the ticks and timers each time
                start = sim.control("stats")["stats"]["cycles"]
                seq = port.send(command)
                for _ in range(10_000):  # a second of simulated time
                    if seq in port.replies:
                        break
                    sim.run_for(0.0001)
                    port.poll()
                else:
                    raise RuntimeError(f"no reply to {command} within 1 simulated second")
                times.append((sim.control("stats")["stats"]["cycles"] - start) / F_CPU * 1000)
            port.close()
    return times


def silent_loss(row: dict[str, Any]) -> bool:
    """Replies missing with nothing counted: no overrun, no bad packet, no dropped reply."""
    answered, sent = (int(n) for n in str(row["replies"]).split("/"))
    counted = int(row["overruns"]) + int(row["bad_packets"]) + int(row["replies_dropped"])
    return answered < sent and counted == 0


def run(out: Path, quick: bool) -> Section:
    started = time.monotonic()
    chosen = bursts()[:2] if quick else bursts()
    rows = [run_burst(b) for b in chosen]
    trips = {name: round_trip_ms(adapter, tries=5 if quick else 20) for name, adapter in ADAPTERS.items()}
    ok_silent = not any(silent_loss(r) for r in rows)
    ok_dropped = all(int(r["replies_dropped"]) == 0 for r in rows)
    md = [__doc__.split("\n\n", 1)[0], ""]
    keys = [
        "burst",
        "bytes",
        "line_ms",
        "usart_received",
        "overruns",
        "frame_errors",
        "bad_packets",
        "replies",
        "replies_dropped",
        "cpu_max_pct",
    ]
    md.append(
        table(
            [
                "burst",
                "bytes",
                "on the line, ms",
                "USART received",
                "overruns",
                "framing errors",
                "rx_errors",
                "replies",
                "replies dropped",
                "CPU max %",
            ],
            [[f"{r[k]:.1f}" if isinstance(r[k], float) else r[k] for k in keys] for r in rows],
        )
    )
    md.append(
        "Requests the host sends without waiting for replies (the gateway never does: one request "
        "outstanding) wait in the firmware's 64-byte receive ring while the 144-byte transmit ring "
        "drains; what the ring cannot hold is lost and counted (STATUS rx_errors: bytes the ring "
        "lost and packets that failed their CRC), and no reply is dropped.\n"
    )
    md.append(
        table(
            ["adapter", "STATUS round trip, ms: median (range)"],
            [[name, spread(t).text(".1f")] for name, t in trips.items()],
        )
    )
    md.append(
        "The direct figure is mostly the line at 115 200 baud (0.6 ms out, 5.9 ms for the 68 bytes "
        "back); the slowest tries waited behind a telemetry frame (72 bytes, 6.3 ms) already on its "
        "way. An FTDI chip holds the reply until its latency timer runs out (16 ms by default; "
        "`setserial /dev/ttyUSB0 low_latency`, or 1 in /sys/bus/usb-serial/devices/ttyUSB0/latency_timer, "
        "makes it 1 ms)\n"
    )
    md.append(f"\n_{'quick' if quick else 'full'} mode, {time.monotonic() - started:.0f} s._\n")
    return Section(
        "serial",
        "\n".join(md),
        {"bursts": rows, "round_trip_ms": {name: spread(t).as_dict() for name, t in trips.items()}},
        targets_met=ok_silent and ok_dropped,
    )


def main() -> int:
    return section_main(run)


if __name__ == "__main__":
    raise SystemExit(main())
