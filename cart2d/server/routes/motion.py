"""Moving the cart: any protocol command, goals, manual driving, and the stop (which needs no
token and runs in threads of its own, server/motion.py)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from cart2d.server.answers import CommandOut, Done, PlanOut
from cart2d.server.deps import GatewayDep, Guarded, Motion, StopperDep
from cart2d.server.models import CommandIn, DriveIn, PointIn, errors
from cart2d.spec import load_spec

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.post(
    "/api/command",
    dependencies=[Guarded],
    summary="any protocol command and its reply",
    responses=errors(400, 401, 422, 503),
    response_model=CommandOut,
)
def command(body: CommandIn, gateway: GatewayDep, token: int | None = Motion) -> dict[str, Any]:
    entry = load_spec().commands[f"COMMAND_{body.name}"]
    reply = gateway.command(entry.code, body.args, token)
    return {
        "command": entry.name,
        "status": ["CONTROL_OK", "CONTROL_ERROR", "CONTROL_INVALID_COM"][reply.status],
        "results": list(reply.results),
        "message": "" if reply.ok else reply.describe_error(),
    }


@router.post(
    "/api/goto",
    dependencies=[Guarded],
    summary="plan from the measured pose and drive there",
    description="Refused with 409 while the gateway does not trust the pose (after the controller "
    "restarted, see /api/status `pose_trust`), until the pose is set, the reset routine has run or "
    "the firmware's pose is accepted (POST /api/pose, /api/pose/reset-routine, /api/pose/accept).",
    responses=errors(400, 401, 409, 422, 503),
    response_model=PlanOut,
)
def goto(body: PointIn, gateway: GatewayDep, token: int | None = Motion) -> dict[str, Any]:
    return gateway.plan_view(gateway.go_to(body.x, body.y, token))


@router.post(
    "/api/stop",
    summary="emergency stop: motors off now",
    description='Needs no token (SECURITY.md, "The stop needs no token"): anyone who can reach the '
    "panel may stop the cart, never start it. Runs in threads of its own, ahead of every other "
    "request on the link.",
    responses=errors(409, 503),
)
async def stop(stopper: StopperDep) -> Done:
    await stopper()
    return Done(result="stopped")


@router.post(
    "/api/drive",
    dependencies=[Guarded],
    summary="manual driving; repeat within 0.5 s or it stops",
    responses=errors(400, 401, 409, 422, 503),
)
def drive(body: DriveIn, gateway: GatewayDep, token: int | None = Motion) -> Done:
    gateway.drive(body.v, body.omega, token)
    return Done(result="driving")
