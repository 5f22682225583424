"""The map: its grid, obstacles and floor plan; the user's obstacles."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, Response

from cart2d.server.answers import MapOut
from cart2d.server.deps import GatewayDep, Guarded, SourceDep
from cart2d.server.models import ObstacleIn, ObstaclesClearedOut, errors

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.get(
    "/api/map",
    summary="grid, obstacles (metres), the floor plan if there is one, and the cart's footprint",
    description="`version` counts the map's changes (also sent on /ws as messages of type map); "
    "`floor_plan.image` is the plan as a PNG (GET it).",
    response_model=MapOut,
)
def get_map(source: SourceDep) -> dict[str, Any]:
    return source.map_view()


@router.get(
    "/api/map/image",
    summary="the floor plan as a PNG: map_server's trinary grey levels, the top row the highest y",
    responses={**errors(404, 422), 200: {"content": {"image/png": {}}}},
    response_class=Response,
)
def map_image(
    source: SourceDep,
    version: Annotated[
        int | None,
        Query(
            description="the map's version the plan is of, as /api/map's `floor_plan.image` names it "
            "(a replay's plans differ by it; a live gateway has its current one only)"
        ),
    ] = None,
) -> Response:
    png = source.floor_plan_png(version)
    if png is None:
        raise HTTPException(404, "the map has no floor plan: it is a grid of nodes")
    return Response(png, media_type="image/png", headers={"Cache-Control": "no-cache"})


@router.put(
    "/api/map/obstacle",
    dependencies=[Guarded],
    summary="add or remove the obstacle nearest (x, y)",
    responses=errors(400, 401, 422),
    response_model=MapOut,
)
def obstacle(body: ObstacleIn, gateway: GatewayDep) -> dict[str, Any]:
    return gateway.set_obstacle(body.x, body.y, body.present)


@router.delete(
    "/api/map/obstacles",
    dependencies=[Guarded],
    response_model=ObstaclesClearedOut,
    summary="remove every obstacle the user put on the map (the floor plan's walls stay)",
    description="A mission in progress drives on (nothing it avoided blocks it now).",
    responses=errors(401),
)
def clear_obstacles(gateway: GatewayDep) -> ObstaclesClearedOut:
    removed, version = gateway.clear_obstacles()
    return ObstaclesClearedOut(removed=[[x, y] for x, y in removed], version=version)
