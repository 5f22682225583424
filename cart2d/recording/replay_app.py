"""The panel's HTTP API in replay mode: the recorded /ws messages at their pace, and what the
panel fetches besides (the map and its floor plan, the simulated world's boxes, the perceived
cells, the camera) as they were at the replay's position; a status that says it is a replay (the
panel then offers no driving); play, pause, seek and restart (POST /api/replay). Nothing else
changes anything: there is no robot behind it."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Annotated, Any, Literal

from fastapi import FastAPI, HTTPException, Request, Response, WebSocket, WebSocketDisconnect
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from pydantic import Field

from cart2d.recording.replay import Player
from cart2d.recording.replay_camera import add_replay_camera_routes
from cart2d.server import api_docs, guards
from cart2d.server.live import Viewers
from cart2d.server.models import Strict, errors, invalid_request
from cart2d.server.panel import MINIMAL_PAGE, PANEL_DIR, PanelFiles

NOT_SIMULATED = "this recording is of a real cart: there is no simulated world"


class ReplayIn(Strict):
    action: Literal["play", "pause", "seek", "restart"] = Field(
        description="play (on from the position; from the start once ended), pause, seek (to "
        "position_s: the state there; a replay that played plays on) or restart (from the start)"
    )
    position_s: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] | None = Field(
        None, description="seek: where to, s from the recording's start (at most its duration_s)"
    )


def status_view(player: Player) -> dict[str, Any]:
    """/api/status in the shape of the gateway's, with `replay` (cart2d/recording/replay.py)."""
    return {
        "link": {
            "state": "connected",
            "port": f"replay of {player.recorded.path.name}",
            "simulated": player.recorded.simulated,
        },
        "firmware": None,
        "mission": player.mission_view(),
        "reset": {"last": None, "noticed": 0},
        "pose_trust": {"trusted": True, "reason": "", "how": "replay"},
        "routine": {"state": "idle", "words": ""},
        "replay": player.view(),
    }


def _control(player: Player, body: ReplayIn) -> None:
    if body.action == "seek":
        duration_s = round(player.recorded.duration_s, 3)  # as the view gives it (the slider's end)
        if body.position_s is None:
            raise HTTPException(422, "seek needs position_s: where to, in seconds from the recording's start")
        if body.position_s > duration_s:
            raise HTTPException(
                422, f"position_s {body.position_s:g} is past the recording's end ({duration_s:.3f} s)"
            )
        player.seek(body.position_s)
    elif body.position_s is not None:
        raise HTTPException(422, f"position_s goes with seek only, not with {body.action}")
    elif body.action == "play":
        player.play()
    elif body.action == "pause":
        player.pause()
    else:
        player.restart()


def add_replay_routes(app: FastAPI, player: Player) -> None:
    recorded = player.recorded

    @app.get("/api/status", summary="the replay's state, in the shape of the gateway's status")
    def status() -> dict[str, Any]:
        return status_view(player)

    @app.get("/api/replay", summary="the replay: file, state (waiting, playing, paused, ended), position")
    def replay() -> dict[str, Any]:
        return player.view()

    @app.post(
        "/api/replay",
        summary="play, pause, seek or restart the replay",
        description="A seek sends every viewer on /ws a `replay` message (the position, the cart's trails "
        "up to it) and the state there (map, world, mission, perceived cells, camera, pose).",
        responses=errors(400, 422),
    )
    def control(body: ReplayIn) -> dict[str, Any]:
        _control(player, body)
        return player.view()

    @app.get("/api/map", summary="the recorded map at the replay's position")
    def map_view() -> dict[str, Any]:
        return player.read(lambda now: now.map_view)

    @app.get(
        "/api/map/image",
        summary="the recorded floor plan at the replay's position as a PNG (map_server's grey levels)",
        responses={**errors(404), 200: {"content": {"image/png": {}}}},
        response_class=Response,
    )
    def map_image(version: int | None = None) -> Response:
        shown = player.read(lambda now: now.map_view.get("version"))
        png = recorded.floor_plans.get(version if version in recorded.floor_plans else shown or 0)
        if png is None:
            raise HTTPException(
                404, "the recorded map has no floor plan at this point: it is a grid of nodes"
            )
        return Response(png, media_type="image/png", headers={"Cache-Control": "no-cache"})

    @app.get(
        "/api/sim/world",
        summary="the simulated world's boxes at the replay's position (a recording of the simulator only)",
        responses=errors(404),
    )
    def sim_world() -> dict[str, Any]:
        if not recorded.simulated:
            raise HTTPException(404, NOT_SIMULATED)
        return player.read(lambda now: now.sim_world())

    @app.get("/api/perception", summary="the perceived cells at the replay's position")
    def perception() -> dict[str, Any]:
        return player.read(lambda now: now.perception())

    add_replay_camera_routes(app, player)


def create_replay_app(
    player: Player, bind_host: str = "127.0.0.1", allowed_hosts: Sequence[str] = ()
) -> FastAPI:
    app = FastAPI(title="cart2d replay", version="0.1.0", description=__doc__, docs_url=None, redoc_url=None)
    api_docs.install(app)
    app.add_exception_handler(RequestValidationError, invalid_request)  # type: ignore[arg-type]
    viewers = Viewers(player)  # a Source: the part of a Gateway the fan-out uses
    app.state.viewers = viewers
    read_only = f"this is a replay of {player.recorded.path.name}: there is no robot, nothing can be changed"
    add_replay_routes(app, player)

    @app.get("/api/protocol", summary="no commands in a replay")
    def protocol() -> list[Any]:
        return []

    @app.get("/api/settings", summary="where the replay listens (the panel's network form, hidden)")
    def settings() -> dict[str, Any]:
        return {"network": {"host": bind_host, "port": 0}}

    @app.get("/api/firmware/settings", summary="no firmware in a replay")
    def firmware_settings() -> list[Any]:
        return []

    @app.api_route(
        "/api/{rest:path}",
        methods=["GET", "POST", "PUT", "DELETE", "PATCH"],
        summary="the rest of the gateway's API: not in a replay (a change is refused)",
        include_in_schema=False,  # one route for every method: not an operation of its own
    )
    def refuse(rest: str, request: Request) -> JSONResponse:
        if request.method == "GET":
            return JSONResponse({"detail": f"/api/{rest} is not part of a replay"}, status_code=404)
        return JSONResponse({"detail": read_only}, status_code=409)

    @app.websocket("/ws")
    async def live(ws: WebSocket) -> None:
        origin = ws.headers.get("origin")
        if origin is not None and origin.split("://", 1)[-1] != ws.headers.get("host", ""):
            await ws.close(code=1008, reason="cross-origin WebSocket refused")
            return
        await ws.accept()
        try:  # a panel that opens late sees the world as it is now: one frame before the hello
            await ws.send_text(json.dumps(player.snapshot()))
        except (WebSocketDisconnect, RuntimeError, OSError):
            return  # gone already
        await viewers.serve(ws)

    if (PANEL_DIR / "index.html").is_file():
        app.mount("/", PanelFiles(directory=PANEL_DIR, api_routes=app.router.routes), name="panel")
    else:

        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            return MINIMAL_PAGE

    guards.install(app, bind_host, allowed_hosts)
    return app
