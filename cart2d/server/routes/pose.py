"""The pose and the controller's restarts: soft reset, setting or accepting the pose, the reset
routine."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from fastapi import APIRouter

from cart2d.server.answers import PoseAcceptedOut, PoseSetOut, RoutineStartedOut, SoftResetOut
from cart2d.server.deps import GatewayDep, Guarded, Motion
from cart2d.server.models import PoseIn, errors

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.post(
    "/api/reset",
    dependencies=[Guarded],
    summary="soft reset of the MCU (REBOOT; the reset button in the simulator)",
    description="Answers once the restart has been noticed (`result` restarted, with its report), "
    "or after 5 s without (`result` resetting). The restart is reported as the gateway's doing; "
    "the pose stays trusted only if the firmware kept it (flag POSE_RESTORED).",
    responses=errors(401, 409, 503),
    response_model=SoftResetOut,
)
def reset(gateway: GatewayDep) -> dict[str, Any]:
    report = gateway.soft_reset()
    return {"result": "restarted" if report else "resetting", "reset": asdict(report) if report else None}


@router.post(
    "/api/pose",
    dependencies=[Guarded],
    summary="set the odometry pose (SET_POSE): where the cart really is; the pose is trusted again",
    responses=errors(400, 401, 409, 422, 503),
    response_model=PoseSetOut,
)
def set_pose(body: PoseIn, gateway: GatewayDep) -> dict[str, Any]:
    pose = gateway.set_pose(body.x, body.y, body.theta)
    return {"result": "pose set", "pose": pose}


@router.post(
    "/api/pose/accept",
    dependencies=[Guarded],
    summary="trust the pose the firmware has (after a restart: kept from RAM, or from (0, 0, 0))",
    responses=errors(401, 409, 503),
    response_model=PoseAcceptedOut,
)
def accept_pose(gateway: GatewayDep) -> dict[str, Any]:
    pose, words = gateway.accept_pose()
    return {"result": "accepted", "pose": pose, "words": words}


@router.post(
    "/api/pose/reset-routine",
    dependencies=[Guarded],
    status_code=202,
    summary="run the reset routine: square up against the wall in front; the pose is trusted again "
    "once it ends squared up",
    description="Follow it in /api/status `routine` (running / done / failed, with words) or on /ws "
    "(messages of type routine and pose_trust). Any mission in progress ends.",
    responses=errors(401, 409, 503),
    response_model=RoutineStartedOut,
)
def reset_routine(gateway: GatewayDep, token: int | None = Motion) -> dict[str, Any]:
    gateway.start_reset_routine(token)
    return {"result": "running", "routine": gateway.routine_view()}
