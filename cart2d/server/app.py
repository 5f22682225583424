"""The gateway's HTTP and WebSocket API (FastAPI), documented by its OpenAPI schema at
/openapi.json. Everything the seed's web page could do, plus live data and missions.

Inputs are validated (finite numbers within the protocol's range, bounded arrays, known names):
a bad request gets a 4xx with a message and changes nothing. Bound to anything but loopback,
every state-changing request and the WebSocket need the access token."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

from fastapi import FastAPI, HTTPException, Request, Response
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.params import Depends
from fastapi.responses import HTMLResponse, JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from cart2d.gateway import Gateway, Refused
from cart2d.link import CommandRefused, LinkError, MotionCancelled
from cart2d.planning import PlanError
from cart2d.server import api_docs, guards
from cart2d.server.admin import add_admin_routes
from cart2d.server.camera import CameraWatchers
from cart2d.server.deps import AccessToken, Guarded
from cart2d.server.guards import is_loopback
from cart2d.server.live import Viewers
from cart2d.server.map_upload import add_map_upload_route
from cart2d.server.models import errors, invalid_request
from cart2d.server.motion import MotionTokens, Stopper
from cart2d.server.panel import MINIMAL_PAGE, PANEL_DIR, PanelFiles
from cart2d.server.reads import ReadsInTurn
from cart2d.server.routes import LIVE_ROUTER, ROUTERS

log = logging.getLogger(__name__)

AddRoutes = Callable[[FastAPI, Depends], None]  # adds routes to the app, given the token's check
NO_SIMULATOR = "there is no simulator: this gateway drives a real cart; {what} exist only in simulation"


def create_app(
    gateway: Gateway,
    bind_host: str = "127.0.0.1",
    token: str | None = None,
    allowed_hosts: Sequence[str] = (),
    simulation: AddRoutes | None = None,
) -> FastAPI:
    """The API for `gateway`. Off loopback, `token` is required for changes and the WebSocket.
    Every request passes the guards first (guards.py: Host, origin, content type, body size);
    `allowed_hosts` are Host names to accept besides the gateway's own (a reverse proxy's).
    `simulation` adds the simulator's routes under /api/sim/ (the simulation package's wiring,
    cart2d/simulation/wiring.py); without, they answer 404 with a sentence."""
    needs_token = not is_loopback(bind_host)
    if needs_token and not token:
        raise ValueError("a token is required when the gateway is not bound to loopback")
    app = FastAPI(
        title="cart2d gateway",
        version="0.1.0",
        description=__doc__,
        responses=errors(413),
        docs_url=None,  # api_docs serves them from a packaged copy, not a CDN
        redoc_url=None,
    )
    api_docs.install(app)

    app.state.gateway = gateway  # for the routes' dependencies (deps.py)
    app.state.source = gateway  # what the reading routes answer from (source.py)
    app.state.access = AccessToken(token, needs_token)
    app.state.stopper = Stopper(gateway.stop)
    app.state.camera_watchers = CameraWatchers()  # the camera's re-stream (camera.py); for tests too
    app.state.viewers = Viewers(gateway)  # for /ws, tests and benchmarks: the viewers and their queues

    app.add_exception_handler(RequestValidationError, invalid_request)  # type: ignore[arg-type]

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> Response:
        if exc.status_code == 405:
            # Starlette's Allow names the methods of the first route on the path only (GET for
            # /api/settings/file); RFC 9110 wants every method the resource supports.
            methods = {
                method
                for route in app.router.routes
                if route.matches(request.scope)[0] is not Match.NONE
                for method in getattr(route, "methods", None) or ()
            }
            exc.headers = {**(exc.headers or {}), "Allow": ", ".join(sorted(methods))}
        return await http_exception_handler(request, exc)

    @app.exception_handler(PlanError)
    async def plan_error(_: Request, exc: PlanError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=422)

    @app.exception_handler(CommandRefused)
    async def refused(_: Request, exc: CommandRefused) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    @app.exception_handler(MotionCancelled)
    async def cancelled(_: Request, exc: MotionCancelled) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    @app.exception_handler(Refused)  # a pose untrusted, exploration busy, nothing seen to save, ...
    async def gateway_refused(_: Request, exc: Refused) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    @app.exception_handler(LinkError)
    async def link_error(_: Request, exc: LinkError) -> JSONResponse:
        return JSONResponse({"detail": f"the robot is not reachable: {exc}"}, status_code=503)

    # Their routes join the app's own list rather than through include_router: FastAPI 0.165 wraps
    # an included router in one route of its own, which the guards' route lookup (body types,
    # body limit), the 405's Allow and the panel's fallback would not see into.
    for router in ROUTERS:
        app.router.routes.extend(router.routes)
    add_admin_routes(app, gateway, Guarded)
    add_map_upload_route(app, gateway, Guarded)
    (simulation or _not_simulated)(app, Guarded)

    app.router.routes.extend(LIVE_ROUTER.routes)

    if (PANEL_DIR / "index.html").is_file():
        # mounted last: /api/..., /ws and /docs match first; everything else is the panel's files
        app.mount("/", PanelFiles(directory=PANEL_DIR, api_routes=app.router.routes), name="panel")
    else:

        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            return MINIMAL_PAGE

    guards.install(app, bind_host, allowed_hosts)
    app.add_middleware(ReadsInTurn)  # outside the guards: a waiting read costs nothing (reads.py)
    app.add_middleware(MotionTokens, token=gateway.motion_token)  # added last: the outermost layer
    return app


def _not_simulated(app: FastAPI, guarded: Depends) -> None:
    """A real cart's /api/sim/...: 404, in a sentence saying why (the panel hides what it lacks);
    a change needs the token first, as the simulation's own routes do."""

    def refuse(rest: str) -> None:
        what = "faults" if rest == "faults" else "boxes"
        raise HTTPException(404, NO_SIMULATOR.format(what=what))

    app.add_api_route("/api/sim/{rest:path}", refuse, methods=["GET"], include_in_schema=False)
    app.add_api_route(
        "/api/sim/{rest:path}",
        refuse,
        methods=["PUT", "POST", "DELETE"],
        dependencies=[guarded],
        include_in_schema=False,
    )
