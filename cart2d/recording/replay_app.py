"""The panel's HTTP API in replay mode: the recorded /ws messages at their pace, the map they
refer to, a status that says it is a replay (the panel then offers no driving), and nothing that
changes anything: there is no robot behind it."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import HTMLResponse, JSONResponse

from cart2d.recording.replay import Player
from cart2d.server import guards
from cart2d.server.live import Viewers
from cart2d.server.panel import MINIMAL_PAGE, PANEL_DIR, PanelFiles


def status_view(player: Player) -> dict[str, Any]:
    """/api/status in the shape of the gateway's, with `replay` (cart2d/recording/replay.py)."""
    return {
        "link": {
            "state": "connected",
            "port": f"replay of {player.recorded.path.name}",
            "simulated": player.truth_seen,
        },
        "firmware": None,
        "mission": player.mission_view(),
        "reset": {"last": None, "noticed": 0},
        "pose_trust": {"trusted": True, "reason": "", "how": "replay"},
        "routine": {"state": "idle", "words": ""},
        "replay": player.view(),
    }


def create_replay_app(
    player: Player, bind_host: str = "127.0.0.1", allowed_hosts: Sequence[str] = ()
) -> FastAPI:
    app = FastAPI(title="cart2d replay", version="0.1.0", description=__doc__)
    viewers = Viewers(player)  # a Source: the part of a Gateway the fan-out uses
    app.state.viewers = viewers
    read_only = f"this is a replay of {player.recorded.path.name}: there is no robot, nothing can be changed"

    @app.get("/api/status", summary="the replay's state, in the shape of the gateway's status")
    def status() -> dict[str, Any]:
        return status_view(player)

    @app.get("/api/map", summary="the recorded map at the replay's position")
    def map_view() -> dict[str, Any]:
        return player.map

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
        await viewers.serve(ws)

    if (PANEL_DIR / "index.html").is_file():
        app.mount("/", PanelFiles(directory=PANEL_DIR, api_routes=app.router.routes), name="panel")
    else:

        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            return MINIMAL_PAGE

    guards.install(app, bind_host, allowed_hosts)
    return app
