"""## Noisy link: missions and stops over a serial line that loses bytes

Issue 22: with 1 % of the bytes damaged towards the MCU and 1 % lost from it (the simulator's
`uart_rx_corrupt` and `uart_tx_drop`: a Bluetooth HC-05 or a Wi-Fi bridge on a bad day), 4 of
12 soak missions failed and a lost STOP waited 250 ms to be resent. Measured at 0 %, 1 % and
5 % of bytes each way, and with bursts (`uart_burst_*`: every byte lost for 150 ms, on average
twice a second), on the real firmware in the simulator:

- **soak missions**: `cart2d mission` (a process of its own, the simulator in real time as a
  mission with UART faults runs) of four goals round the seed's 1.8 m arena past a wall with two
  gaps, each with its own simulator seed; completed = every goal reached. Every failure is
  listed with the sentence its report gives.
- **stops**: a gateway in this process drives the cart across the arena at full speed (go-to,
  the simulator in real time); at a random moment it is stopped (Gateway.stop(), what `POST
  /api/stop` calls) and ground truth (500 samples per simulated second) gives the time from the
  request (the simulator's time just before it) to the cart's true speed under 20 % of what it
  was: simulated time, p50 and p99.

Targets (issue 22): at 1 % every mission completes and the stop's p99 is at most 200 ms; at 5 %
at least 95 % complete. The full run: 12 missions and 40 stops per line; `--quick` (in `make
bench-quick`) 1 or 2 missions (none at 5 %: two cannot judge 95 %) and 6 stops, and fails only
on those targets: completion and simulated time, not on how busy the machine is.

`python -m bench.noisy_link [--quick]`.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from bench.common import Section, percentile, section_main, table
from cart2d.gateway import Gateway
from cart2d.link import Link, LinkError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import GatewaySettings, MapSettings, Store

NAME = "noisy_link"
STOP_P99_BUDGET_S = 0.2  # at 1 %
COMPLETION_TARGETS = {"1 %": 1.0, "5 %": 0.95}
SLOW_SHARE = 0.2  # stopped: the true speed under this share of the speed at the request
TRUTH_HZ = 500.0
V_MAX = 0.5
WALL = [[0.8, y] for y in (0.0, 0.2, 0.4, 0.6)] + [[0.8, y] for y in (1.4, 1.6, 1.8)]
GOALS = [[1.6, 1.4], [0.2, 1.6], [1.6, 0.2], [0.2, 0.4]]
ENDS = ((0.2, 0.9), (1.6, 0.9))  # the stops' cart drives between these
# The quick run has no 5 % missions: two cannot tell 95 % from less (one failure in twenty, which
# the target allows, fails one of two missions one time in ten), and at 5 % a mission's STATUS
# reads (79 bytes, one try in 60 gets through) sometimes all fail for 5 s. Its stops are measured.
QUICK_MISSIONS = {"0 %": 1, "1 %": 2, "5 %": 0, "bursts": 1}


def byte_errors(share: float) -> dict[str, float]:
    return {"uart_rx_corrupt": share, "uart_tx_drop": share} if share else {}


BURSTS = {"uart_burst_hz": 2.0, "uart_burst_ms": 150.0, "uart_burst_drop": 1.0}
LEVELS: dict[str, dict[str, float]] = {
    "0 %": {},
    "1 %": byte_errors(0.01),
    "5 %": byte_errors(0.05),
    "bursts": BURSTS,
}


def soak_mission(faults: dict[str, float]) -> dict[str, Any]:
    return {
        "grid": {"cols": 10, "rows": 10, "step": 0.2},
        "obstacles": WALL,
        "start": [0.2, 0.4, 0.0],
        "goals": GOALS,
        "faults": faults,
        # Completion is measured, not speed: at 5 % a 2-point path frame gets through about one
        # try in nine, so the cart waits for its path, longer the busier the machine (the link's
        # retries run on the wall clock). About 47 simulated s with both cores busy; a line that
        # answers nothing for 5 s still fails the mission at once.
        "timeout_s": 300.0,
    }


def run_mission(mission: dict[str, Any], seed: int) -> dict[str, Any]:
    """One `cart2d mission` in its own process; its report (an `error` if it has none)."""
    with tempfile.TemporaryDirectory() as tmp:
        mission_path, report_path = Path(tmp) / "mission.json", Path(tmp) / "report.json"
        mission_path.write_text(json.dumps(mission))
        command = [sys.executable, "-m", "cart2d.tools.cli", "mission", str(mission_path)]
        command += ["--report", str(report_path), "--seed", str(seed), "--no-mcap"]
        done = subprocess.run(command, capture_output=True, text=True, timeout=900, check=False)
        if not report_path.exists():
            return {"error": f"no report: {done.stderr.strip().splitlines()[-1:]}", "goals": []}
        report: dict[str, Any] = json.loads(report_path.read_text())
        return report


def mission_outcome(report: dict[str, Any]) -> tuple[bool, str]:
    """Whether every goal was reached; else the report's sentence why not."""
    if "error" in report:
        return False, str(report["error"])
    goals = report.get("goals", [])
    missed = [g for g in goals if not g.get("reached")]
    if len(goals) == len(GOALS) and not missed:
        return True, ""
    return False, missed[0].get("reason", "not reached") if missed else "goals missing"


# -- stops ----------------------------------------------------------------------------------------
@dataclass
class StopRig:
    sim: Simulator
    gateway: Gateway
    truth: list[tuple[float, float]] = field(default_factory=list)  # (t, |v|)
    x: float = 0.0  # the latest true position's x
    lock: threading.Lock = field(default_factory=threading.Lock)

    def keep(self, message: dict[str, Any]) -> None:
        with self.lock:
            self.truth.append((float(message["t"]), abs(float(message["v"]))))
            self.x = float(message["x"])

    def since(self, t: float) -> list[tuple[float, float]]:
        with self.lock:
            return [s for s in self.truth if s[0] >= t]

    def speed(self) -> float:
        with self.lock:
            return self.truth[-1][1] if self.truth else 0.0


@contextmanager
def stop_rig(faults: dict[str, float], seed: int) -> Iterator[StopRig]:
    """The simulator in real time with these faults, its link and a gateway, started."""
    with tempfile.TemporaryDirectory() as tmp:
        eeprom = Path(tmp) / "eeprom.bin"
        options = SimOptions(speed="1", seed=seed, eeprom=eeprom, quiet=True, start=(0.2, 0.9, 0.0))
        with Simulator(options) as sim, Link(sim.pty) as link:
            settings = GatewaySettings(map=MapSettings())
            gateway = simulated_gateway(link, Store(Path(tmp) / "gateway"), settings, sim).gateway
            rig = StopRig(sim, gateway)
            sim.subscribe_truth(rig.keep)
            sim.control("truth_rate", hz=TRUTH_HZ)
            gateway.wait_for_firmware(20.0, 0.1)
            link.call("SET_POSE", 0.2, 0.9, 0.0)
            sim.control("faults", **faults)
            gateway.start()
            try:
                yield rig
            finally:
                gateway.close()


def wait_until(condition: Any, wall_s: float) -> bool:
    deadline = time.monotonic() + wall_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


def stop_latency(rig: StopRig, rng: random.Random) -> float | None:
    """Drives towards the end of the arena farther away, stops at a random moment at full speed;
    simulated seconds from the request to the true speed under SLOW_SHARE of its value then
    (None: never at full speed)."""
    goal = max(ENDS, key=lambda end: abs(end[0] - rig.x))
    for _ in range(5):  # a noisy line may refuse a goal (every try lost): asked again
        try:
            rig.gateway.go_to(*goal)
            break
        except LinkError:
            continue
    if not wait_until(lambda: rig.speed() > 0.8 * V_MAX, 15.0):
        return None
    time.sleep(rng.uniform(0.0, 0.4))
    asked_t = float(rig.sim.truth()["t"])
    v0 = rig.speed()
    rig.gateway.stop()
    if not wait_until(lambda: any(v < SLOW_SHARE * v0 for _, v in rig.since(asked_t)), 15.0):
        return None
    slow_t = next(t for t, v in rig.since(asked_t) if v < SLOW_SHARE * v0)
    wait_until(lambda: rig.speed() < 0.01, 5.0)  # at rest before the next goal
    return slow_t - asked_t


def stop_latencies(faults: dict[str, float], count: int, seed: int) -> tuple[list[float], int]:
    """`count` stops; their latencies, and how many went without a measurement."""
    rng = random.Random(seed)
    latencies: list[float] = []
    missed = 0
    with stop_rig(faults, seed) as rig:
        for _ in range(count):
            latency = stop_latency(rig, rng)
            if latency is None:
                missed += 1
            else:
                latencies.append(latency)
    return latencies, missed


# -- the section ----------------------------------------------------------------------------------
@dataclass
class Level:
    name: str
    missions: list[tuple[bool, str]]
    stops_s: list[float]
    stops_missed: int

    @property
    def completion(self) -> float:
        return sum(ok for ok, _ in self.missions) / max(1, len(self.missions))

    def p(self, q: float) -> float | None:
        return percentile(self.stops_s, q) if self.stops_s else None


def measure(missions: dict[str, int], stops: int, workers: int) -> list[Level]:
    jobs = [(name, seed) for name in LEVELS for seed in range(1, missions[name] + 1)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        reports = list(pool.map(lambda job: run_mission(soak_mission(LEVELS[job[0]]), job[1]), jobs))
    levels = []
    for k, (name, faults) in enumerate(LEVELS.items()):
        outcomes = [mission_outcome(r) for (n, _), r in zip(jobs, reports, strict=True) if n == name]
        latencies, missed = stop_latencies(faults, stops, seed=k + 1)
        levels.append(Level(name, outcomes, latencies, missed))
    return levels


def targets_met(levels: list[Level]) -> bool:
    by_name = {level.name: level for level in levels}
    complete = all(
        by_name[name].completion >= share
        for name, share in COMPLETION_TARGETS.items()
        if by_name[name].missions  # none at 5 % in the quick run
    )
    p99 = by_name["1 %"].p(99)
    return complete and p99 is not None and p99 <= STOP_P99_BUDGET_S and by_name["1 %"].stops_missed == 0


def _ms(value: float | None) -> str:
    return "none" if value is None else f"{value * 1000:.0f}"


def _plot(levels: list[Level], out: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.boxplot([[s * 1000 for s in level.stops_s] or [0.0] for level in levels], whis=(1, 99))
    ax.set_xticks(range(1, len(levels) + 1), [level.name for level in levels])
    ax.axhline(STOP_P99_BUDGET_S * 1000, color="tab:red", linestyle="--", label="p99 budget at 1 %")
    ax.set_ylabel("request to speed < 20 % (ms, simulated)")
    ax.set_xlabel("the serial line: bytes lost or damaged each way, or bursts")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(out / f"{NAME}_stops.png", dpi=110)
    plt.close(fig)


def _markdown(levels: list[Level], ok: bool) -> str:
    rows = [
        [
            level.name,
            f"{sum(k for k, _ in level.missions)} of {len(level.missions)} ({level.completion:.0%})"
            if level.missions
            else "none in the quick run",
            len(level.stops_s),
            _ms(level.p(50)),
            _ms(level.p(99)),
            _ms(max(level.stops_s) if level.stops_s else None),
        ]
        for level in levels
    ]
    header = ["line", "missions completed", "stops", "stop p50 (ms)", "stop p99 (ms)", "max (ms)"]
    failures = [f"- {level.name}: {why}" for level in levels for done, why in level.missions if not done]
    text = (__doc__ or "").strip() + "\n\n" + table(header, rows)
    failed = "Failures, in the reports' words:\n\n" + "\n".join(failures) if failures else "No failure."
    text += "\n" + failed
    text += f"\n\n![stop latency by line](noisy_link_stops.png)\n\nTargets {'met' if ok else '**MISSED**'}.\n"
    return text


def run(out: Path, quick: bool) -> Section:
    missions = QUICK_MISSIONS if quick else {name: 12 for name in LEVELS}
    levels = measure(missions, stops=6 if quick else 40, workers=2)
    ok = targets_met(levels)
    _plot(levels, out)
    data = {
        level.name: {
            "missions": [{"completed": done, "reason": why} for done, why in level.missions],
            "completion": level.completion,
            "stops_s": level.stops_s,
            "stops_missed": level.stops_missed,
            "stop_p50_s": level.p(50),
            "stop_p99_s": level.p(99),
        }
        for level in levels
    }
    return Section(NAME, _markdown(levels, ok), data, ok)


if __name__ == "__main__":
    sys.exit(section_main(run))
