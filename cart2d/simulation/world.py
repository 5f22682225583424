"""The boxes of the simulated world as `cart2d sim` holds them (issue 14): placed from the
command line's --world, added and removed through the API (the panel's Box mode), and told to
/ws viewers as "sim_world" so the panel redraws them.

The simulator's options keep them (SimOptions.world, whose walls follow the map: the gateway's
map edits call `SimWorld.follow_walls`, which keeps the boxes with `with_boxes`), so a restart of
the simulator puts them back as they were, as it does the faults. The boxes are physical, not
the map: the planner does not know them until the camera sees them.

`SimWorld` is the gateway's simulated world (cart2d/gateway/collaborators.py), wired in by
wiring.py; its routes are routes.py's.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from cart2d.files import read_regular
from cart2d.gateway.bus import EventBus, ViewerMessage
from cart2d.gateway.messages import SimWorldMessage
from cart2d.maps.world import Box, World
from cart2d.params import footprint_radius_m
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.world_file import MAX_FILE_BYTES, WorldSpec, parse

BOX_ID_PREFIX = "box-"

log = logging.getLogger(__name__)


def with_boxes(walls: World, held: World | None) -> World:
    """`walls` (the map's world) with the boxes `held` has: new walls leave the boxes standing."""
    return replace(walls, boxes=held.boxes if held is not None else ())


def footprint_clearance_m(box: Box, x: float, y: float) -> float:
    """How far the edge of `box` is from the cart's footprint centred on (x, y); negative: over it."""
    dx = max(abs(x - box.x) - box.sx / 2, 0.0)
    dy = max(abs(y - box.y) - box.sy / 2, 0.0)
    return math.hypot(dx, dy) - footprint_radius_m()


def under_cart_problem(index: int, box: Box, pose: tuple[float, float]) -> str | None:
    """A sentence when `box` would stand under the cart's footprint at `pose` (x, y)."""
    if footprint_clearance_m(box, *pose) >= 0.0:
        return None
    return (
        f"boxes[{index}] at ({box.x:g}, {box.y:g}) would stand under the cart "
        f"({footprint_radius_m():g} m around its true position ({pose[0]:.2f}, {pose[1]:.2f}))"
    )


def named(boxes: Sequence[Box], taken: set[str]) -> list[Box]:
    """The boxes, each without an id given one (box-1, box-2, ...) that no other box has."""
    taken = set(taken) | {b.id for b in boxes if b.id is not None}
    numbers = (f"{BOX_ID_PREFIX}{n}" for n in itertools.count(1))
    out = []
    for box in boxes:
        if box.id is None:
            ident = next(n for n in numbers if n not in taken)
            taken.add(ident)
            box = replace(box, id=ident)
        out.append(box)
    return out


def box_view(box: dict[str, Any]) -> dict[str, Any]:
    """A box of the simulator's world_get, as the API and /ws show it."""
    keys = ("id", "x", "y", "sx", "sy", "height", "colour", "solid")
    return {key: box[key] for key in keys if key in box}


class SimWorld:
    """The simulator's boxes and walls (see the module's docstring). Viewers are told of changes
    on `bus` once tell() has given it (the gateway's, made after this)."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self._bus: EventBus | None = None

    def tell(self, bus: EventBus) -> None:
        self._bus = bus

    # -- what the gateway asks (collaborators.SimulatedWorld) ----------------------------------
    def follow_walls(self, walls: Callable[[], World]) -> None:
        """The simulator's walls follow the map (and do so again after a restart), under the
        simulator's lifecycle lock as its boxes' changes: the map it reads is the latest, whoever
        sends last."""
        sim = self.sim
        with sim.lifecycle:
            world = with_boxes(walls(), sim.options.world)  # boxes stay
            sim.options.world = world
            if sim.running():
                try:
                    sim.set_world(world)
                except SimulatorError as exc:
                    log.warning("the simulator's walls could not follow the map: %s", exc)

    def boxes_view(self) -> dict[str, Any] | None:
        try:
            return self.view()
        except SimulatorError:
            return None

    # -- what its routes ask (routes.py) ---------------------------------------------------------
    def view(self) -> dict[str, Any]:
        """The boxes the simulator holds now (SimulatorError when it does not answer)."""
        world = self.sim.world_state()
        boxes = [box_view(b) for b in world.get("boxes", []) if not b.get("obstacle", False)]
        return {"version": world.get("version"), "boxes": boxes}

    def add_boxes(self, boxes: Sequence[Box]) -> dict[str, Any]:
        """Adds `boxes` (those without an id get one; an id already there is replaced) now and at
        every restart; ValueError, nothing added, when one would stand under the cart."""
        sim = self.sim
        with sim.lifecycle:  # a restart meanwhile starts with the boxes as they end up
            truth = sim.truth()
            problems = [under_cart_problem(k, b, (truth["x"], truth["y"])) for k, b in enumerate(boxes)]
            said = [p for p in problems if p is not None]
            if said:
                raise ValueError("; ".join(said))
            held = sim.options.world or World()
            boxes = named(boxes, {b.id for b in held.boxes if b.id is not None} | self._ids_in(sim))
            sim.add_boxes(boxes)
            new_ids = {b.id for b in boxes}
            sim.options.world = replace(held, boxes=(*(b for b in held.boxes if b.id not in new_ids), *boxes))
        return self._world_changed([b.id or "" for b in boxes], "added")

    def remove_box(self, ident: str) -> dict[str, Any]:
        """Removes the box `ident` now and for restarts; KeyError when there is none."""
        sim = self.sim
        with sim.lifecycle:
            if ident not in self._ids_in(sim):
                raise KeyError(ident)
            sim.remove_boxes([ident])
            held = sim.options.world or World()
            sim.options.world = replace(held, boxes=tuple(b for b in held.boxes if b.id != ident))
        return self._world_changed([ident], "removed")

    def clear_boxes(self) -> dict[str, Any]:
        """Removes every box (the map's walls stay), now and for restarts."""
        sim = self.sim
        with sim.lifecycle:
            gone = sorted(self._ids_in(sim))
            sim.control("boxes", clear=True)
            held = sim.options.world or World()
            sim.options.world = replace(held, boxes=())
        return self._world_changed(gone, "removed")

    @staticmethod
    def _ids_in(sim: Simulator) -> set[str]:
        boxes = sim.world_state().get("boxes", [])
        return {str(b["id"]) for b in boxes if "id" in b and not b.get("obstacle", False)}

    def _world_changed(self, ids: list[str], what: str) -> dict[str, Any]:
        view = self.view()
        if self._bus is not None:
            self._bus.publish(ViewerMessage(SimWorldMessage(**view)))
        return {**view, what: ids}


def world_file_boxes(path: Path, start: tuple[float, float] = (0.0, 0.0)) -> tuple[list[Box], list[str]]:
    """The boxes of a world file (`cart2d sim --world`: a mission's "world", {"boxes": [...]}),
    each with an id, or one sentence per problem: unreadable, not JSON, a bad box, a box under the
    cart at its start."""
    boxes, _, problems = world_file(path, start)
    return boxes, problems


def world_file(
    path: Path, start: tuple[float, float] = (0.0, 0.0)
) -> tuple[list[Box], dict[str, Any] | None, list[str]]:
    """A world file's boxes (as world_file_boxes) and its "look" (None if it has none; the
    simulator checks it), or one sentence per problem."""
    try:
        data = read_regular(path, MAX_FILE_BYTES)
    except ValueError:  # a NUL in the name
        return [], None, [f"the world file {path!r} cannot be read: its name holds a NUL"]
    except FileNotFoundError:
        return [], None, [f"there is no world file {path}"]
    except IsADirectoryError:
        return [], None, [f"{path} is a folder, not a world file"]
    except OSError as exc:
        return [], None, [f"the world file {path} cannot be read: {exc.strerror or exc}"]
    spec, problems = parse(data, WorldSpec, f"the world file {path}")
    if spec is None:
        said = [p.replace("(a mission has:", "(a world has:") for p in problems]
        return [], None, [p if p.startswith("the world file") else f"{path}: {p}" for p in said]
    boxes = named([b.box() for b in spec.boxes], set())
    under = [under_cart_problem(k, b, start) for k, b in enumerate(boxes)]
    look = spec.look.message() if spec.look is not None else None
    return boxes, look, [f"{path}: {p.replace(' true ', ' start ')}" for p in under if p is not None]
