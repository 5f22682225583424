"""The API's routes of the simulation: the simulated world's boxes (issue 14; world.py): list
them, add some, remove one or all; and the simulator's faults (faults.py). Added to the app by
the simulation's wiring (wiring.py, create_app's `simulation`); a real cart's app answers 404
with a sentence there instead (cart2d/server/app.py). `guarded` is the app's dependency that
checks the access token."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, HTTPException
from fastapi.params import Depends
from pydantic import BaseModel, ConfigDict, Field, create_model

from cart2d.server.answers import FaultsOut
from cart2d.server.models import errors
from cart2d.shown import quoted
from cart2d.simulation import faults as fault_table
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.world import SimWorld
from cart2d.simulation.world_file import BoxSpec
from cart2d.store import Integer

MAX_BOXES_PER_REQUEST = 1000
MIN_SIZE_M = 0.01


class BoxIn(BoxSpec):
    """A mission's box (BoxSpec: within the simulator's reach), at least 1 cm across, its id fit
    for a URL path; numbers must be numbers (strict: no true for 1)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    sx: float = Field(ge=MIN_SIZE_M, le=100.0, allow_inf_nan=False)
    sy: float = Field(ge=MIN_SIZE_M, le=100.0, allow_inf_nan=False)
    id: str | None = Field(None, min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.~-]+$")


class BoxesIn(BaseModel):
    """Boxes to add: as a mission's "world" has them (x, y: centre; sx, sy: size, m; height, m;
    colour "#rrggbb"; id optional: one is given, box-N; an id already there is replaced)."""

    model_config = ConfigDict(extra="forbid")
    boxes: list[BoxIn] = Field(min_length=1, max_length=MAX_BOXES_PER_REQUEST)


def _fault_field(fault: fault_table.Fault) -> Any:
    unit = f" ({fault.unit})" if fault.unit else ""
    about = f"{fault.doc}{unit}"
    if fault.whole:
        return (Integer, Field(int(fault.default), ge=int(fault.low), le=int(fault.high), description=about))
    return (float, Field(fault.default, ge=fault.low, le=fault.high, allow_inf_nan=False, description=about))


# The faults a PUT sets: every key of cart2d/faults.py with its range; a key left out is off.
SimFaultsIn: type[BaseModel] = create_model(
    "SimFaultsIn",
    __config__=ConfigDict(extra="forbid", strict=True),
    **{fault.name: _fault_field(fault) for fault in fault_table.FAULTS},
)


def _faults_view(current: dict[str, float]) -> dict[str, Any]:
    return {
        "faults": current,
        "available": [
            {
                "name": f.name,
                "min": f.low,
                "max": f.high,
                "default": f.default,
                "unit": f.unit,
                "whole": f.whole,
                "doc": f.doc,
            }
            for f in fault_table.FAULTS
        ],
    }


def add_simulation_routes(app: FastAPI, sim: Simulator, world: SimWorld, guarded: Depends) -> None:
    add_sim_world_routes(app, world, guarded)
    add_sim_faults_routes(app, sim, guarded)


def add_sim_world_routes(app: FastAPI, world: SimWorld, guarded: Depends) -> None:
    def answer(change: Any, *args: Any) -> dict[str, Any]:
        try:
            result: dict[str, Any] = change(*args)
        except SimulatorError as exc:
            raise HTTPException(503, f"the simulator does not answer: {exc}") from exc
        return result

    @app.get(
        "/api/sim/world",
        summary="the boxes standing in the simulated world, with their ids (simulation only)",
        description="What is physically there, not the map: the planner knows a box only when the "
        "camera has seen it (or it is also an obstacle of the map).",
        responses=errors(404, 503),
    )
    def get_world() -> dict[str, Any]:
        return answer(world.view)

    @app.post(
        "/api/sim/boxes",
        dependencies=[guarded],
        summary="put boxes in the simulated world; they stay until removed, across restarts of the "
        "simulator (simulation only)",
        description="Refused whole (422) when a box would stand under the cart's true footprint. "
        "Viewers on /ws are told (`sim_world`).",
        responses=errors(400, 401, 404, 422, 503),
    )
    def add_boxes(body: BoxesIn) -> dict[str, Any]:
        try:
            return answer(world.add_boxes, [b.box() for b in body.boxes])
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc

    @app.delete(
        "/api/sim/boxes/{box_id}",
        dependencies=[guarded],
        summary="remove one box from the simulated world (simulation only)",
        responses=errors(400, 401, 404, 503),
    )
    def remove_box(box_id: str) -> dict[str, Any]:
        try:
            return answer(world.remove_box, box_id)
        except KeyError as exc:
            raise HTTPException(404, f"there is no box {quoted(box_id)} in the simulated world") from exc

    @app.delete(
        "/api/sim/boxes",
        dependencies=[guarded],
        summary="remove every box from the simulated world; the walls stay (simulation only)",
        responses=errors(400, 401, 404, 503),
    )
    def clear_boxes() -> dict[str, Any]:
        return answer(world.clear_boxes)


def add_sim_faults_routes(app: FastAPI, sim: Simulator, guarded: Depends) -> None:
    @app.get(
        "/api/sim/faults",
        summary="the simulator's faults now, and every fault with its range (simulation only)",
        responses=errors(404, 503),
        response_model=FaultsOut,
    )
    def get_faults() -> dict[str, Any]:
        try:
            return _faults_view(sim.faults())
        except SimulatorError as exc:
            raise HTTPException(503, f"the simulator does not answer: {exc}") from exc

    @app.put(
        "/api/sim/faults",
        dependencies=[guarded],
        summary="set the simulator's faults (those left out: off); they last until changed or the "
        "gateway stops (simulation only)",
        responses=errors(400, 401, 404, 422, 503),
        response_model=FaultsOut,
    )
    def put_faults(body: SimFaultsIn) -> dict[str, Any]:
        chosen = {k: float(v) for k, v in body.model_dump().items()}
        try:
            return _faults_view(sim.set_faults(chosen))
        except SimulatorError as exc:
            raise HTTPException(503, f"the simulator does not answer: {exc}") from exc
