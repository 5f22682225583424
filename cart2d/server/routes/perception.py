"""Perception: whether it is on, and the perceived cells [x, y, p_occupied] that block the planner
(the camera's, or sent by perception running outside the gateway)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException
from pydantic import Field
from pydantic import Strict as StrictMark

from cart2d.gateway.perceived import DEFAULT_RESOLUTION_M, OCCUPIED_P, parse_cells
from cart2d.server.answers import PerceptionOut
from cart2d.server.deps import GatewayDep, Guarded, SourceDep
from cart2d.server.models import Strict, errors

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)

MAX_CELLS_IN = 10_000  # a request's cells (256 KiB of JSON)

# [x_m, y_m, p_occupied]: a JSON array read as a tuple (lax), of numbers taken as they are (strict)
Metres = Annotated[float, StrictMark(), Field(allow_inf_nan=False, gt=-1048576.0, lt=1048576.0)]
Occupied = Annotated[float, StrictMark(), Field(ge=OCCUPIED_P, le=1.0, allow_inf_nan=False)]
PerceivedCellIn = Annotated[tuple[Metres, Metres, Occupied], StrictMark(False)]


class PerceptionIn(Strict):
    enabled: bool | None = Field(None, description="perception on (its cells block the planner) or off")
    cells: list[PerceivedCellIn] | None = Field(
        None,
        max_length=MAX_CELLS_IN,
        description="replace the perceived cells with these [x_m, y_m, p_occupied] (p 0.5 to 1): for "
        "perception running outside the gateway, and for tests",
    )
    resolution_m: float | None = Field(
        None, ge=0.005, le=1.0, allow_inf_nan=False, description=f"cell size (default {DEFAULT_RESOLUTION_M})"
    )
    why: str = Field("perception saw obstacles", max_length=200, description="the reason a replan gives")


@router.get(
    "/api/perception",
    summary="the perceived cells [x, y, p_occupied] and whether perception is on",
    response_model=PerceptionOut,
    response_model_exclude_unset=True,  # a replay's has no why nor blocked_cells
)
def perception(source: SourceDep) -> dict[str, Any]:
    return source.perception_view()


@router.put(
    "/api/perception",
    dependencies=[Guarded],
    summary="turn perception on or off; or replace the perceived cells",
    description="Turning it off clears the perceived cells. New cells replan a mission whose path they "
    "block, as an obstacle the user puts does.",
    responses=errors(400, 401, 422),
    response_model=PerceptionOut,
)
def set_perception(body: PerceptionIn, gateway: GatewayDep) -> dict[str, Any]:
    try:
        if body.cells is not None:
            parse_cells(body.cells)  # all checked before anything changes
        if body.enabled is not None:
            gateway.set_perception_enabled(body.enabled)
        if body.cells is not None:
            gateway.set_perceived(body.cells, body.why, body.resolution_m)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from exc
    return gateway.perception_view()


@router.post(
    "/api/perception/clear",
    dependencies=[Guarded],
    summary="forget the perceived cells (the user's obstacles stay)",
    responses=errors(401),
    response_model=PerceptionOut,
)
def clear_perception(gateway: GatewayDep) -> dict[str, Any]:
    return gateway.clear_perceived("the perceived cells were cleared by the user")
