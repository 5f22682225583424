"""The API's routes for the simulated world's boxes (issue 14; cart2d/gateway/sim_world.py):
list them, add some, remove one or all. Simulation only: 404 on a real cart. Added to the app by
create_app; `guarded` is its dependency that checks the access token."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, HTTPException
from fastapi.params import Depends
from pydantic import BaseModel, ConfigDict, Field

from cart2d.gateway import Gateway
from cart2d.gateway.sim_world import NotSimulated
from cart2d.server.models import errors
from cart2d.shown import quoted
from cart2d.simulation.world_file import BoxSpec
from cart2d.simulator import SimulatorError

NO_SIMULATOR = "there is no simulator: this gateway drives a real cart; boxes exist only in simulation"
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


def add_sim_world_routes(app: FastAPI, gateway: Gateway, guarded: Depends) -> None:
    def answer(change: Any, *args: Any) -> dict[str, Any]:
        try:
            result: dict[str, Any] = change(*args)
        except NotSimulated as exc:
            raise HTTPException(404, NO_SIMULATOR) from exc
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
        return answer(gateway.sim_world_view)

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
            return answer(gateway.add_sim_boxes, [b.box() for b in body.boxes])
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
            return answer(gateway.remove_sim_box, box_id)
        except KeyError as exc:
            raise HTTPException(404, f"there is no box {quoted(box_id)} in the simulated world") from exc

    @app.delete(
        "/api/sim/boxes",
        dependencies=[guarded],
        summary="remove every box from the simulated world; the walls stay (simulation only)",
        responses=errors(400, 401, 404, 503),
    )
    def clear_boxes() -> dict[str, Any]:
        return answer(gateway.clear_sim_boxes)
