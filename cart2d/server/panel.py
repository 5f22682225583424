"""The control panel's files (web/, built by `make panel` into cart2d/panel/), served at / after
the API, or a minimal page when the panel is not built."""

from __future__ import annotations

from pathlib import Path

from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import JSONResponse
from starlette.routing import BaseRoute, Match, Mount
from starlette.staticfiles import StaticFiles
from starlette.types import Receive, Scope, Send
from starlette.websockets import WebSocketClose

PANEL_DIR = Path(__file__).resolve().parent.parent / "panel"  # the built control panel

MINIMAL_PAGE = """<!doctype html><html><head><meta charset="utf-8"><title>cart2d</title>
<meta name="viewport" content="width=device-width, initial-scale=1"></head>
<body style="font-family: sans-serif; max-width: 40em; margin: 2em auto">
<h1>cart2d gateway</h1>
<p>The control panel is on its way. Meanwhile the API is live:
<a href="/docs">interactive API documentation</a>, <a href="/openapi.json">OpenAPI schema</a>.</p>
<pre id="status">loading status...</pre>
<script>
async function refresh() {
  const r = await fetch('/api/status');
  document.getElementById('status').textContent = JSON.stringify(await r.json(), null, 2);
}
refresh(); setInterval(refresh, 1000);
</script></body></html>
"""


FLEET_PAGES = ("/fleet.html", "/fleet")  # built with the panel (web/fleet.html), served by `cart2d fleet`


class PanelFiles(StaticFiles):
    """The panel's files, mounted at / after the API. The API keeps its own answers: a wrong
    method on an API path is a 405 with its Allow (not a missing file), an unknown /api/ path a
    404, a WebSocket to any path but /ws is closed."""

    def __init__(self, *, directory: Path, api_routes: list[BaseRoute]) -> None:
        super().__init__(directory=directory, html=True)
        self.api_routes = api_routes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await WebSocketClose()(scope, receive, send)
            return
        routes = [r for r in self.api_routes if not isinstance(r, Mount)]
        if any(route.matches(scope)[0] is Match.PARTIAL for route in routes):
            raise StarletteHTTPException(405)  # the app's handler lists the allowed methods
        path: str = scope["path"]
        if path == "/api" or path.startswith("/api/") or path in FLEET_PAGES:
            raise StarletteHTTPException(404)  # the fleet page is the fleet manager's, not a cart's
        if scope["method"] not in ("GET", "HEAD"):
            response = JSONResponse({"detail": "Method Not Allowed"}, 405, headers={"Allow": "GET, HEAD"})
            await response(scope, receive, send)
            return
        await super().__call__(scope, receive, send)
