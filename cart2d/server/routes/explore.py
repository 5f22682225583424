"""POST /api/explore starts exploration (issue 26), POST /api/stop ends it as every motion;
GET /api/explore is its progress, as the `exploration` /ws message has it."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from cart2d.gateway.exploration_service import DEFAULT_NAME
from cart2d.gateway.map_saving import NAME
from cart2d.gateway.messages import ExplorationMessage
from cart2d.server.deps import GatewayDep, Guarded
from cart2d.server.models import errors

router = APIRouter(responses=errors(413))


class ExploreIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    save: str = Field(
        DEFAULT_NAME,
        pattern=NAME.pattern,
        description="the name the map is saved as at the end (maps/NAME.yaml + NAME.pgm)",
    )


@router.post(
    "/api/explore",
    dependencies=[Guarded],
    status_code=202,
    summary="explore: drive to frontiers of what the camera has seen until none can be reached",
    description='Body: {} or {"save": NAME}. Starts and answers at once; POST /api/stop ends '
    "it. The map is saved at the end (also after a stop). 409 without a camera and perception, "
    "while a mission runs or the cart explores already.",
    responses=errors(400, 401, 409, 422),
    response_model=ExplorationMessage,
)
def explore(body: ExploreIn, gateway: GatewayDep) -> dict[str, Any]:
    try:
        return gateway.exploration.start(body.save)  # ExplorationRefused: 409 (app.py)
    except ValueError as exc:
        raise HTTPException(400, str(exc)) from None


@router.get(
    "/api/explore",
    summary="exploration's progress: floor seen, frontiers left and set aside, time, its end",
    response_model=ExplorationMessage,
)
def exploration(gateway: GatewayDep) -> dict[str, Any]:
    return gateway.exploration.view()
