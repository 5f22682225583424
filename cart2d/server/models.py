"""What the API takes and answers: the request bodies (strict: no coercion, bounded numbers and
arrays, known names), the error body and the OpenAPI error responses."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field, JsonValue, field_validator

from cart2d.link.protocol import MAX_ARGS
from cart2d.maps import MAX_RESOLUTION_M, MIN_RESOLUTION_M
from cart2d.shown import error_sentences, quoted
from cart2d.spec import load_spec
from cart2d.store import Integer, Metres, PlanningStep

MAX_BODY_BYTES = 256 * 1024  # the largest request but a map's
# A floor plan: a map upload (a 2000 x 2000 PGM is 4 MB, 5.3 MB in base64) or a settings file
# that carries one.
MAX_MAP_BODY_BYTES = 8 * 1024 * 1024
# Numbers the firmware accepts (docs/protocol.md): finite, magnitude below 2^20.
Number = Annotated[float, Field(allow_inf_nan=False, gt=-1048576.0, lt=1048576.0)]


class Strict(BaseModel):
    # strict: no coercion, so `true` is not 1.0 m/s and "1" is not a number, as the schema says
    model_config = ConfigDict(extra="forbid", strict=True)


class Problem(BaseModel):
    detail: str = Field(description="what is wrong, in a sentence")


ERRORS = {
    400: "the body is not readable (not UTF-8 JSON)",
    401: "the access token is missing or wrong (a gateway bound off loopback)",
    403: "a change from another origin or site (a web page elsewhere): refused, see SECURITY.md",
    404: "not here: the simulator's faults on a gateway that drives a real cart, or a floor plan's image "
    "while the map is a grid of nodes",
    408: "the request body did not arrive in time",
    409: "the firmware refused the command (a value out of its range, busy, wrong mode), or the gateway "
    "does not trust the pose since the controller restarted",
    413: f"the request body is over {MAX_BODY_BYTES} bytes ({MAX_MAP_BODY_BYTES} for a map or settings file)",
    415: "a change not sent with the content type its operation takes (application/json unless "
    "documented otherwise), even without a body",
    421: "the Host header does not name this gateway (DNS rebinding): refused, see SECURITY.md",
    422: "the request is invalid, or (goals, obstacles) off the map, blocked or unreachable, or (a pose) "
    "beyond the arena's walls",
    503: "the robot is not reachable (link down, no reply)",
}


async def read_body(request: Request, limit: int = MAX_BODY_BYTES) -> bytes:
    """The request's body, or 413 when over `limit` (a chunked body has no Content-Length)."""
    body = await request.body()
    if len(body) > limit:
        raise HTTPException(413, f"request body over {limit} bytes")
    return body


def errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI `responses` for the error statuses an operation can answer, all {"detail": str}."""
    return {code: {"model": Problem, "description": ERRORS[code]} for code in codes}


# The commands of the generic form (codes 0..2 are reply statuses), without the COMMAND_ prefix.
COMMAND_NAMES = sorted(c.name.removeprefix("COMMAND_") for c in load_spec().commands.values() if c.code > 2)
COMMAND_ENUM: list[JsonValue] = list(COMMAND_NAMES)


def inline_refs(schema: dict[str, Any]) -> dict[str, Any]:
    """A pydantic JSON schema with its $defs inlined, for an OpenAPI document of its own."""
    defs = schema.pop("$defs", {})

    def resolve(node: Any) -> Any:
        if isinstance(node, dict):
            if "$ref" in node:
                return resolve(defs[node["$ref"].rsplit("/", 1)[-1]])
            return {key: resolve(value) for key, value in node.items()}
        if isinstance(node, list):
            return [resolve(value) for value in node]
        return node

    resolved: dict[str, Any] = resolve(schema)
    return resolved


class PointIn(Strict):
    x: Number = Field(description="m")
    y: Number = Field(description="m")


class ObstacleIn(PointIn):
    present: bool = Field(True, description="true adds the obstacle at the nearest node, false removes it")


class ObstaclesClearedOut(BaseModel):
    """What DELETE /api/map/obstacles did: enough to put them back (PUT /api/map/obstacle each)."""

    removed: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(
        description="the obstacles taken away: their nodes [x, y], m"
    )
    version: int = Field(description="the map's version now (GET /api/map; /ws tells it as type map)")


class CommandIn(Strict):
    name: str = Field(
        description="a command of docs/protocol.md, e.g. POSE or GOTO",
        json_schema_extra={"enum": COMMAND_ENUM},
    )
    args: list[Number] = Field(default_factory=list, max_length=MAX_ARGS)

    @field_validator("name")
    @classmethod
    def known_command(cls, name: str) -> str:
        if name not in COMMAND_NAMES:
            raise ValueError(f"unknown command {quoted(name)}; GET /api/protocol lists them")
        return name


class PoseIn(Strict):
    x: Number = Field(description="m")
    y: Number = Field(description="m")
    theta: float = Field(
        allow_inf_nan=False, ge=-100.0, le=100.0, description="heading, rad (wrapped into [-pi, pi])"
    )


class DriveIn(Strict):
    v: Number = Field(description="linear speed, m/s")
    omega: Number = Field(description="angular speed, rad/s")


class SettingIn(Strict):
    id: Integer = Field(ge=0, le=255, description="stable setting id (config/robot.toml)")
    value: Number


class MapFieldsIn(Strict):
    """A floor plan's fields but its image (POST /api/map, as JSON or multipart/form-data)."""

    yaml: str | None = Field(
        None,
        max_length=64 * 1024,
        description="the map_server .yaml's text (resolution, origin, negate, occupied_thresh, free_thresh, "
        "mode trinary); its `image` names the file sent as `image`. Without it, `resolution_m` is needed",
    )
    name: str = Field("", max_length=200, description="a name for the map (its file name)")
    resolution_m: float | None = Field(
        None,
        ge=MIN_RESOLUTION_M,
        le=MAX_RESOLUTION_M,
        allow_inf_nan=False,
        description="a plain image's cell side, m",
    )
    origin_m: list[Metres] = Field(
        default_factory=lambda: [0.0, 0.0],
        min_length=2,
        max_length=2,
        description="[x, y]: a plain image's lower-left corner, m (the YAML gives a map_server map's)",
    )
    negate: bool = Field(False, description="a plain image: light is occupied, dark free")
    planning_step_m: PlanningStep | None = Field(
        None,
        description="plan on blocks of cells at most this wide (default: half the planning radius); a block "
        "is occupied if any of its cells is, so no obstacle is lost",
    )
    unknown_is_free: bool = Field(False, description="plan through unknown cells (default: blocked)")


async def invalid_request(_: Request, exc: RequestValidationError) -> JSONResponse:
    """A 422 with a sentence per problem, without echoing the input (NaN cannot even be written in
    JSON): the apps' handler of RequestValidationError."""
    # bounded: a location holds the body's own keys, a validator's message may quote a value
    return JSONResponse({"detail": error_sentences(exc.errors(), "body", drop={"body"})}, status_code=422)


class MapUploadIn(MapFieldsIn):
    """A floor plan: a ROS map_server map (its .yaml's text and the image it names), or a plain
    image with its resolution. Up to 2000 x 2000 cells."""

    image: str = Field(
        min_length=1,
        max_length=MAX_MAP_BODY_BYTES,
        description="base64 of the image file: PNG or PGM (Netpbm's PPM and PBM are taken too, no other "
        "format); dark is occupied, light free, between unknown (map_server's trinary thresholds); at most "
        "2000 x 2000 pixels",
    )
