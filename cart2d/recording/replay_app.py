"""The panel's HTTP API in replay mode: the recorded /ws messages at their pace, and what the
panel fetches besides (the map and its floor plan, the simulated world's boxes, the perceived
cells, the camera) as they were at the replay's position; a status that says it is a replay (the
panel then offers no driving); play, pause, seek and restart (POST /api/replay). Nothing else
changes anything: there is no robot behind it.

The reads are the live gateway's own routes (cart2d/server/routes: status, mission, map, its
floor plan, perception, the camera and its re-stream), answering from a RecordedSource instead of
a Gateway; every change is refused (409) with a sentence."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Annotated, Any, Literal

from fastapi import FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from pydantic import Field

from cart2d.recording.replay import Player
from cart2d.recording.replay_camera import RecordedCamera, camera_view, recorded_fps
from cart2d.server import api_docs, guards
from cart2d.server.answers import ProtocolCommandOut, ReplayOut, SettingsOut
from cart2d.server.camera import CameraWatchers
from cart2d.server.live import Viewers
from cart2d.server.models import Strict, errors, invalid_request
from cart2d.server.panel import MINIMAL_PAGE, PANEL_DIR, PanelFiles
from cart2d.server.routes import ROUTERS, source_reads

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


class RecordedSource:
    """The Source of the live routes (cart2d/server/source.py): the recorded state at the replay's
    position."""

    def __init__(self, player: Player) -> None:
        self.player = player
        self._frames = player.recorded.frames
        self._fps = round(recorded_fps(player.recorded), 2)
        self._camera = RecordedCamera(player) if self._frames else None

    def status_view(self) -> dict[str, Any]:
        return status_view(self.player)

    def status_view_unless_busy(self) -> dict[str, Any] | None:
        return self.status_view()  # the player's lock is held for a copy only

    def mission_view(self) -> dict[str, Any]:
        return self.player.mission_view()

    def map_view(self) -> dict[str, Any]:
        view = self.player.read(lambda now: now.map_view)
        if not view:
            raise HTTPException(404, "this recording holds no map")
        return view

    def floor_plan_png(self, version: int | None) -> bytes | None:
        """The plan of the map's `version` if the recording has it, else the one shown now."""
        plans = self.player.recorded.floor_plans
        shown = self.player.read(lambda now: now.map_view.get("version"))
        return plans.get(version if version in plans else shown or 0)

    def perception_view(self) -> dict[str, Any]:
        return self.player.read(lambda now: now.perception())

    def firmware_settings(self) -> list[dict[str, object]]:
        return []  # no firmware in a replay

    def camera_view(self) -> dict[str, Any]:
        return camera_view(self.player, self._frames, self._fps)

    def camera_feed(self) -> RecordedCamera | None:
        return self._camera


def add_replay_routes(app: FastAPI, player: Player, bind_host: str) -> None:
    """What a replay has and the gateway not, or answers otherwise: the replay's controls, no
    commands, where it listens, the recorded world's boxes."""
    recorded = player.recorded

    @app.get(
        "/api/replay",
        summary="the replay: file, state (waiting, playing, paused, ended), position",
        response_model=ReplayOut,
    )
    def replay() -> dict[str, Any]:
        return player.view()

    @app.post(
        "/api/replay",
        summary="play, pause, seek or restart the replay",
        description="A seek sends every viewer on /ws a `replay` message (the position, the cart's trails "
        "up to it) and the state there (map, world, mission, perceived cells, camera, pose).",
        responses=errors(400, 422),
        response_model=ReplayOut,
    )
    def control(body: ReplayIn) -> dict[str, Any]:
        _control(player, body)
        return player.view()

    @app.get("/api/protocol", summary="no commands in a replay", response_model=list[ProtocolCommandOut])
    def protocol() -> list[Any]:
        return []

    @app.get(
        "/api/settings",
        summary="where the replay listens (the panel's network form, hidden)",
        response_model=SettingsOut,
        response_model_exclude_unset=True,
    )
    def settings() -> dict[str, Any]:
        return {"network": {"host": bind_host, "port": 0}}

    @app.get(
        "/api/sim/world",
        summary="the simulated world's boxes at the replay's position (a recording of the simulator only)",
        responses=errors(404),
    )
    def sim_world() -> dict[str, Any]:
        if not recorded.simulated:
            raise HTTPException(404, NOT_SIMULATED)
        return player.read(lambda now: now.sim_world())


def create_replay_app(
    player: Player, bind_host: str = "127.0.0.1", allowed_hosts: Sequence[str] = ()
) -> FastAPI:
    app = FastAPI(title="cart2d replay", version="0.1.0", description=__doc__, docs_url=None, redoc_url=None)
    api_docs.install(app)
    app.add_exception_handler(RequestValidationError, invalid_request)  # type: ignore[arg-type]
    viewers = Viewers(player)  # the part of a Gateway the fan-out uses
    app.state.viewers = viewers
    app.state.source = RecordedSource(player)  # what the live routes read (server/deps.py)
    read_only = f"this is a replay of {player.recorded.path.name}: there is no robot, nothing can be changed"
    add_replay_routes(app, player, bind_host)
    # the live gateway's reads, answering from the recording (joined as create_app joins them)
    app.state.camera_watchers = CameraWatchers()  # the re-stream's viewers (server/camera.py)
    app.router.routes.extend(source_reads(ROUTERS))

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
