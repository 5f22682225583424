"""Reading the gateway's state: status, the protocol's commands, the mission."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from starlette.concurrency import run_in_threadpool

from cart2d.server.answers import MissionOut, ProtocolCommandOut, StatusOut
from cart2d.server.deps import SourceDep
from cart2d.server.models import errors
from cart2d.spec import load_spec

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.get(
    "/api/status",
    summary="link, firmware, mission, pose",
    description="STATUS and the pose as the gateway last read them (`status_age_s`): reading this "
    "makes no request to the robot.",
    response_model=StatusOut,
    response_model_exclude_unset=True,  # simulator, status, pose: absent until there is one
)
async def status(source: SourceDep) -> dict[str, Any]:
    # On the event loop when the gateway's lock is free (no thread of the pool, which a
    # hundred readers filled, contending for the GIL with the link's reader); else in one.
    view = source.status_view_unless_busy()
    return view if view is not None else await run_in_threadpool(source.status_view)


@router.get(
    "/api/protocol",
    summary="the commands the generic-command form offers",
    response_model=list[ProtocolCommandOut],
)
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


@router.get(
    "/api/mission",
    summary="idle / driving / arrived / failed, with the planned path",
    response_model=MissionOut,
)
def mission(source: SourceDep) -> dict[str, Any]:
    return source.mission_view()
