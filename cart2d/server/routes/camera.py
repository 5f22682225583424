"""The camera: its state, its newest frame and its re-stream to any number of panels (live, or a
replay's recorded frames: both are a Source's), and which camera to read."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from fastapi.responses import StreamingResponse

from cart2d.server.answers import CameraOut
from cart2d.server.camera import BOUNDARY, CameraWatchers, camera_errors
from cart2d.server.deps import GatewayDep, Guarded, SourceDep
from cart2d.server.models import errors
from cart2d.server.source import Camera, Source
from cart2d.store import CameraSettings

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


async def camera_watchers_of(request: Request) -> CameraWatchers:
    watchers: CameraWatchers = request.app.state.camera_watchers
    return watchers


WatchersDep = Annotated[CameraWatchers, Depends(camera_watchers_of)]


def _feed(source: Source) -> Camera:
    feed = source.camera_feed()
    if feed is None:
        raise HTTPException(404, source.camera_view()["message"])
    return feed


def _state(source: Source, watchers: CameraWatchers) -> dict[str, Any]:
    view = source.camera_view()
    feed = source.camera_feed()
    return view if feed is None else {**view, "viewers": len(watchers.of(feed).watchers)}


@router.get(
    "/api/camera",
    response_model=CameraOut,
    response_model_exclude_unset=True,  # without a camera: `camera` false and a `message` only
    summary="the camera: its stream (connected, fps, reconnects) and its frames (taken in, refused; "
    "seeing or blind, and why)",
)
def camera_state(source: SourceDep, watchers: WatchersDep) -> dict[str, Any]:
    return _state(source, watchers)


@router.get(
    "/api/camera/frame.jpg",
    summary="the newest frame, with what perception drew on it",
    responses={200: {"content": {"image/jpeg": {}}}, **camera_errors(404)},
    response_class=Response,
)
def frame(source: SourceDep) -> Response:
    shown = _feed(source).shown()
    if shown is None:
        raise HTTPException(404, "no frame from the camera yet: GET /api/camera says why")
    return Response(shown.jpeg, media_type="image/jpeg", headers={"Cache-Control": "no-store"})


@router.get(
    "/api/camera/stream",
    summary="the camera's frames as MJPEG (multipart/x-mixed-replace), for any number of viewers",
    responses={200: {"content": {"multipart/x-mixed-replace": {}}}, **camera_errors(404, 503)},
    response_class=StreamingResponse,
)
async def stream(source: SourceDep, watchers: WatchersDep) -> StreamingResponse:
    parts = await watchers.of(_feed(source)).stream()
    return StreamingResponse(
        parts,
        media_type=f"multipart/x-mixed-replace; boundary={BOUNDARY}",
        headers={"Cache-Control": "no-store"},
    )


@router.put(
    "/api/settings/camera",
    dependencies=[Guarded],
    summary="the camera to read: saved, and read from now on (null for both: no camera)",
    description="`url` is the stock CameraWebServer's base, http://HOST[:PORT] (its stream on PORT + 1); "
    "`stream_url` an MJPEG stream outright (ESPHome's esp32_camera_web_server), which wins. The command "
    "line's --camera and --camera-stream apply to their run only.",
    responses=errors(400, 401, 422),
    response_model=CameraOut,
    response_model_exclude_unset=True,
)
def set_camera(body: CameraSettings, gateway: GatewayDep, watchers: WatchersDep) -> dict[str, Any]:
    try:
        gateway.set_camera(body)
    except ValueError as exc:
        raise HTTPException(422, f"url: {exc}") from exc
    return _state(gateway, watchers)
