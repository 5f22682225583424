"""The API's routes, one module a resource; create_app includes them in this order (/ws after
the routes that the older modules add to the app, the panel's files last)."""

from collections.abc import Iterable

from fastapi import APIRouter
from fastapi.dependencies.models import Dependant
from fastapi.routing import APIRoute

from cart2d.server.deps import source_of
from cart2d.server.routes import (
    camera,
    explore,
    firmware,
    live,
    map,
    map_save,
    motion,
    perception,
    pose,
    status,
)

ROUTERS = (
    status.router,
    map.router,
    map_save.router,
    explore.router,
    motion.router,
    firmware.router,
    pose.router,
    perception.router,
    camera.router,
)
LIVE_ROUTER = live.router


def _calls(dependant: Dependant) -> set[object]:
    """Every dependency a route's handler has, those of its dependencies too."""
    return {call for sub in dependant.dependencies for call in ({sub.call} | _calls(sub))}


# What a replay's app has besides its Source (cart2d/recording/replay_app.py)
REPLAY_HAS = {source_of, camera.camera_watchers_of}


def source_reads(routers: Iterable[APIRouter]) -> list[APIRoute]:
    """The routes that read a Source and need nothing a replay lacks (no gateway, no stop, no
    token): a replay answers them too, from its recording (cart2d/recording/replay_app.py)."""
    return [
        route
        for router in routers
        for route in router.routes
        if isinstance(route, APIRoute)
        and set(route.methods or ()) <= {"GET", "HEAD"}
        and source_of in _calls(route.dependant)
        and _calls(route.dependant) <= REPLAY_HAS
    ]


__all__ = ["LIVE_ROUTER", "ROUTERS", "source_reads"]
