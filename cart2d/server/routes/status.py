"""Reading the gateway's state: status, the protocol's commands, the mission."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from starlette.concurrency import run_in_threadpool

from cart2d.server.deps import GatewayDep
from cart2d.server.models import errors
from cart2d.spec import load_spec

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.get(
    "/api/status",
    summary="link, firmware, mission, pose",
    description="STATUS and the pose as the gateway last read them (`status_age_s`): reading this "
    "makes no request to the robot.",
)
async def status(gateway: GatewayDep) -> dict[str, Any]:
    # On the event loop when the gateway's lock is free (no thread of the pool, which a
    # hundred readers filled, contending for the GIL with the link's reader); else in one.
    view = gateway.status_view_unless_busy()
    return view if view is not None else await run_in_threadpool(gateway.status_view)


@router.get("/api/protocol", summary="the commands the generic-command form offers")
def protocol() -> list[dict[str, Any]]:
    spec = load_spec()
    return [
        {
            "code": c.code,
            "name": c.name.removeprefix("COMMAND_"),  # what POST /api/command takes
            "args": c.args,
            "results": c.results,
            "arg_count": c.arg_count,
        }
        for c in spec.commands.values()
        if c.code > 2
    ]


@router.get("/api/mission", summary="idle / driving / arrived / failed, with the planned path")
def mission(gateway: GatewayDep) -> dict[str, Any]:
    return gateway.mission_view()
