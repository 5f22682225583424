"""POST /api/map/save: what the camera has seen, written as a ROS map_server map (issue 26)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from cart2d.gateway.map_saving import NAME, checked_name, save_seen_map
from cart2d.server.deps import GatewayDep, Guarded
from cart2d.server.models import errors

router = APIRouter(responses=errors(413))


class MapSaveIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(
        pattern=NAME.pattern, description="the map's name: NAME.yaml and NAME.pgm in the maps folder"
    )


class MapSavedOut(BaseModel):
    yaml: str
    resolution_m: float
    counts: dict[str, int]


@router.post(
    "/api/map/save",
    dependencies=[Guarded],
    summary="save what the camera has seen as a ROS map_server map (NAME.yaml + NAME.pgm)",
    description="Occupied where perception believes it, free where the camera saw floor, unknown "
    "elsewhere; in the gateway's folder, maps/NAME.yaml. Load it back with POST /api/map or "
    "`cart2d sim --map FILE`.",
    responses=errors(400, 401, 409, 422),
    response_model=MapSavedOut,
)
def save_map(body: MapSaveIn, gateway: GatewayDep) -> dict[str, Any]:
    try:
        name = checked_name(body.name)
    except ValueError as exc:
        raise HTTPException(400, str(exc)) from None
    return save_seen_map(gateway.seeing, gateway.store.directory, name)  # NothingSeen: 409 (app.py)
