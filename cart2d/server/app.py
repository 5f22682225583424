"""The gateway's HTTP and WebSocket API (FastAPI), documented by its OpenAPI schema at
/openapi.json. Everything the seed's web page could do, plus live data and missions.

Inputs are validated (finite numbers within the protocol's range, bounded arrays, known names):
a bad request gets a 4xx with a message and changes nothing. Bound to anything but loopback,
every state-changing request and the WebSocket need the access token."""

from __future__ import annotations

import hmac
import logging
from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

from fastapi import Depends, FastAPI, HTTPException, Request, Response, WebSocket
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match

from cart2d.gateway import Gateway, PoseUntrusted
from cart2d.link import CommandRefused, LinkError, MotionCancelled
from cart2d.maps.ros import image_bytes
from cart2d.planning import PlanError
from cart2d.server import api_docs, guards
from cart2d.server.admin import add_admin_routes
from cart2d.server.camera import add_camera_routes
from cart2d.server.guards import is_loopback
from cart2d.server.live import Viewers
from cart2d.server.map_upload import add_map_upload_route
from cart2d.server.models import (
    CommandIn,
    DriveIn,
    ObstacleIn,
    ObstaclesClearedOut,
    PointIn,
    PoseIn,
    SettingIn,
    errors,
    invalid_request,
    read_body,
)
from cart2d.server.motion import MotionTokens, Stopper, motion_token
from cart2d.server.panel import MINIMAL_PAGE, PANEL_DIR, PanelFiles
from cart2d.server.reads import ReadsInTurn
from cart2d.server.sim_world import add_sim_world_routes
from cart2d.spec import load_spec

log = logging.getLogger(__name__)


def create_app(
    gateway: Gateway,
    bind_host: str = "127.0.0.1",
    token: str | None = None,
    allowed_hosts: Sequence[str] = (),
) -> FastAPI:
    """The API for `gateway`. Off loopback, `token` is required for changes and the WebSocket.
    Every request passes the guards first (guards.py: Host, origin, content type, body size);
    `allowed_hosts` are Host names to accept besides the gateway's own (a reverse proxy's)."""
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

    def token_ok(supplied: str | None) -> bool:
        # compared as bytes: compare_digest refuses str with non-ASCII characters (a TypeError, a 500)
        return not needs_token or (
            supplied is not None
            and token is not None
            and hmac.compare_digest(supplied.encode("utf-8", "surrogatepass"), token.encode())
        )

    async def require_token(request: Request) -> None:
        supplied = request.headers.get("x-cart2d-token")
        auth = request.headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            supplied = auth[7:]
        if not token_ok(supplied):
            raise HTTPException(
                401, "this gateway needs its access token (shown in its terminal) for changes"
            )

    Guarded = Depends(require_token)
    Motion = Depends(motion_token)  # the stop generation at the request's arrival (server/motion.py)
    stopper = Stopper(gateway.stop)
    viewers = Viewers(gateway)
    app.state.viewers = viewers  # for tests and benchmarks: the viewers and their queues

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

    @app.exception_handler(PoseUntrusted)
    async def untrusted(_: Request, exc: PoseUntrusted) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    @app.exception_handler(LinkError)
    async def link_error(_: Request, exc: LinkError) -> JSONResponse:
        return JSONResponse({"detail": f"the robot is not reachable: {exc}"}, status_code=503)

    # -- reading -----------------------------------------------------------------------------
    @app.get(
        "/api/status",
        summary="link, firmware, mission, pose",
        description="STATUS and the pose as the gateway last read them (`status_age_s`): reading this "
        "makes no request to the robot.",
    )
    async def status() -> dict[str, Any]:
        # On the event loop when the gateway's lock is free (no thread of the pool, which a
        # hundred readers filled, contending for the GIL with the link's reader); else in one.
        view = gateway.status_view_unless_busy()
        return view if view is not None else await run_in_threadpool(gateway.status_view)

    @app.get("/api/protocol", summary="the commands the generic-command form offers")
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

    @app.get(
        "/api/map",
        summary="grid, obstacles (metres), the floor plan if there is one, and the cart's footprint",
        description="`version` counts the map's changes (also sent on /ws as messages of type map); "
        "`floor_plan.image` is the plan as a PNG (GET it).",
    )
    def get_map() -> dict[str, Any]:
        return gateway.map_view()

    @app.get(
        "/api/map/image",
        summary="the floor plan as a PNG: map_server's trinary grey levels, the top row the highest y",
        responses={**errors(404), 200: {"content": {"image/png": {}}}},
        response_class=Response,
    )
    def map_image() -> Response:
        plan = gateway.floor_plan()
        if plan is None:
            raise HTTPException(404, "the map has no floor plan: it is a grid of nodes")
        return Response(
            image_bytes(plan, ".png"), media_type="image/png", headers={"Cache-Control": "no-cache"}
        )

    @app.get("/api/mission", summary="idle / driving / arrived / failed, with the planned path")
    def mission() -> dict[str, Any]:
        return gateway.mission_view()

    @app.get(
        "/api/firmware/settings",
        summary="every firmware setting: id, name, unit, range, value",
        responses=errors(409, 503),
    )
    def firmware_settings() -> list[dict[str, object]]:
        return gateway.firmware_settings()

    # -- changing ----------------------------------------------------------------------------
    @app.post(
        "/api/command",
        dependencies=[Guarded],
        summary="any protocol command and its reply",
        responses=errors(400, 401, 422, 503),
    )
    def command(body: CommandIn, token: int | None = Motion) -> dict[str, Any]:
        entry = load_spec().commands[f"COMMAND_{body.name}"]
        reply = gateway.command(entry.code, body.args, token)
        return {
            "command": entry.name,
            "status": ["CONTROL_OK", "CONTROL_ERROR", "CONTROL_INVALID_COM"][reply.status],
            "results": list(reply.results),
            "message": "" if reply.ok else reply.describe_error(),
        }

    @app.put(
        "/api/map/obstacle",
        dependencies=[Guarded],
        summary="add or remove the obstacle nearest (x, y)",
        responses=errors(400, 401, 422),
    )
    def obstacle(body: ObstacleIn) -> dict[str, Any]:
        return gateway.set_obstacle(body.x, body.y, body.present)

    @app.delete(
        "/api/map/obstacles",
        dependencies=[Guarded],
        response_model=ObstaclesClearedOut,
        summary="remove every obstacle the user put on the map (the floor plan's walls stay)",
        description="A mission in progress drives on (nothing it avoided blocks it now).",
        responses=errors(401),
    )
    def clear_obstacles() -> ObstaclesClearedOut:
        removed, version = gateway.clear_obstacles()
        return ObstaclesClearedOut(removed=[[x, y] for x, y in removed], version=version)

    @app.post(
        "/api/goto",
        dependencies=[Guarded],
        summary="plan from the measured pose and drive there",
        description="Refused with 409 while the gateway does not trust the pose (after the controller "
        "restarted, see /api/status `pose_trust`), until the pose is set, the reset routine has run or "
        "the firmware's pose is accepted (POST /api/pose, /api/pose/reset-routine, /api/pose/accept).",
        responses=errors(400, 401, 409, 422, 503),
    )
    def goto(body: PointIn, token: int | None = Motion) -> dict[str, Any]:
        return gateway.plan_view(gateway.go_to(body.x, body.y, token))

    @app.post(
        "/api/stop",
        summary="emergency stop: motors off now",
        description='Needs no token (SECURITY.md, "The stop needs no token"): anyone who can reach the '
        "panel may stop the cart, never start it. Runs in threads of its own, ahead of every other "
        "request on the link.",
        responses=errors(409, 503),
    )
    async def stop() -> dict[str, str]:
        await stopper()
        return {"result": "stopped"}

    @app.post(
        "/api/drive",
        dependencies=[Guarded],
        summary="manual driving; repeat within 0.5 s or it stops",
        responses=errors(400, 401, 409, 422, 503),
    )
    def drive(body: DriveIn, token: int | None = Motion) -> dict[str, str]:
        gateway.drive(body.v, body.omega, token)
        return {"result": "driving"}

    @app.put(
        "/api/firmware/settings",
        dependencies=[Guarded],
        summary="change one firmware setting",
        responses=errors(400, 401, 409, 422, 503),
    )
    def set_setting(body: SettingIn) -> dict[str, float]:
        return {"value": gateway.write_setting(body.id, body.value)}

    @app.post(
        "/api/firmware/save",
        dependencies=[Guarded],
        summary="firmware settings to EEPROM",
        responses=errors(401, 409, 503),
    )
    def save() -> dict[str, str]:
        gateway.save_settings()
        return {"result": "saving"}

    @app.post(
        "/api/firmware/load",
        dependencies=[Guarded],
        summary="firmware settings from EEPROM",
        responses=errors(401, 409, 503),
    )
    def load() -> dict[str, str]:
        gateway.link.call("LOAD")
        return {"result": "loaded"}

    @app.post(
        "/api/reset",
        dependencies=[Guarded],
        summary="soft reset of the MCU (REBOOT; the reset button in the simulator)",
        description="Answers once the restart has been noticed (`result` restarted, with its report), "
        "or after 5 s without (`result` resetting). The restart is reported as the gateway's doing; "
        "the pose stays trusted only if the firmware kept it (flag POSE_RESTORED).",
        responses=errors(401, 409, 503),
    )
    def reset() -> dict[str, Any]:
        report = gateway.soft_reset()
        return {"result": "restarted" if report else "resetting", "reset": asdict(report) if report else None}

    @app.post(
        "/api/pose",
        dependencies=[Guarded],
        summary="set the odometry pose (SET_POSE): where the cart really is; the pose is trusted again",
        responses=errors(400, 401, 409, 422, 503),
    )
    def set_pose(body: PoseIn) -> dict[str, Any]:
        pose = gateway.set_pose(body.x, body.y, body.theta)
        return {"result": "pose set", "pose": pose}

    @app.post(
        "/api/pose/accept",
        dependencies=[Guarded],
        summary="trust the pose the firmware has (after a restart: kept from RAM, or from (0, 0, 0))",
        responses=errors(401, 409, 503),
    )
    def accept_pose() -> dict[str, Any]:
        pose, words = gateway.accept_pose()
        return {"result": "accepted", "pose": pose, "words": words}

    @app.post(
        "/api/pose/reset-routine",
        dependencies=[Guarded],
        status_code=202,
        summary="run the reset routine: square up against the wall in front; the pose is trusted again "
        "once it ends squared up",
        description="Follow it in /api/status `routine` (running / done / failed, with words) or on /ws "
        "(messages of type routine and pose_trust). Any mission in progress ends.",
        responses=errors(401, 409, 503),
    )
    def reset_routine(token: int | None = Motion) -> dict[str, Any]:
        gateway.start_reset_routine(token)
        return {"result": "running", "routine": gateway.routine_view()}

    @app.post(
        "/api/firmware/update",
        dependencies=[Guarded],
        status_code=202,
        summary="upload an Intel HEX file: avrdude flashes it through the Nano's bootloader (simulated too)",
        description="409 with a sentence saying what to do when nothing can flash the robot on this link "
        "(rfc2217://, which avrdude does not speak; a simulator started with --no-bootloader) or an update "
        "is already running; 422 when the file is refused.",
        responses=errors(401, 409, 422),
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
            }
        },
    )
    async def update_firmware(request: Request) -> dict[str, object]:
        body = await read_body(request)
        try:
            return gateway.flasher.start(body).view()
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc
        except RuntimeError as exc:
            raise HTTPException(409, str(exc)) from exc

    @app.get("/api/firmware/update", summary="the firmware update's state and log")
    def update_state() -> dict[str, object]:
        return gateway.flasher.job.view()

    add_admin_routes(app, gateway, Guarded)
    add_map_upload_route(app, gateway, Guarded)
    add_camera_routes(app, gateway, Guarded)
    add_sim_world_routes(app, gateway, Guarded)

    # -- live data ---------------------------------------------------------------------------
    @app.websocket("/ws")
    async def live(ws: WebSocket) -> None:
        origin = ws.headers.get("origin")
        host = ws.headers.get("host", "")
        if origin is not None and origin.split("://", 1)[-1] != host:
            await ws.close(code=1008, reason="cross-origin WebSocket refused")
            return
        if not token_ok(ws.query_params.get("token")):
            await ws.close(code=1008, reason="this gateway needs its access token")
            return
        await ws.accept()
        await viewers.serve(ws)

    if (PANEL_DIR / "index.html").is_file():
        # mounted last: /api/..., /ws and /docs match first; everything else is the panel's files
        app.mount("/", PanelFiles(directory=PANEL_DIR, api_routes=app.router.routes), name="panel")
    else:

        @app.get("/", response_class=HTMLResponse, include_in_schema=False)
        def index() -> str:
            return MINIMAL_PAGE

    guards.install(app, bind_host, allowed_hosts)
    app.add_middleware(ReadsInTurn)  # outside the guards: a waiting read costs nothing (reads.py)
    app.add_middleware(MotionTokens, link=gateway.link)  # added last: the outermost layer
    return app
