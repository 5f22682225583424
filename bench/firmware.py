"""## Firmware: flash and RAM against the budgets, CPU per control tick, the highest control rate.

- **Memory** from `avr-size` (tools/firmware_size.py and its budgets).
- **CPU per tick**, exactly, in simavr: the simulation is stepped one control tick (8 ms of
  simulated time) at a time and the simulator's `stats` after each step give the cycles of that
  tick: from the Timer2 compare match to the loop going back to sleep, with every interrupt
  that nests in it. The cart drives three routes at v_max = 0.5 m/s: the bench square (1.6 m
  straight legs, turns on the spot at the corners), a 16-gon "circle" of radius 0.6 m
  (driving and turning at once) and a 96-gon circle streamed through the waypoint window (the
  rest of its points arrive in XY_APPEND frames while it drives, as the gateway's uploader
  sends them), with the requests a gateway sends (STATUS and POSE, each 10 times a simulated
  second) written between steps at seeded random moments. Nothing depends
  on the wall clock, so a run repeats exactly; each run starts both routes from another corner
  and phase, with another seed.
- **Interrupt load**: the cycles per invocation of every interrupt handler come from the
  simulator's cycle `profile` (the vector table's jump executes once per invocation), the
  invocations from its counters (encoder A edges, UART bytes).
- **Highest control rate**: derived from the worst tick, then checked by building variants of
  the firmware at higher tick rates into a temporary directory and driving the same routes.

`python -m bench.firmware [--quick]`; `make bench-firmware` runs the quick form.
"""

from __future__ import annotations

import math
import random
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import serial

from bench.common import Section, percentile, section_main, spread, table
from cart2d.link import Link
from cart2d.link.built import default_firmware
from cart2d.link.path_stream import POINTS_PER_FRAME
from cart2d.link.protocol import (
    BITS_PER_BYTE,
    Decoder,
    Packet,
    Reply,
    Telemetry,
    decode_reply,
    encode_request,
)
from cart2d.params import robot
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.spec import load_spec, repo_file
from tools.firmware_size import CHIP_FLASH, FLASH_BUDGET, RAM_BUDGET, RAM_TOTAL, sections, usage

NAME = "firmware"
F_CPU = int(robot()["control"]["f_cpu_hz"])
TICK_HZ = int(robot()["control"]["tick_hz"])
PERIOD = F_CPU // TICK_HZ  # cycles per control tick: 128 000
TIMER2_PRESCALER = 1024  # firmware/board/tick_timer.cpp: clk/1024
# The mean budget was 15 % until paths were streamed (an XY_APPEND every few waypoints, 14.9 %)
# and telemetry stopped losing the frames that found a reply on the wire (each sent frame costs
# ~5 000 cycles with its transmit interrupts: 15.1 %). 16 % keeps a margin for the next feature
# without hiding one: anything that adds a per-tick cost shows here.
CPU_MEAN_BUDGET = 0.16
# The worst tick is the control step with a request dispatched in it: a full XY_APPEND frame
# (every point checked and stored in float), its reply and a telemetry frame written, 41 629
# cycles (32.5 %). Which tick that lands in depends on the traffic's alignment with the tick,
# which a few cycles' change anywhere shifts (a SAVE's tick check moved it from 27 % to 32.5 %).
# 35 % holds that worst case with a margin and still leaves the tick 2.8 times its peak.
CPU_MAX_BUDGET = 0.35
OPTIBOOT = 512  # the Nano's (new) bootloader at the top of the flash
ENC_STATE_M = (
    2 * math.pi * float(robot()["encoders"]["radius_m"]) / (4 * int(robot()["encoders"]["pulses_per_rev"]))
)
RESPONSE_CYCLES = 4  # ATmega328P datasheet, "Interrupt Response Time": 4 cycles to enter a handler
TICK_VECTOR = 7
VECTORS = {
    1: "INT0 (left encoder)",
    2: "INT1 (right encoder)",
    TICK_VECTOR: "TIMER2_COMPA (tick)",
    18: "USART_RX",
    19: "USART_UDRE",
}
# the background interrupts, whose load follows the wheels and the link, not the tick rate: the
# field of Step that counts each one's invocations
BACKGROUND_COUNTERS = {1: "int0", 2: "int1", 18: "rx", 19: "tx"}

SQUARE = [(1.6, 0.0), (1.6, 1.6), (0.0, 1.6), (0.0, 0.0)]


def drive_square(sim: Simulator, link: Link, poll_s: float = 0.05) -> tuple[float, float]:
    """Drives the bench square from the origin in a running simulator, polling STATUS every
    poll_s wall seconds until the firmware is idle again; returns (simulated s, wall s)."""
    sim.control("stats", reset=True)
    t0_sim = sim.truth()["t"]
    t0_wall = time.monotonic()
    link.call("WAIT_XY_ARRAY", len(SQUARE), *[c for p in SQUARE for c in p])
    while int(link.call("STATUS")[0]) != 0:
        if time.monotonic() - t0_wall > 120:
            raise RuntimeError("the square was not finished in 120 s of wall time")
        time.sleep(poll_s)
    return sim.truth()["t"] - t0_sim, time.monotonic() - t0_wall


# -- routes ------------------------------------------------------------------------------------
Pose = tuple[float, float, float]
Point = tuple[float, float]


@dataclass(frozen=True)
class Route:
    name: str
    start: Pose
    points: list[Point]


def square_route(corner: int) -> Route:
    """The 1.6 m square with corners 0.1 m inside the grid, started from corner `corner`."""
    corners = [(0.1, 0.1), (1.7, 0.1), (1.7, 1.7), (0.1, 1.7)]
    k = corner % 4
    x, y = corners[k]
    return Route("square", (x, y, k * math.pi / 2), [corners[(k + j) % 4] for j in range(1, 5)])


def circle_route(phase: int, sides: int = 16) -> Route:
    """One lap of a regular polygon of radius 0.6 m around (0.9, 0.9), counter-clockwise."""
    cx, cy, r = 0.9, 0.9, 0.6
    phi0 = phase * 2 * math.pi / 3 + 0.1
    points = [
        (cx + r * math.cos(phi0 + j * 2 * math.pi / sides), cy + r * math.sin(phi0 + j * 2 * math.pi / sides))
        for j in range(1, sides + 1)
    ]
    heading = math.atan2(math.sin(phi0 + math.pi / 2), math.cos(phi0 + math.pi / 2))
    return Route("circle", (cx + r * math.cos(phi0), cy + r * math.sin(phi0), heading), points)


STREAMED = "streamed circle"
WINDOW = int(robot()["control"]["waypoint_capacity"])
STREAM_BATCH = max(1, WINDOW // 4)  # cart2d/link/path_stream.py, PathStream: an append per quarter window


def streamed_route(phase: int) -> Route:
    """The circle as a 96-gon: three times the window's points, so most arrive while it drives."""
    circle = circle_route(phase, sides=96)
    return Route(STREAMED, circle.start, circle.points)


# -- stepping the simulation tick by tick -------------------------------------------------------
@dataclass
class Step:
    """One step of simulated time: the ticks that ended in it and what the counters saw."""

    route: str
    cycles: list[int]  # of every tick that reached sleep (or overran) in this step
    overruns: int
    int0: int  # invocations of each interrupt in this step
    int1: int
    rx: int
    tx: int
    v_left: float  # measuring wheels over the step, m/s
    v_right: float


@dataclass
class Counters:
    values: dict[str, int] = field(default_factory=dict)

    def delta(self, stats: dict[str, Any]) -> dict[str, int]:
        now = {
            "int0": int(stats["encoders"]["a_edges_l"]),
            "int1": int(stats["encoders"]["a_edges_r"]),
            "states_l": int(stats["encoders"]["states_l"]),
            "states_r": int(stats["encoders"]["states_r"]),
            "rx": int(stats["uart"]["rx_bytes"]),
            "tx": int(stats["uart"]["tx_bytes"]),
        }
        before = self.values or now
        self.values = now
        return {k: now[k] - before[k] for k in now}


def tick_cycles(cpu: dict[str, Any]) -> list[int]:
    """The cycles of the ticks in a stats report reset after the previous step (0 to 2 ticks)."""
    n = int(cpu["ticks"])
    if n == 0:
        return []
    peak = int(cpu["max_cycles"])
    total = round(float(cpu["mean"]) * int(cpu["period_cycles"]) * n)
    if n == 1:
        return [peak]
    rest = total - peak
    return [peak] + [round(rest / (n - 1))] * (n - 1)  # n > 2 never happens with 8 ms steps


class SteppedDecoder:
    """The link's Decoder for a paused simulator stepped from Python: its clock is the line time
    of the bytes read so far, not the wall clock. A reply spans many steps (an 85-byte STATUS,
    7.4 ms of line, over 74 steps of 0.1 ms), and a host that took over PARTIAL_MARGIN_S of wall
    time between two of them (a busy machine, a garbage collection) saw its partial reply expire
    and lost it."""

    def __init__(self, baudrate: int) -> None:
        self._decoder = Decoder()
        self._baudrate = baudrate
        self._line_s = 0.0

    def feed(self, data: bytes) -> list[Packet | Telemetry]:
        self._line_s += len(data) * BITS_PER_BYTE / self._baudrate
        return self._decoder.feed(data, self._line_s)


class Port:
    """The firmware's serial port, driven from the stepping loop alone: requests are written
    while the simulation is paused and everything it sent is read after each step, so a run
    is a function of its inputs and repeats exactly (no thread decides when a byte lands)."""

    def __init__(self, pty: str, seed: int) -> None:
        self._serial = serial.Serial(pty, 115200, timeout=0)
        self._serial.reset_input_buffer()
        self._decoder = SteppedDecoder(self._serial.baudrate)
        self._seq = random.Random(seed).randrange(256)
        self.replies: dict[int, Reply] = {}
        self.telemetry: Telemetry | None = None
        self.telemetry_count = 0

    def send(self, command: str, *args: float) -> int:
        self._seq = (self._seq + 1) & 0xFF
        self.replies.pop(self._seq, None)
        self._serial.write(encode_request(self._seq, load_spec().code(command), args))
        return self._seq

    def poll(self) -> None:
        while data := self._serial.read(65536):
            for item in self._decoder.feed(data):
                if isinstance(item, Telemetry):
                    self.telemetry = item
                    self.telemetry_count += 1
                else:
                    reply = decode_reply(item)
                    self.replies[reply.seq] = reply

    def close(self) -> None:
        self._serial.close()


def call(sim: Simulator, port: Port, command: str, *args: float) -> tuple[float, ...]:
    """One request, stepping the simulation 1 ms at a time until its reply is in."""
    seq = port.send(command, *args)
    for _ in range(1000):
        sim.run_for(0.001)
        port.poll()
        if seq in port.replies:
            reply = port.replies.pop(seq)
            if not reply.ok:
                raise RuntimeError(reply.describe_error())
            return reply.results
    raise RuntimeError(f"no reply to {command} within 1 simulated second")


class Traffic:
    """What the gateway sends while a mission runs (its monitor polls STATUS, the panel POSE):
    one request every every_s of simulated time on average, alternately STATUS and POSE, each
    at a seeded random moment of its slot."""

    def __init__(self, port: Port, seed: int, every_s: float = 0.05) -> None:
        self._port = port
        self._rng = random.Random(seed)
        self._every_s = every_s
        self._count = 0
        self._slot = 0
        self.next_s = 0.0

    def jitter(self) -> float:
        """A seeded random share of a step."""
        return self._rng.uniform(0, 1)

    def restart(self) -> None:
        self._slot = 0
        self.next_s = self._rng.uniform(0, self._every_s)

    def send(self) -> None:
        self._port.send(("STATUS", "POSE")[self._count % 2])
        self._count += 1
        self._slot += 1
        self.next_s = (self._slot + self._rng.uniform(0, 1)) * self._every_s


def align_to_ticks(sim: Simulator) -> None:
    """Moves on so that the next control tick's compare match comes 0.5 to 1.5 ms after now, and
    so every tick window (a few ms) lies inside one step of a whole tick period."""
    sim.control("stats", reset=True)
    for _ in range(2 * 1000 // TICK_HZ + 2):  # 1 ms at a time, two periods at most
        sim.run_for(0.001)
        cpu = sim.control("stats", reset=True)["stats"]["cpu"]
        if int(cpu["ticks"]) > 0:
            # the window ended in the last millisecond, so it began about 0.5 ms + its length
            # ago, and the next one begins a period after that: 1 ms after the wait
            length_ms = 1000 * int(cpu["max_cycles"]) / F_CPU
            wait_ms = 1000 / TICK_HZ - 0.5 - length_ms - 1.0
            sim.run_for(max(0.001, (wait_ms % (1000 / TICK_HZ)) / 1000))
            return
    raise RuntimeError("no control tick in two periods")


@dataclass
class Probe:
    """Profile one step, by its index in the samples."""

    step: int
    profile: list[list[int]] = field(default_factory=list)


def drive_stepped(
    sim: Simulator,
    port: Port,
    route: Route,
    traffic: Traffic,
    step_s: float,
    samples: list[Step] | None,
    max_sim_s: float = 90.0,
    probe: Probe | None = None,
) -> float:
    """In a paused simulation: places the cart at the route's start and uploads the route, then
    steps `step_s` at a time, with the gateway's traffic, until the firmware's telemetry says
    IDLE. With `samples`, every step's stats are appended (the CPU totals are reset after each
    step). Returns the distance of the true pose from the last waypoint."""
    x, y, theta = route.start
    sim.control("place", x=x, y=y, theta=theta)
    call(sim, port, "SET_POSE", x, y, theta)
    flat = [c for p in route.points for c in p]
    n = len(route.points)
    sent = int(call(sim, port, "WAIT_XY_ARRAY", n, *flat[: 2 * POINTS_PER_FRAME])[0])
    while sent < min(n, WINDOW):  # as much as the window holds before the drive
        k = min(POINTS_PER_FRAME, min(n, WINDOW) - sent)
        sent = int(call(sim, port, "XY_APPEND", sent, *flat[2 * sent : 2 * (sent + k)])[0])
    appends: list[int] = []  # the sequence numbers of the appends sent while driving
    uploaded = port.telemetry_count
    counters = Counters()
    if samples is not None:
        align_to_ticks(sim)
        counters.delta(sim.control("stats", reset=True)["stats"])
    traffic.restart()
    t = 0.0
    while t < max_sim_s:
        end = t + step_s
        probing = probe is not None and samples is not None and len(samples) == probe.step
        if probing:
            sim.control("profile", enable=True)
        # The rest of a streamed route, as the uploader sends it: once telemetry shows room for a
        # batch, an XY_APPEND at a seeded random moment of the next step.
        frame = port.telemetry
        append_at = math.inf
        if sent < n and frame is not None and port.telemetry_count > uploaded:
            room = min(n, max(int(frame.waypoint_index) - 1, 0) + WINDOW) - sent
            if room >= min(STREAM_BATCH, n - sent):
                append_at = t + traffic.jitter() * step_s
        while min(traffic.next_s, append_at) < end:  # the requests that fall in this step
            moment = min(traffic.next_s, append_at)
            if moment - t > 1e-6:
                sim.run_for(moment - t)
                t = moment
            if moment == append_at:
                k = min(room, POINTS_PER_FRAME)
                appends.append(port.send("XY_APPEND", sent, *flat[2 * sent : 2 * (sent + k)]))
                sent += k
                append_at = math.inf
            else:
                traffic.send()
        sim.run_for(end - t)
        t = end
        if probing and probe is not None:
            probe.profile = sim.control("profile", enable=False)["profile"]
        if samples is not None:
            stats = sim.control("stats", reset=True)["stats"]
            d = counters.delta(stats)
            samples.append(
                Step(
                    route.name,
                    tick_cycles(stats["cpu"]),
                    int(stats["cpu"]["overruns"]),
                    d["int0"],
                    d["int1"],
                    d["rx"],
                    d["tx"],
                    d["states_l"] * ENC_STATE_M / step_s,
                    d["states_r"] * ENC_STATE_M / step_s,
                )
            )
        port.poll()
        frame = port.telemetry
        if port.telemetry_count > uploaded + 1 and frame is not None and frame.mode == 0:
            break  # IDLE: the route is done
    else:
        raise RuntimeError(f"the {route.name} was not finished in {max_sim_s} simulated seconds")
    refused = [seq for seq in appends if seq in port.replies and not port.replies[seq].ok]
    if sent < n or refused:
        raise RuntimeError(
            f"the {route.name} was not streamed whole: {sent} of {n} sent, {len(refused)} refused"
        )
    truth = sim.truth()
    gx, gy = route.points[-1]
    return math.hypot(truth["x"] - gx, truth["y"] - gy)


def paused_sim(tmp: str, firmware_elf: Path | None = None) -> Simulator:
    options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin", quiet=True, paused=True)
    if firmware_elf is not None:
        options.firmware = firmware_elf
    return Simulator(options)


# -- interrupt handlers from the cycle profile ---------------------------------------------------
@dataclass(frozen=True)
class Symbol:
    name: str
    start: int
    size: int


def symbols(elf: Path) -> list[Symbol]:
    out = subprocess.run(["avr-nm", "-S", "-C", str(elf)], capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines():
        parts = line.split(maxsplit=3)
        if len(parts) == 4 and parts[2] in "tTW" and re.fullmatch(r"[0-9a-f]+", parts[0] + parts[1]):
            found.append(Symbol(parts[3], int(parts[0], 16), int(parts[1], 16)))
    return found


def vector_table(elf: Path) -> dict[int, tuple[str, int]]:
    """Vector number -> (handler symbol, cycles of the vector table's jump to it)."""
    out = subprocess.run(
        ["avr-objdump", "-d", "--start-address=0", "--stop-address=0x68", str(elf)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    table_: dict[int, tuple[str, int]] = {}
    for m in re.finditer(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(r?jmp)\s+\S+\s*;.*<(\w+)>", out, re.M):
        address, mnemonic, target = int(m.group(1), 16), m.group(2), m.group(3)
        if address % 4 == 0 and address > 0 and target.startswith("__vector_"):
            table_[address // 4] = (target, 3 if mnemonic == "jmp" else 2)
    return table_


def calls_out(elf: Path, s: Symbol) -> bool:
    """Whether a function calls another (whose cycles its own address range leaves out)."""
    out = subprocess.run(
        ["avr-objdump", "-d", f"--start-address={s.start}", f"--stop-address={s.start + s.size}", str(elf)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return re.search(r"\s(r|e|i)?call\b", out) is not None


def invocations(table: dict[int, tuple[str, int]], profile: list[list[int]]) -> dict[int, float]:
    """Vector number -> invocations of its handler in the profile: the cycles of the vector
    table's jump, which executes once per invocation, over the jump's cycles."""
    by_address = {a: c for a, c in profile}
    return {vector: by_address.get(4 * vector, 0) / jump_cycles for vector, (_, jump_cycles) in table.items()}


def isr_costs(elf: Path, profile: list[list[int]]) -> tuple[dict[int, float], list[str]]:
    """Cycles per invocation of each interrupt handler seen in the profile: the vector table's
    jump, the handler's own instructions and the 4-cycle interrupt response; and the handlers
    that call functions (whose cycles are then left out)."""
    ranges = {s.name: s for s in symbols(elf)}
    costs: dict[int, float] = {}
    calling: list[str] = []
    jumps = vector_table(elf)
    counts = invocations(jumps, profile)
    for vector, (handler, jump_cycles) in jumps.items():
        count = counts[vector]
        s = ranges.get(handler)
        if count < 1 or s is None:
            continue
        body = sum(c for a, c in profile if s.start <= a < s.start + s.size)
        costs[vector] = jump_cycles + body / count + RESPONSE_CYCLES
        if calls_out(elf, s):
            calling.append(handler)
    return costs, calling


def by_function(elf: Path, profile: list[list[int]]) -> Counter[str]:
    """Cycles by innermost function (inlined ones included), through avr-addr2line."""
    text = "\n".join(hex(a) for a, _ in profile)
    out = subprocess.run(
        ["avr-addr2line", "-f", "-i", "-C", "-a", "-e", str(elf)],
        input=text,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    names: dict[int, str] = {}
    address: int | None = None
    for line in out:
        if line.startswith("0x"):
            address = int(line, 16)
        elif address is not None and address not in names and not line.startswith(("/", "??:")):
            names[address] = re.sub(r"\(.*|\s*\[clone.*", "", line).strip() or "?"
    totals: Counter[str] = Counter()
    for a, cycles in profile:
        totals[names.get(a, "?")] += cycles
    return totals


# -- one measured run ------------------------------------------------------------------------------
@dataclass
class Run:
    steps: list[Step]
    profile: list[list[int]]
    errors_m: dict[str, float]


def measure_run(k: int, with_profile: bool, probe: Probe | None = None) -> Run:
    """Run k: both routes, stepped tick by tick; with_profile: the cycle profile of all of it;
    with a probe: the profile of that one step (a replay: runs repeat exactly)."""
    steps: list[Step] = []
    errors: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp, paused_sim(tmp) as sim:
        port = Port(sim.pty, seed=k)
        sim.run_for(sim.boot_s())  # the firmware starts (the open reset it)
        if with_profile:
            sim.control("profile", enable=True)
        for route in (square_route(k), circle_route(k), streamed_route(k)):
            errors[route.name] = drive_stepped(
                sim, port, route, Traffic(port, k), 1.0 / TICK_HZ, steps, probe=probe
            )
        profile = sim.control("profile", enable=False)["profile"] if with_profile else []
        port.close()
    return Run(steps, profile, errors)


def isr_load(step: Step, costs: dict[int, float]) -> float:
    """The background interrupts' share of this step's cycles."""
    return (
        sum(int(getattr(step, counter)) * costs.get(v, 0.0) for v, counter in BACKGROUND_COUNTERS.items())
        / PERIOD
    )


def is_straight(s: Step) -> bool:
    return min(s.v_left, s.v_right) >= 0.45 and abs(s.v_left - s.v_right) < 0.05


def is_turning(s: Step) -> bool:
    return abs(s.v_left - s.v_right) >= 0.2


@dataclass
class RunSummary:
    rows: dict[str, dict[str, float]]  # class -> mean, p99, max cycles, ticks
    overruns: int
    isr_mean: float  # background interrupt share while driving
    isr_straight: float  # at full speed, straight
    isr_max: float
    work_max: float  # worst tick's own cycles (background interrupts nested in it removed)
    f_max: float


def summarize(run: Run, costs: dict[int, float]) -> RunSummary:
    classes: dict[str, Callable[[Step], bool]] = {
        "square (straight legs, turns on the spot)": lambda s: s.route == "square",
        "circle (driving while turning)": lambda s: s.route == "circle",
        f"{STREAMED} (96 points, XY_APPEND while driving)": lambda s: s.route == STREAMED,
        "straight at full speed (≥ 0.45 m/s)": is_straight,
        "turning (|v_r - v_l| ≥ 0.2 m/s)": is_turning,
        "all driving ticks": lambda s: True,
    }
    rows = {}
    for label, keep in classes.items():
        cycles = [c for s in run.steps if keep(s) for c in s.cycles]
        if cycles:
            rows[label] = {
                "ticks": len(cycles),
                "mean": sum(cycles) / len(cycles),
                "p99": percentile(cycles, 99),
                "max": max(cycles),
            }
    loads = [isr_load(s, costs) for s in run.steps]
    straight = [load for s, load in zip(run.steps, loads, strict=True) if is_straight(s)]
    work = [c * (1 - load) for s, load in zip(run.steps, loads, strict=True) for c in s.cycles]
    work_max, isr_max = max(work), max(loads)
    return RunSummary(
        rows=rows,
        overruns=sum(s.overruns for s in run.steps),
        isr_mean=sum(loads) / len(loads),
        isr_straight=sum(straight) / len(straight) if straight else float("nan"),
        isr_max=isr_max,
        work_max=work_max,
        f_max=F_CPU * (1 - isr_max) / work_max,
    )


# -- firmware variants at higher tick rates -----------------------------------------------------
class VariantSkipped(Exception):
    """The variant could not be built as planned (the firmware's sources changed shape)."""


def avr_make_variables() -> dict[str, list[str]]:
    """The firmware's compiler and linker flags and sources, as firmware/avr.mk has them."""
    script = "print-avr: ; $(info CXX $(AVR_CXXFLAGS))$(info LD $(AVR_LDFLAGS))$(info SRC $(AVR_SOURCES))@:"
    out = subprocess.run(
        ["make", "-s", "--no-print-directory", "-f", "firmware/avr.mk", "--eval", script, "print-avr"],
        cwd=repo_file(),
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    found = {}
    for line in out.splitlines():
        key, _, rest = line.partition(" ")
        if key in ("CXX", "LD", "SRC"):
            found[key] = shlex.split(rest)
    if set(found) != {"CXX", "LD", "SRC"}:
        raise VariantSkipped("firmware/avr.mk no longer defines AVR_CXXFLAGS, AVR_LDFLAGS, AVR_SOURCES")
    return found


def replace_once(text: str, pattern: str, new: str, what: str) -> str:
    result, n = re.subn(pattern, new, text, flags=re.M)
    if n != 1:
        raise VariantSkipped(f"{what}: expected one match of {pattern!r}, found {n}")
    return result


def build_variant(counts: int, work: Path) -> tuple[Path, float]:
    """The firmware with Timer2's compare value `counts` instead of 125 (a tick every
    counts * 1024 cycles), built with avr.mk's flags from a copy of firmware/ in `work`.
    Returns the ELF and the tick rate."""
    root = repo_file()
    make = avr_make_variables()
    shutil.copytree(root / "firmware", work / "firmware")
    hz = F_CPU / TIMER2_PRESCALER / counts
    header = work / "firmware/board/tick_timer.hpp"
    header.write_text(
        replace_once(
            header.read_text(), r"kCountsPerTick = \d+;", f"kCountsPerTick = {counts};", "tick_timer.hpp"
        )
    )
    toml = work / "robot.toml"
    # tick_hz as the firmware's static_assert computes it (integer division)
    toml.write_text(
        replace_once(
            (root / "config/robot.toml").read_text(),
            r"^tick_hz = \d+",
            f"tick_hz = {F_CPU // TIMER2_PRESCALER // counts}",
            "robot.toml",
        )
    )
    gen = work / "gen"
    gen.mkdir()
    subprocess.run(
        [sys.executable, "tools/gen_params.py", str(toml), str(gen / "robot_params.hpp")],
        cwd=root,
        check=True,
    )
    subprocess.run(
        [sys.executable, "tools/gen_protocol.py", "docs/protocol.md", str(gen / "protocol_table.hpp")],
        cwd=root,
        check=True,
    )
    local = {"-Ifirmware": work / "firmware", "-Ifirmware/core": work / "firmware/core", "-Ibuild/gen": gen}
    cxx = [f"-I{local[a]}" if a in local else a for a in make["CXX"] if a not in ("-MMD", "-MP")]
    # Above 255 Hz the firmware's one-second counters (uint8_t) wrap: the compiler says so, as
    # warnings rather than errors here (see the section's text).
    cxx += ["-Wno-error=overflow", "-Wno-error=type-limits", "-w"]
    (work / "obj").mkdir()

    def compile_one(source: str) -> str:
        obj = work / "obj" / (source.replace("/", "_") + ".o")
        subprocess.run(
            ["avr-g++", *cxx, "-c", str(work / source), "-o", str(obj)], check=True, capture_output=True
        )
        return str(obj)

    with ThreadPoolExecutor(2) as compilers:
        objects = list(compilers.map(compile_one, make["SRC"]))
    elf = work / "variant.elf"
    ld = [a for a in make["LD"] if not a.startswith("-Wl,-Map")]
    subprocess.run(["avr-g++", *ld, *objects, "-o", str(elf), "-lm"], check=True, capture_output=True)
    return elf, hz


@dataclass
class Variant:
    counts: int
    hz: float
    period: int
    ticks: int
    max_cycles: int
    late: int  # ticks that had not reached sleep by the next compare match (simulator)
    lost: int  # ticks the firmware itself counted as lost (STATUS loop_overruns)
    error_m: float

    @property
    def sustained(self) -> bool:
        return self.late == 0 and self.lost == 0 and self.error_m < 0.05


def run_variant(counts: int) -> Variant:
    with tempfile.TemporaryDirectory() as tmp:
        elf, hz = build_variant(counts, Path(tmp))
        with paused_sim(tmp, elf) as sim:
            port = Port(sim.pty, seed=0)
            sim.run_for(sim.boot_s())  # the firmware starts (the open reset it)
            sim.control("stats", reset=True)
            error = 0.0
            for route in (square_route(0), circle_route(0)):
                error = max(error, drive_stepped(sim, port, route, Traffic(port, 0), 0.1, None))
            cpu = sim.control("stats")["stats"]["cpu"]
            lost = int(call(sim, port, "STATUS")[4])
            port.close()
    return Variant(
        counts,
        hz,
        counts * TIMER2_PRESCALER,
        int(cpu["ticks"]),
        int(cpu["max_cycles"]),
        int(cpu["overruns"]),
        lost,
        error,
    )


def search_rate(f_derived: float, budget: int) -> tuple[list[Variant], str]:
    """Brackets the highest rate that keeps up, over Timer2's compare values (a tick every
    counts * 1024 cycles): first the setting at or just below f_derived, then ever larger steps
    towards faster ticks while they keep up (slower ones if the first did not), then halving
    the gap between the fastest that kept up and the slowest that did not; `budget` builds."""
    base = F_CPU / TIMER2_PRESCALER
    tried: dict[int, Variant] = {}

    def sustained(counts: int) -> bool:
        if counts not in tried:
            tried[counts] = run_variant(counts)
        return tried[counts].sustained

    try:
        start = min(255, math.ceil(base / f_derived))
        ok_first = sustained(start)
        step = 1
        good, bad = (start, None) if ok_first else (None, start)
        while len(tried) < budget:  # widen until the result flips
            probe = start - step if ok_first else start + step
            if not 2 <= probe <= 255:
                break
            if sustained(probe) == ok_first:
                good, bad = (probe, bad) if ok_first else (good, probe)
                step *= 2
            else:
                good, bad = (good, probe) if ok_first else (probe, bad)
                break
        while good is not None and bad is not None and abs(good - bad) > 1 and len(tried) < budget:
            middle = (good + bad) // 2
            good, bad = (middle, bad) if sustained(middle) else (good, middle)
    except VariantSkipped as exc:
        return sorted(tried.values(), key=lambda v: v.hz), f"variant builds skipped: {exc}"
    except (subprocess.CalledProcessError, RuntimeError, OSError) as exc:
        return sorted(tried.values(), key=lambda v: v.hz), f"variant builds stopped: {exc}"
    return sorted(tried.values(), key=lambda v: v.hz), ""


# -- the section --------------------------------------------------------------------------------------
def pct(share: float) -> str:
    return f"{100 * share:.1f} %"


def kib(n: int) -> str:
    return f"{n:,} B".replace(",", " ")


def plot_histogram(runs: list[Run], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(8, 4))
    top = max([c for r in runs for s in r.steps for c in s.cycles] + [int(0.33 * PERIOD)])
    edges = list(range(0, top + 1000, 500))
    for route in ("square", "circle", STREAMED):
        cycles = [c for r in runs for s in r.steps if s.route == route for c in s.cycles]
        ax.hist(cycles, bins=edges, histtype="step", linewidth=1.5, label=route)
    ax.axvline(
        CPU_MEAN_BUDGET * PERIOD,
        color="tab:green",
        linestyle="--",
        label=f"mean budget ({100 * CPU_MEAN_BUDGET:.0f} %)",
    )
    ax.axvline(
        CPU_MAX_BUDGET * PERIOD, color="tab:red", linestyle="--", label=f"max budget ({CPU_MAX_BUDGET:.0%})"
    )
    ax.set_yscale("log")
    ax.set_xlabel(f"cycles per control tick (of {PERIOD})")
    ax.set_ylabel("ticks")
    ax.set_title("Firmware CPU per 8 ms tick while driving at 0.5 m/s (simavr, exact)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_profile(functions: Counter[str], ticks: int, path: Path, top: int = 16) -> None:
    items = functions.most_common(top)
    rest = sum(functions.values()) - sum(c for _, c in items)
    handlers = {f"__vector_{v}": f"__vector_{v} ({name.split()[0]})" for v, name in VECTORS.items()}
    labels = [handlers.get(n, n) for n, _ in items] + ["(everything else)"]
    values = [c / ticks for _, c in items] + [rest / ticks]
    fig, ax = plt.subplots(figsize=(8, 5.5))
    colors = ["tab:orange" if n.startswith("__vector") else "tab:blue" for n in labels]
    ax.barh(range(len(labels)), values, color=colors)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel(f"cycles per control tick (mean; all: {sum(functions.values()) / ticks:.0f} of {PERIOD})")
    ax.set_title("Where a control tick's cycles go (innermost function; interrupt handlers orange)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(out: Path, quick: bool) -> Section:
    started = time.monotonic()
    elf = default_firmware()
    flash, ram = usage(sections(str(elf)))

    runs = [measure_run(k, with_profile=k == 0) for k in range(1 if quick else 3)]
    costs, calling = isr_costs(elf, runs[0].profile)
    summaries = [summarize(r, costs) for r in runs]
    worst = min(summaries, key=lambda s: s.f_max)
    variants, variant_note = search_rate(worst.f_max, 3 if quick else 7)
    # the heaviest tick, replayed with the cycle profile on for its step alone
    peak_cycles, peak_run, peak_step = max(
        (c, k, i) for k, r in enumerate(runs) for i, st in enumerate(r.steps) for c in st.cycles
    )
    probe = Probe(peak_step)
    replay = measure_run(peak_run, with_profile=False, probe=probe)
    replayed = replay.steps[peak_step].cycles == runs[peak_run].steps[peak_step].cycles
    peak_functions = by_function(elf, probe.profile)

    out.mkdir(parents=True, exist_ok=True)
    plot_histogram(runs, out / f"{NAME}_cycles_hist.png")
    ticks_profiled = invocations(vector_table(elf), runs[0].profile).get(TICK_VECTOR, 0.0)
    profile_ticks = max(1, round(ticks_profiled))
    functions = by_function(elf, runs[0].profile)
    plot_profile(functions, profile_ticks, out / f"{NAME}_profile.png")

    # -- numbers and targets
    labels = list(summaries[0].rows)
    per_class = {
        label: {
            key: spread([s.rows[label][key] for s in summaries if label in s.rows])
            for key in ("mean", "p99", "max", "ticks")
        }
        for label in labels
    }
    overruns = sum(s.overruns for s in summaries)
    mean_high = max(s.rows["all driving ticks"]["mean"] for s in summaries) / PERIOD
    max_high = max(s.rows["all driving ticks"]["max"] for s in summaries) / PERIOD
    targets = [
        (f"flash ≤ {kib(FLASH_BUDGET)}", kib(flash), flash <= FLASH_BUDGET),
        (f"static RAM ≤ {kib(RAM_BUDGET)}", kib(ram), ram <= RAM_BUDGET),
        (
            f"CPU per tick, mean ≤ {100 * CPU_MEAN_BUDGET:.0f} %",
            f"{pct(mean_high)} (worst run)",
            mean_high <= CPU_MEAN_BUDGET,
        ),
        (
            f"CPU per tick, max ≤ {CPU_MAX_BUDGET:.0%}",
            f"{pct(max_high)} (worst run)",
            max_high <= CPU_MAX_BUDGET,
        ),
        ("no tick overruns", str(overruns), overruns == 0),
    ]
    checks = {name: met for name, _, met in targets}
    ok = all(checks.values())
    over = [(s, c) for r in runs for s in r.steps for c in s.cycles if c > CPU_MAX_BUDGET * PERIOD]

    # -- Markdown
    n = len(runs)
    md = ["## Firmware\n"]
    md.append(
        f"`{elf.name}`, ATmega328P at {F_CPU / 1e6:g} MHz, control tick {TICK_HZ} Hz = {PERIOD} cycles. "
        f"Memory from `avr-size`; CPU measured exactly in simavr, one tick at a time, while driving "
        "at v_max = 0.5 m/s with the gateway's STATUS/POSE polling "
        + (
            f"({n} runs, each from another start corner and phase and with another seed; medians with "
            "the range over runs). "
            if n > 1
            else "(1 run; the full benchmark makes 3). "
        )
        + f"Targets: {'met' if ok else 'MISSED'}.\n\n"
    )
    md.append(
        table(
            ["target", "measured", ""],
            [[name, measured, "met" if met else "**MISSED**"] for name, measured, met in targets],
        )
    )
    md.append("### Memory\n")
    md.append(
        table(
            ["", "used", "budget", "chip"],
            [
                [
                    "flash (.text + .data)",
                    kib(flash),
                    f"≤ {kib(FLASH_BUDGET)} ({100 * flash / FLASH_BUDGET:.0f} %)",
                    f"{kib(CHIP_FLASH)}, {kib(CHIP_FLASH - OPTIBOOT)} without the 512 B Optiboot",
                ],
                [
                    "static RAM (.data + .bss)",
                    kib(ram),
                    f"≤ {kib(RAM_BUDGET)} ({100 * ram / RAM_BUDGET:.0f} %)",
                    f"{kib(RAM_TOTAL)}; {kib(RAM_TOTAL - ram)} left for the stack",
                ],
            ],
        )
    )
    md.append(f"\n### CPU per control tick ({PERIOD} cycles = 8 ms)\n")
    rows = []
    for label in labels:
        c = per_class[label]
        rows.append(
            [
                label,
                c["ticks"].text(".0f"),
                f"{c['mean'].text('.0f')} ({pct(c['mean'].median / PERIOD)})",
                c["p99"].text(".0f"),
                f"{c['max'].text('.0f')} ({pct(c['max'].median / PERIOD)})",
            ]
        )
    md.append(table(["ticks", "n", "mean cycles (share)", "p99 cycles", "max cycles (share)"], rows))
    md.append(
        f"\nOverruns (a tick not asleep by the next compare match): {overruns} of "
        f"{sum(int(s.rows['all driving ticks']['ticks']) for s in summaries)} ticks. "
        f"Budgets: mean ≤ {100 * CPU_MEAN_BUDGET:.0f} % "
        f"({int(CPU_MEAN_BUDGET * PERIOD)} cycles), "
        f"max ≤ {CPU_MAX_BUDGET:.0%} ({int(CPU_MAX_BUDGET * PERIOD)}): worst run "
        f"{pct(mean_high)} mean, {pct(max_high)} max.\n"
    )
    if over:
        squares = sum(1 for st, _ in over if st.route == "square")
        md.append(
            f"\nTicks over the {CPU_MAX_BUDGET:.0%} budget: {len(over)} of "
            f"{sum(len(st.cycles) for r in runs for st in r.steps)} ({squares} on the square, "
            f"{len(over) - squares} on the circle).\n"
        )
    md.append(f"\n![cycles per tick]({NAME}_cycles_hist.png)\n")
    peak_route = runs[peak_run].steps[peak_step].route
    reproduced = "the same cycles again" if replayed else "NOT reproduced: what follows may be another tick"
    md.append(
        f"\nThe heaviest tick, {peak_cycles} cycles ({pct(peak_cycles / PERIOD)}; run {peak_run + 1}, "
        f"{peak_route}), replayed with the cycle profile on for its 8 ms alone ({reproduced}; the "
        f"profile holds {sum(peak_functions.values())} cycles of it): "
        + ", ".join(f"{name} {cycles}" for name, cycles in peak_functions.most_common(10))
        + ".\n"
    )

    md.append("\n### Interrupt load\n")
    isr_rows = []
    straight_steps = [s for r in runs for s in r.steps if is_straight(s)]
    for vector, cost in sorted(costs.items()):
        rate = ""
        if straight_steps and vector in BACKGROUND_COUNTERS:
            counter = BACKGROUND_COUNTERS[vector]
            per_s = sum(getattr(s, counter) for s in straight_steps) / (len(straight_steps) / TICK_HZ)
            rate = f"{per_s:.0f} /s ({pct(per_s * cost / F_CPU)})"
        elif vector == TICK_VECTOR:
            rate = f"{TICK_HZ} /s (part of the tick)"
        isr_rows.append([VECTORS.get(vector, f"vector {vector}"), f"{cost:.0f}", rate])
    md.append(
        table(["interrupt", "cycles per invocation", "at full speed, straight: rate (CPU share)"], isr_rows)
    )
    md.append(
        "\nCycles per invocation: the vector table's jump and the handler's instructions from the "
        "simulator's cycle profile, plus the 4-cycle interrupt response"
        + (f" (not counted: the functions that {', '.join(calling)} call)" if calling else "")
        + ". Background interrupt load "
        "(encoders and UART, which follow the wheels and the link, not the tick rate): "
        f"{spread([s.isr_mean for s in summaries]).text('.2%')} of the CPU on average while driving, "
        f"{spread([s.isr_straight for s in summaries]).text('.2%')} straight at full speed, "
        f"{spread([s.isr_max for s in summaries]).text('.2%')} in the busiest 8 ms.\n"
    )
    md.append(f"\n![profile]({NAME}_profile.png)\n")

    md.append("\n### Highest control rate\n")
    md.append(
        "A tick's own work T is its cycles minus the background interrupts nested in it (their share "
        "s of that 8 ms, taken as spread evenly); at a rate f the loop has F_CPU/f cycles per tick, "
        "of which the background interrupts take s. So the loop keeps up while "
        "f ≤ f_max = F_CPU·(1 - s_max) / T_max, with the worst tick's work and the busiest "
        f"interrupt load: T_max = {spread([s.work_max for s in summaries]).text('.0f')} cycles, "
        f"s_max = {spread([s.isr_max for s in summaries]).text('.2%')}, "
        f"**f_max = {spread([s.f_max for s in summaries]).text('.0f')} Hz** "
        f"({worst.f_max / TICK_HZ:.1f} times the {TICK_HZ} Hz in use).\n"
    )
    if variants:
        md.append(
            "\nChecked by measuring: variants of the firmware with Timer2's compare value changed "
            "(a copy of firmware/ and robot.toml's tick_hz in a temporary directory, built with "
            "avr.mk's flags) drive the square and the circle with the same polling. A tick is late "
            "when it has not reached sleep by the next compare match (the simulator's test, whatever "
            "the rate it was built for), lost when the "
            "firmware found its flag still set (STATUS loop_overruns). Above 255 Hz the firmware's "
            "one-second counters (uint8_t) wrap, so there the stall timeout is shorter and STATUS's "
            "CPU percentages stop updating; neither affects these routes.\n\n"
        )
        md.append(
            table(
                [
                    "tick rate",
                    "period (cycles)",
                    "ticks",
                    "max cycles",
                    "late ticks",
                    "lost ticks",
                    "route end error",
                    "keeps up",
                ],
                [
                    [
                        f"{v.hz:.1f} Hz",
                        v.period,
                        v.ticks,
                        f"{v.max_cycles} ({pct(v.max_cycles / v.period)})"
                        if not v.late
                        else "over the period",
                        v.late,
                        v.lost,
                        f"{1000 * v.error_m:.1f} mm",
                        "yes" if v.sustained else "no",
                    ]
                    for v in variants
                ],
            )
        )
        kept = [v.hz for v in variants if v.sustained]
        failed = [v.hz for v in variants if not v.sustained]
        verdict = []
        if kept:
            verdict.append(f"keeps up at {max(kept):.0f} Hz")
        if failed:
            verdict.append(f"falls behind at {min(failed):.0f} Hz")
        md.append(
            f"\nMeasured: the MCU {' and '.join(verdict)} "
            f"(derived from the worst run: {worst.f_max:.0f} Hz).\n"
        )
    if variant_note:
        md.append(f"\n{variant_note}; the rate above is derived only.\n")
    elapsed = time.monotonic() - started
    md.append(f"\n_{'quick' if quick else 'full'} mode, {elapsed:.0f} s._\n")

    data: dict[str, Any] = {
        "elf": str(elf),
        "flash_bytes": flash,
        "flash_budget": FLASH_BUDGET,
        "ram_bytes": ram,
        "ram_budget": RAM_BUDGET,
        "period_cycles": PERIOD,
        "runs": n,
        "cpu": {label: {k: v.as_dict() for k, v in c.items()} for label, c in per_class.items()},
        "cpu_mean_share_worst_run": mean_high,
        "cpu_max_share_worst_run": max_high,
        "overruns": overruns,
        "isr_cycles_per_invocation": {VECTORS.get(v, str(v)): c for v, c in costs.items()},
        "isr_share_mean": spread([s.isr_mean for s in summaries]).as_dict(),
        "isr_share_straight": spread([s.isr_straight for s in summaries]).as_dict(),
        "isr_share_max": spread([s.isr_max for s in summaries]).as_dict(),
        "tick_work_max_cycles": spread([s.work_max for s in summaries]).as_dict(),
        "f_max_derived_hz": spread([s.f_max for s in summaries]).as_dict(),
        "variants": [{**v.__dict__, "sustained": v.sustained} for v in variants],
        "variant_note": variant_note,
        "route_end_error_m": [r.errors_m for r in runs],
        "peak_tick": {
            "cycles": peak_cycles,
            "run": peak_run,
            "route": peak_route,
            "replayed": replayed,
            "by_function": dict(peak_functions.most_common()),
        },
        "checks": checks,
        "run_seconds": elapsed,
    }
    return Section(NAME, "\n".join(md), data, ok)


if __name__ == "__main__":
    sys.exit(section_main(run))
