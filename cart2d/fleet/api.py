"""The fleet manager's HTTP API and its page (`cart2d fleet`, `cart2d fleet sim`): every cart on
one live map, goals dropped on it or posted, STOP ALL. The page is the control panel's fleet.html
(web/, built by `make panel` into cart2d/panel/ with its assets); its JSON is cart2d/fleet/views.py.
Its live stream, /ws, pushes the page's view as it changes (stream.py). The server's guards
(Host, origin, content type, body size: cart2d/server/guards.py) stand in front of it as of the
gateway, the WebSocket's handshake included."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, WebSocket
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles

from cart2d.fleet.manager import FleetManager
from cart2d.fleet.stream import FleetStream
from cart2d.fleet.views import (
    CartAnswer,
    FleetView,
    GoalAccepted,
    GoalRequest,
    PauseRequest,
    RemovedAnswer,
    StopAnswer,
    TruthView,
)
from cart2d.server import guards
from cart2d.server.panel import PANEL_DIR

Truth = Callable[[], dict[str, Any]]

NOT_BUILT = """<!doctype html><html><head><meta charset="utf-8"><title>cart2d fleet</title></head>
<body style="font-family: sans-serif; max-width: 40em; margin: 2em auto"><h1>cart2d fleet</h1>
<p>The fleet page is part of the control panel, which is not built here (<code>make panel</code>).
Meanwhile the API is live: <a href="/api/fleet">GET /api/fleet</a>.</p></body></html>
"""


def fleet_app(
    manager: FleetManager, bind_host: str, truth: Truth | None = None, panel: Path = PANEL_DIR
) -> FastAPI:
    """`truth`: the simulated carts' ground truth (the shared arena's view), if simulated;
    `panel`: the built control panel, whose fleet.html and assets/ are the page."""
    app = FastAPI(title="cart2d fleet", docs_url=None, redoc_url=None)
    guards.install(app, bind_host)

    @app.get("/", include_in_schema=False)
    def fleet_page() -> Response:
        page = panel / "fleet.html"
        return FileResponse(page) if page.is_file() else HTMLResponse(NOT_BUILT)

    def view() -> FleetView:
        shown = manager.view()
        if truth is not None:
            shown = shown.model_copy(update={"truth": TruthView.model_validate(truth())})
        return shown

    @app.get("/api/fleet")
    def fleet_view() -> FleetView:
        """Every cart (connection, state, pose, order, nodes held, route), the goals, the deadlocks."""
        return view()

    stream = FleetStream(view)

    @app.websocket("/ws")
    async def live(ws: WebSocket) -> None:
        """The same view, pushed as it changes (views.FleetUpdate messages: stream.py)."""
        await stream.serve(ws)

    @app.post("/api/fleet/goals", status_code=201)
    def add_goal(goal: GoalRequest) -> GoalAccepted:
        """A goal for the named cart or the nearest idle one, at the lattice node nearest (x, y)."""
        try:
            added = manager.add_goal(goal.x, goal.y, goal.cart)
        except ValueError as exc:
            raise HTTPException(400, str(exc)) from exc
        return GoalAccepted(id=added.goal_id, at=manager.lattice.position(added.cell), cart=added.cart)

    @app.post("/api/fleet/stop")
    def stop_all() -> StopAnswer:
        """STOP ALL: every gateway's own stop where it runs here, then cancelOrder to each cart."""
        manager.stop_all()
        return StopAnswer(stopped="all")

    @app.post("/api/fleet/carts/{name}/cancel")
    def cancel_order(name: str) -> CartAnswer:
        """cancelOrder to one cart: its goal cancelled; it keeps the nodes it stands on."""
        _to_cart(lambda: manager.cancel(name))
        return CartAnswer(cart=name, sent="cancelOrder")

    @app.post("/api/fleet/carts/{name}/pause")
    def pause(name: str, request: PauseRequest) -> CartAnswer:
        """startPause (paused: true) or stopPause to one cart; it keeps its order and its nodes."""
        _to_cart(lambda: manager.pause(name, request.paused))
        return CartAnswer(cart=name, sent="startPause" if request.paused else "stopPause")

    @app.delete("/api/fleet/carts/{name}")
    def remove_cart(name: str) -> RemovedAnswer:
        """Forgets a cart: the nodes an OFFLINE cart held are free again."""
        if name not in manager.carts:
            raise HTTPException(404, f"there is no cart {name!r}")
        manager.remove(name)
        return RemovedAnswer(removed=name)

    if (panel / "assets").is_dir():  # the page's scripts and styles, as the gateway serves them
        app.mount("/assets", StaticFiles(directory=panel / "assets"), name="assets")
    return app


def _to_cart(act: Callable[[], None]) -> None:
    """The manager's refusals as the API's: a cart unknown 404, one that cannot do it 409."""
    try:
        act()
    except KeyError as exc:
        raise HTTPException(404, str(exc.args[0])) from exc
    except ValueError as exc:
        raise HTTPException(409, str(exc)) from exc
