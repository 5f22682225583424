"""Fleet (issue 27): 3 and 5 simulated carts (the real firmware each, in one 4 m arena, coupled
through their simulators' side channels) on a loopback mosquitto, given the same random goals
by the fleet manager (VDA 5050 orders, traffic control on the shared 0.5 m lattice), against one
cart doing them all. Goals are handed out as carts come free (as many open as carts).

Measured: contacts between carts (disc to disc, from the simulators' truth) and with the walls,
goals reached, the makespan (simulated seconds from the first goal to the last arrival) against
the one cart's, the time goals spent waiting for reservations, the latency from a goal's
assignment to the cart's state showing its order (through the broker), the CPU of the broker,
of each simulator and of the Python process that runs every gateway and the manager, and the
slowest simulator's real-time factor (how many carts this machine simulates in real time)."""

from __future__ import annotations

import contextlib
import random
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import psutil

from bench.common import Section, missed, section_main, spread, table
from cart2d.fleet.arena import FLEET_MAP, map_lattice
from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.lattice import Cell, Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.tools.fleet import SimFleet, default_starts

NAME = "fleet"
GOALS = 30
MAKESPAN_TARGET = 0.45  # 3 carts against one (issue 27)
SEED = 27


@dataclass
class FleetRun:
    carts: int
    goals: int
    reached: int = 0
    cart_contacts: int = 0
    wall_contacts: int = 0
    makespan_s: float = 0.0  # simulated
    wall_s: float = 0.0
    waited_s: list[float] = field(default_factory=list)
    latency_s: list[float] = field(default_factory=list)
    cpu_percent: dict[str, float] = field(default_factory=dict)
    slowest_rtf: float = 0.0
    deadlocks: int = 0


def goal_cells(lattice: Lattice, n: int, seed: int = SEED) -> list[Cell]:
    rng = random.Random(seed)
    free = sorted(lattice.free)
    cells: list[Cell] = []
    while len(cells) < n:
        cell = rng.choice(free)
        if not cells or cell != cells[-1]:
            cells.append(cell)
    return cells


def fleet_run(n: int, goals: list[Cell], timeout_s: float) -> FleetRun:
    lattice = map_lattice(FLEET_MAP)
    run = FleetRun(n, len(goals))
    with contextlib.ExitStack() as stack:
        mosquitto = stack.enter_context(Mosquitto())
        home = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="cart2d-bench-fleet-")))
        fleet = SimFleet.start(default_starts(lattice, n), "1", [], mosquitto.broker, stack, home)
        manager = FleetManager(lattice, mosquitto.broker).start()
        stack.callback(manager.close)
        deadline = time.monotonic() + 30
        while len(manager.traffic.standing) < n and time.monotonic() < deadline:
            time.sleep(0.1)
        processes = _processes(mosquitto, fleet)
        before = {k: sum(p.cpu_times()[:2]) for k, p in processes.items()}
        started, sim_start = time.monotonic(), _sim_time(fleet)
        _hand_out(manager, lattice, list(goals), n, started + timeout_s)
        run.wall_s = time.monotonic() - started
        run.makespan_s = _sim_time(fleet) - sim_start
        run.cpu_percent = {
            k: round(100 * (sum(p.cpu_times()[:2]) - before[k]) / run.wall_s, 1) for k, p in processes.items()
        }
        truth = fleet.arena.view()
        run.cart_contacts = int(truth["cart_contacts"])
        run.wall_contacts = sum(int(c["wall_contacts"] or 0) for c in truth["carts"].values())
        run.slowest_rtf = min(float(c["rtf"] or 0) for c in truth["carts"].values())
        reached = [g for g in manager.goals if g.status == "reached"]
        run.reached = len(reached)
        run.waited_s = [g.waited_s for g in reached]
        run.latency_s = [g.accepted_s - g.assigned_s for g in reached if g.accepted_s and g.assigned_s]
        run.deadlocks = manager.traffic.deadlocks
    return run


def _processes(mosquitto: Mosquitto, fleet: SimFleet) -> dict[str, psutil.Process]:
    found = {"gateways and manager (Python)": psutil.Process()}
    if mosquitto.pid is not None:
        found["mosquitto"] = psutil.Process(mosquitto.pid)
    for cart in fleet.carts:
        if cart.sim.process is not None:
            found[f"simulator {cart.name}"] = psutil.Process(cart.sim.process.pid)
    return found


def _sim_time(fleet: SimFleet) -> float:
    return float(fleet.carts[0].sim.truth()["t"])


def _hand_out(manager: FleetManager, lattice: Lattice, queue: list[Cell], n: int, deadline: float) -> None:
    """Keeps as many goals open as carts, each on a node no cart holds and no open goal has."""
    while time.monotonic() < deadline:
        open_goals = [g for g in manager.goals if g.status in ("waiting", "driving")]
        if not queue and not open_goals:
            return
        taken = set(manager.traffic.holds) | {g.cell for g in open_goals}
        for k, cell in enumerate(queue):
            if len(open_goals) >= n:
                break
            if cell not in taken:
                open_goals.append(manager.add_goal(*lattice.position(queue.pop(k))))
                break
        time.sleep(0.2)


def run(out: Path, quick: bool) -> Section:
    lattice = map_lattice(FLEET_MAP)
    goals = goal_cells(lattice, 3 if quick else GOALS)
    sizes = (2,) if quick else (1, 3, 5)
    runs = {n: fleet_run(n, goals, 120 if quick else 900) for n in sizes}
    one = runs.get(1)
    rows = []
    for n, r in runs.items():
        ratio = r.makespan_s / one.makespan_s if one and one.makespan_s else float("nan")
        rows.append(
            [
                n,
                f"{r.reached} of {r.goals}",
                r.cart_contacts,
                r.wall_contacts,
                f"{r.makespan_s:.0f} s" + (f" ({ratio:.2f} x)" if one and n > 1 else ""),
                spread(r.waited_s).text(".1f", "s") if r.waited_s else "-",
                spread(r.latency_s).text(".3f", "s") if r.latency_s else "-",
                r.deadlocks,
                f"{r.slowest_rtf:.2f}",
                ", ".join(f"{k} {v:.0f} %" for k, v in r.cpu_percent.items()),
            ]
        )
    md = [f"## {NAME}", "", __doc__.split("\n\n", 1)[0], ""]
    md.append(
        table(
            [
                "carts",
                "goals reached",
                "contacts between carts",
                "wall contacts",
                "makespan (x one cart)",
                "waiting per goal",
                "goal → order latency",
                "deadlocks resolved",
                "slowest real-time factor",
                "CPU (of one core)",
            ],
            rows,
        )
    )
    checks = [(f"{n} carts: every goal reached", r.reached == r.goals) for n, r in runs.items()]
    checks += [
        (f"{n} carts: no contact", r.cart_contacts == 0 and r.wall_contacts == 0) for n, r in runs.items()
    ]
    three = runs.get(3)
    if one and three and one.makespan_s:
        checks.append(
            (
                f"3 carts' makespan ≤ {MAKESPAN_TARGET} x one cart's",
                three.makespan_s <= MAKESPAN_TARGET * one.makespan_s,
            )
        )
    failed = missed(checks)
    if failed:
        md.append("Missed: " + "; ".join(failed) + "\n")
    return Section(
        NAME,
        "\n".join(md),
        {str(n): asdict(r) for n, r in runs.items()},
        targets_met=not failed,
    )


def main() -> int:
    return section_main(run)


if __name__ == "__main__":
    raise SystemExit(main())
