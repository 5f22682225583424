"""Several simulated carts in one physical world (`cart2d fleet sim`): one cart2d-sim per cart
(the real firmware of each in its own simavr), coupled through their side channels. Each
simulator's world holds the others as boxes that follow their true poses (a square round the
footprint disc, as tall as the cart, in the cart's colour): a cart cannot drive through another,
its bumper switches close on it, its camera sees it. The contacts between carts are counted
here, disc to disc, from the true poses, with the truth of every cart in one place (view()).

Why not one process with N carts: the simulator is one MCU, one pty and one side channel per
process, and the simulators run apart already (speed 1 each: paced to the wall clock). Coupling
them costs a `boxes` message per simulator COUPLING_HZ times a second, and a cart's box lags its
true pose by at most one period (2 cm at 0.5 m/s at 25 Hz), which the contact count, made from
the true poses, does not share. docs/fleet.md says so."""

from __future__ import annotations

import contextlib
import itertools
import math
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from cart2d.files import read_regular
from cart2d.maps.world import Box
from cart2d.params import footprint_radius_m, robot
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.world_file import MAX_FILE_BYTES, BoxSpec, parse

COUPLING_HZ = 25.0
CONTACT_RELEASE_M = 0.001  # a contact ends once the discs are this far apart (the simulator's 1 mm)
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2")


class CartStart(BaseModel):
    model_config = ConfigDict(extra="forbid")
    id: str = Field(pattern=r"^[A-Za-z0-9_.-]{1,64}$")
    x: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    y: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    theta: float = Field(0.0, ge=-10, le=10, allow_inf_nan=False)


class FleetWorldSpec(BaseModel):
    """A fleet's world file: `cart2d sim --world`'s boxes, and where each cart starts."""

    model_config = ConfigDict(extra="forbid")
    boxes: list[BoxSpec] = Field(default_factory=list, max_length=10_000)
    carts: list[CartStart] = Field(default_factory=list, max_length=64)


def read_fleet_world(path: Path) -> tuple[FleetWorldSpec | None, list[str]]:
    try:
        data = read_regular(path, MAX_FILE_BYTES)
    except (OSError, ValueError) as exc:
        return None, [f"the world file {path} cannot be read: {getattr(exc, 'strerror', None) or exc}"]
    spec, problems = parse(data, FleetWorldSpec, f"the world file {path}")
    if spec is not None:
        ids = [c.id for c in spec.carts]
        if len(set(ids)) != len(ids):
            problems = [f"{path}: two carts have one id"]
        problems += _overlaps(spec.carts, path)
    return (spec if not problems else None), problems


def _overlaps(carts: list[CartStart], path: Path) -> list[str]:
    reach = 2 * footprint_radius_m()
    return [
        f"{path}: carts {a.id} and {b.id} start {math.dist((a.x, a.y), (b.x, b.y)):.2f} m apart "
        f"(their footprints need {reach:.2f} m)"
        for a, b in itertools.combinations(carts, 2)
        if math.dist((a.x, a.y), (b.x, b.y)) < reach
    ]


class SharedArena:
    """Couples the simulators of `sims` (name -> a started Simulator, at its start pose)."""

    def __init__(self, sims: dict[str, Simulator]) -> None:
        self.sims = sims
        self.colours = {name: COLOURS[k % len(COLOURS)] for k, name in enumerate(sims)}
        self._lock = threading.Lock()
        self._truth: dict[str, dict[str, Any]] = {}
        self._touching: set[tuple[str, str]] = set()
        self.cart_contacts = 0  # contacts begun between two carts (disc to disc)
        self.contact_log: list[dict[str, Any]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._couple, name="shared arena", daemon=True)
        for name, sim in sims.items():
            sim.subscribe_truth(self._truth_listener(name))

    def _truth_listener(self, name: str) -> Callable[[dict[str, Any]], None]:
        def listen(truth: dict[str, Any]) -> None:
            with self._lock:
                self._truth[name] = truth
                self._count_contacts(name)

        return listen

    def start(self) -> SharedArena:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)

    def _count_contacts(self, moved: str) -> None:
        """Lock held: a contact begins when two discs overlap, ends once 1 mm apart."""
        reach = 2 * footprint_radius_m()
        mine = self._truth[moved]
        for other, theirs in self._truth.items():
            if other == moved:
                continue
            pair = (min(moved, other), max(moved, other))
            gap = math.dist((mine["x"], mine["y"]), (theirs["x"], theirs["y"])) - reach
            if gap < 0 and pair not in self._touching:
                self._touching.add(pair)
                self.cart_contacts += 1
                self.contact_log.append({"carts": list(pair), "t": mine.get("t"), "gap_m": round(gap, 4)})
            elif gap > CONTACT_RELEASE_M:
                self._touching.discard(pair)

    def boxes_for(self, name: str) -> list[Box]:
        """The other carts, as `name`'s simulator holds them."""
        side, height = 2 * footprint_radius_m(), float(robot()["camera"]["height_m"])
        with self._lock:
            poses = {n: (t["x"], t["y"]) for n, t in self._truth.items() if n != name}
        return [Box(x, y, side, side, height, self.colours[n], f"cart:{n}") for n, (x, y) in poses.items()]

    def _couple(self) -> None:
        while not self._stop.wait(1.0 / COUPLING_HZ):
            for name, sim in self.sims.items():
                boxes = self.boxes_for(name)
                if boxes and sim.running():
                    with contextlib.suppress(SimulatorError, OSError):
                        sim.add_boxes(boxes)  # same ids: each replaces the box it was

    def view(self) -> dict[str, Any]:
        """The ground truth of every cart, and the contacts between them."""
        keys = ("t", "x", "y", "theta", "v", "collisions", "wall_contacts", "box_contacts", "rtf")
        with self._lock:
            carts = {n: {k: t.get(k) for k in keys} for n, t in self._truth.items()}
            return {
                "carts": carts,
                "cart_contacts": self.cart_contacts,
                "touching": [list(p) for p in sorted(self._touching)],
            }
