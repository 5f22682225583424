"""The API's administration routes: the gateway's settings (network, the settings file with the
firmware's tuning). Added to the app by create_app (the simulator's faults: cart2d/simulation/routes.py);
`guarded` is its dependency that checks the access token."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from fastapi import FastAPI, HTTPException, Request, Response
from fastapi.params import Depends

from cart2d.gateway import Gateway, backup
from cart2d.link import LinkError
from cart2d.server.addresses import address_problem
from cart2d.server.answers import NetworkSavedOut, SettingsImportedOut, SettingsOut
from cart2d.server.models import MAX_MAP_BODY_BYTES, errors, inline_refs, read_body
from cart2d.store import (
    GatewaySettings,
    NetworkSettings,
    SettingsFile,
    gateway_part,
    parse_settings,
)

SETTINGS_FILE_SCHEMA = inline_refs(SettingsFile.model_json_schema())  # what POST takes back


def add_admin_routes(app: FastAPI, gateway: Gateway, guarded: Depends) -> None:
    def check_address(host: str, where: str) -> None:
        problem = address_problem(host)
        if problem is not None:
            raise HTTPException(422, f"{where}: {problem}")

    @app.get(
        "/api/settings",
        summary="the gateway's own settings (network, map), without the token",
        response_model=SettingsOut,
        response_model_exclude_unset=True,
    )
    def gateway_settings() -> dict[str, Any]:
        return gateway.settings.model_dump(exclude={"token"})

    @app.put(
        "/api/settings/network",
        dependencies=[guarded],
        summary="bind address and port (at restart)",
        description="Refused (422) for an address this machine does not have; 0.0.0.0 and :: are every "
        "interface, 127.0.0.1 this machine alone.",
        responses=errors(400, 401, 422),
        response_model=NetworkSavedOut,
    )
    def network(body: NetworkSettings) -> dict[str, Any]:
        check_address(body.host, "host")
        gateway.update_settings(gateway.settings.model_copy(update={"network": body}))
        return {"result": "saved; takes effect when the gateway restarts", **body.model_dump()}

    @app.get(
        "/api/settings/file",
        summary="download the settings file: JSON of the gateway's network and map, and the firmware's "
        "settings (its tuning) when the firmware answers",
        response_class=Response,
        # the file POST takes back, whose request body gives its schema: as a response's, its map's
        # tuples (prefixItems) are refused by OpenAPI validators (schemathesis)
        responses={200: {"content": {"application/json": {}}}},
    )
    def export_settings() -> Response:
        data = gateway.settings.model_dump(mode="json", exclude={"token"})
        firmware = backup.section(gateway)
        if firmware is not None:
            data["firmware"] = firmware
        text = json.dumps(data, indent=2)
        headers = {"Content-Disposition": 'attachment; filename="cart2d-settings.json"'}
        return Response(text, media_type="application/json", headers=headers)

    @app.post(
        "/api/settings/file",
        dependencies=[guarded],
        summary="upload a settings file: the gateway's settings, and the firmware's written back",
        description="Checked whole first (nothing changes on a 4xx). The firmware's settings, if the file "
        "has them, are written with PARAM_SET (in RAM: POST /api/firmware/save keeps them); the answer's "
        "`firmware` says what changed. A file without them leaves the firmware's as they are.",
        responses=errors(401, 422, 503),
        openapi_extra={
            "x-max-body-bytes": MAX_MAP_BODY_BYTES,  # it may carry a floor plan
            "requestBody": {
                "required": True,
                "content": {"application/json": {"schema": SETTINGS_FILE_SCHEMA}},
            },
        },
        response_model=SettingsImportedOut,
    )
    async def import_settings(request: Request) -> dict[str, Any]:
        body = await read_body(request, MAX_MAP_BODY_BYTES)

        def check() -> tuple[GatewaySettings, backup.RestorePlan | None]:
            """The file checked whole (a second for a 2000 x 2000 plan's obstacles: off the event
            loop, as everything after it: a stop never waits for an import)."""
            try:
                file = parse_settings(body)
            except ValueError as exc:
                raise HTTPException(422, str(exc)) from exc
            todo = None
            if file.firmware is not None:
                todo, problems = backup.plan(file.firmware)
                if problems:
                    raise HTTPException(422, "invalid settings file: " + "; ".join(problems))
            problem = address_problem(file.network.host)  # a name may ask DNS
            if problem is not None:
                raise HTTPException(422, f"invalid settings file: network.host: {problem}")
            return gateway_part(file).model_copy(update={"token": gateway.settings.token}), todo

        imported, todo = await asyncio.to_thread(check)

        def apply() -> dict[str, Any] | None:
            if todo is not None:
                gateway.firmware_settings()  # the firmware answers (LinkError: 503) before anything changes
            gateway.update_settings(imported)  # PlanError: obstacles off the file's own grid
            return backup.restore(gateway, todo) if todo is not None else None

        try:
            # a new planner for the map: up to half a second for a 1000 x 1000 grid, so off the event loop
            restored = await asyncio.to_thread(apply)
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc
        except LinkError as exc:
            raise HTTPException(503, f"the robot is not reachable, its settings not restored: {exc}") from exc
        words = (
            restored.pop("words")
            if restored is not None
            else "The file holds no firmware settings: the firmware's were left as they are."
        )
        return {
            "result": "imported; network changes take effect when the gateway restarts",
            "firmware": restored,
            "words": words,
        }
