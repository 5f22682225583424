"""POST /api/map: a floor plan, as JSON (the image in base64, as the panel sends it) or as
multipart/form-data (the image a file part, as `curl -F image=@plan.pgm` sends it; the guards take
it only from the gateway's own page or with X-Cart2d-Token, SECURITY.md). Added to the app by
create_app; `guarded` is its dependency that checks the access token.

Everything long (the JSON's validation, base64, the image's decoding, the new map's planners)
runs in a worker thread: the event loop, and with it a stop, never waits for an upload."""

from __future__ import annotations

import asyncio
import base64
import binascii
import json
from collections.abc import Callable
from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.params import Depends
from pydantic import ValidationError
from starlette.datastructures import UploadFile

from cart2d.gateway import Gateway
from cart2d.maps import MapError, OccupancyMap, Thresholds, map_from_image, map_from_ros
from cart2d.server.answers import MapLoadedOut
from cart2d.server.guards import media_type
from cart2d.server.models import (
    MAX_MAP_BODY_BYTES,
    MapFieldsIn,
    MapUploadIn,
    errors,
    inline_refs,
    read_body,
)
from cart2d.shown import error_sentences, quoted

MULTIPART = "multipart/form-data"
TEXT_FIELDS = frozenset({"yaml", "name"})  # a form's other fields are JSON: 0.05, true, [1.0, 2.0]


def _form_schema() -> dict[str, Any]:
    """The multipart body's schema: the fields as in JSON (OpenAPI encodes a form's arrays, numbers
    and booleans as JSON text) and the image as a file."""
    schema = inline_refs(MapFieldsIn.model_json_schema())
    schema["properties"] = {
        "image": {
            "type": "string",
            "format": "binary",
            "description": "the image file: PNG or PGM (PPM and PBM too), at most 2000 x 2000 pixels",
        },
        **schema["properties"],
    }
    schema["required"] = ["image"]
    return schema


def add_map_upload_route(app: FastAPI, gateway: Gateway, guarded: Depends) -> None:
    @app.post(
        "/api/map",
        dependencies=[guarded],
        summary="load a floor plan (a ROS map_server .yaml and its image, or a plain image)",
        description="Up to 2000 x 2000 cells, planned on blocks of them (`planning_step_m`) so that even "
        "the largest plans in well under a second; the user's obstacles are cleared; in simulation the "
        "plan's occupied cells become the simulated walls. A mission in progress is replanned if the new "
        f"map blocks its path. The body may have up to {MAX_MAP_BODY_BYTES} bytes: JSON with the image in "
        "base64, or multipart/form-data with the image as a file part (`curl -F image=@plan.pgm -F "
        "resolution_m=0.05 -H 'X-Cart2d-Token: TOKEN'`; on loopback any token). The answer is the map "
        "(GET /api/map) and `pose_warning`: null, or a sentence when the cart's pose is off the new map's "
        "free floor (inside a wall, in unknown space, off the plan), with what to do.",
        responses=errors(400, 401, 422),
        response_model=MapLoadedOut,
        openapi_extra={
            "x-max-body-bytes": MAX_MAP_BODY_BYTES,
            "requestBody": {
                "required": True,
                "content": {
                    "application/json": {"schema": inline_refs(MapUploadIn.model_json_schema())},
                    MULTIPART: {"schema": _form_schema()},
                },
            },
        },
    )
    async def upload_map(request: Request) -> dict[str, Any]:
        parse: Callable[[], tuple[MapFieldsIn, bytes]]
        if media_type(request.headers.get("content-type")) == MULTIPART:
            parse = _form_upload(*await _form_parts(request))
        else:
            parse = _json_upload(await read_body(request, MAX_MAP_BODY_BYTES))

        def load() -> dict[str, Any]:
            upload, data = parse()
            occupancy = _occupancy(upload, data)
            return gateway.load_floor_plan(
                occupancy, upload.name, upload.planning_step_m, upload.unknown_is_free
            )

        try:
            return await asyncio.to_thread(load)
        except MapError as exc:
            raise HTTPException(422, str(exc)) from exc


def _form_upload(fields: dict[str, object], image: bytes) -> Callable[[], tuple[MapFieldsIn, bytes]]:
    """What checks a multipart upload's fields (in the worker thread)."""

    def parse() -> tuple[MapFieldsIn, bytes]:
        try:
            return MapFieldsIn.model_validate(fields), image
        except ValidationError as exc:
            raise HTTPException(422, error_sentences(exc.errors(), "body")) from None

    return parse


def _json_upload(body: bytes) -> Callable[[], tuple[MapFieldsIn, bytes]]:
    """What reads a JSON upload (in the worker thread: 8 MB of JSON and base64)."""

    def parse() -> tuple[MapFieldsIn, bytes]:
        try:
            upload = MapUploadIn.model_validate_json(body)
        except ValidationError as exc:
            raise HTTPException(422, error_sentences(exc.errors(), "body")) from None
        try:
            return upload, base64.b64decode(upload.image.encode("ascii"), validate=True)
        except (binascii.Error, UnicodeEncodeError):
            raise HTTPException(422, "image: not base64") from None

    return parse


async def _form_parts(request: Request) -> tuple[dict[str, object], bytes]:
    """The form's fields (text ones as text, the others decoded from JSON) and the image's bytes."""
    async with request.form(max_files=len(TEXT_FIELDS) + 1, max_fields=20) as form:
        items = form.multi_items()
        names = [name for name, _ in items]
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise HTTPException(422, f"give each field once, not {quoted(twice)}")
        parts = dict(items)
        image = parts.pop("image", None)
        if not isinstance(image, UploadFile):
            raise HTTPException(422, "image: send the image as a file part (curl -F image=@plan.pgm)")
        data = await image.read()
        fields: dict[str, object] = {}
        for name, value in parts.items():
            text = await _text(name, value)
            fields[name] = text if name in TEXT_FIELDS else _json_field(name, text)
        if "name" not in fields:
            fields["name"] = (image.filename or "")[:200]
        return fields, data


async def _text(name: str, value: str | UploadFile) -> str:
    if isinstance(value, str):
        return value
    try:
        return (await value.read()).decode("utf-8")
    except UnicodeDecodeError:
        raise HTTPException(422, f"{quoted(name)}: not UTF-8 text") from None


def _json_field(name: str, text: str) -> object:
    try:
        return json.loads(text)
    except (ValueError, RecursionError):  # ValueError: JSON's own errors, an integer's digits
        raise HTTPException(
            422, f"{quoted(name)}: not a JSON value (a number, true or false, [x, y])"
        ) from None


def _occupancy(upload: MapFieldsIn, image: bytes) -> OccupancyMap:
    if upload.yaml is not None:
        return map_from_ros(upload.yaml, image)
    if upload.resolution_m is None:
        raise MapError("a plain image needs resolution_m (or send its map_server yaml)")
    origin = (upload.origin_m[0], upload.origin_m[1])
    return map_from_image(image, upload.resolution_m, origin, Thresholds(negate=upload.negate))
