"""What the API answers: the response models of the routes, so that /openapi.json says what each
returns. The gateway's views are dicts; these models check them at the API's edge (an undeclared
key is refused: a view cannot drift from its documentation silently) and give the same JSON. A
key a view gives only sometimes is optional here, and the routes that answer such a view drop
unset keys (`response_model_exclude_unset`): what is absent stays absent.

Where a view is a dataclass of the gateway's turned into a dict (Version, Status, ResetReport,
SimulatorState, Replan), the dataclass itself is the model: one source of truth."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from cart2d.gateway.live_map import Replan
from cart2d.gateway.state import ResetReport, SimulatorState
from cart2d.link.firmware import Status, Version

XY = Annotated[list[float], Field(min_length=2, max_length=2, description="[x, y], m")]


class Out(BaseModel):
    # a key the view has and the model not is an error (500 in the tests), never dropped silently
    model_config = ConfigDict(extra="forbid")


class Done(Out):
    result: str = Field(description="what was done, in words")


# -- status --------------------------------------------------------------------------------------
class LinkOut(Out):
    state: Literal["connected", "reconnecting"]
    port: str = Field(description="the serial port, a simulator's address, or the replayed file")
    simulated: bool
    error: str | None = Field(None, description="why the link is down or the last read failed")


class PoseOut(Out):
    x: float = Field(description="m")
    y: float = Field(description="m")
    theta: float = Field(description="heading, rad")


class PlanOut(Out):
    start: XY
    waypoints: list[XY] = Field(description="the path the cart drives in straight lines, to the goal")
    grid_path: list[XY] = Field(description="the optimal path on the planning grid")
    length_m: float
    grid_length_m: float


class MissionOut(Out):
    state: Literal["idle", "driving", "arrived", "failed"]
    goal: XY | None
    reason: str = Field(description="why it failed or ended, in words")
    elapsed_s: float
    plan: PlanOut | None
    replans: list[Replan]


class ResetsOut(Out):
    last: ResetReport | None = Field(description="the last restart of the controller noticed")
    noticed: int = Field(description="restarts noticed since the gateway started")


class PoseTrustOut(Out):
    trusted: bool
    reason: str = Field(description="why not, in words")
    how: str | None = Field(None, description="a replay's: the pose is the recorded one")


class RoutineOut(Out):
    state: Literal["idle", "running", "done", "failed"]
    words: str


class ReplayOut(Out):
    file: str
    state: Literal["waiting", "playing", "paused", "ended"]
    position_s: float = Field(description="s from the recording's start")
    duration_s: float
    speed: float
    loop: bool
    sent: int = Field(description="/ws messages sent")
    seeks: int
    version: int = Field(description="counts the seeks and restarts")


class StatusOut(Out):
    link: LinkOut
    firmware: Version | None
    mission: MissionOut
    simulator: SimulatorState | None = Field(None, description="simulation only")
    status: Status | None = Field(None, description="STATUS as last read (absent until read)")
    status_age_s: float | None = Field(None, description="how old `status` is, s")
    pose: PoseOut | None = Field(None, description="the pose as last read (absent until read)")
    reset: ResetsOut
    pose_trust: PoseTrustOut
    routine: RoutineOut
    replay: ReplayOut | None = Field(None, description="a replay's only")


class ProtocolCommandOut(Out):
    code: int
    name: str = Field(description="what POST /api/command takes")
    args: str
    results: str
    arg_count: int | None = Field(description="null when it varies")


# -- motion and the pose ---------------------------------------------------------------------------
class CommandOut(Out):
    command: str
    status: Literal["CONTROL_OK", "CONTROL_ERROR", "CONTROL_INVALID_COM"]
    results: list[float]
    message: str = Field(description="the firmware's error, in words; empty when OK")


class SoftResetOut(Out):
    result: Literal["restarted", "resetting"]
    reset: ResetReport | None


class PoseSetOut(Out):
    result: str
    pose: PoseOut


class PoseAcceptedOut(PoseSetOut):
    words: str = Field(description="what the accepted pose is, in words")


class RoutineStartedOut(Out):
    result: str
    routine: RoutineOut


# -- the map and perception ------------------------------------------------------------------------
class ArenaOut(Out):
    x_min: float
    y_min: float
    x_max: float
    y_max: float


class FloorPlanOut(Out):
    name: str
    origin_m: XY
    resolution_m: float
    width: int
    height: int
    cells: dict[str, int] = Field(description="how many cells are free, occupied, unknown")
    image: str = Field(description="the plan as a PNG: GET it")


class MapOut(Out):
    version: int = Field(description="counts the map's changes (/ws: messages of type map)")
    cols: int
    rows: int
    step_m: float
    origin_m: XY
    arena: ArenaOut = Field(description="where the walls around the map are, m")
    footprint_radius_m: float
    planning_radius_m: float
    obstacles: list[XY] = Field(description="the user's obstacles, their nodes")
    floor_plan: FloorPlanOut | None
    unknown_is_free: bool


class MapLoadedOut(MapOut):
    pose_warning: str | None = Field(description="why the cart's pose is off the new map's free floor")


class PerceptionOut(Out):
    enabled: bool
    resolution: float = Field(description="the cells' side, m")
    cells: list[Annotated[list[float], Field(min_length=3, max_length=3)]] = Field(
        description="[x_m, y_m, p_occupied]"
    )
    why: str | None = Field(None, description="the last change, in words")
    blocked_cells: int | None = Field(None, description="the planner's cells they block")


class CalibrationOut(Out):
    calibrated: bool
    rms_px: float | None
    views: int
    ground_rms_m: float | None
    ground_max_m: float | None
    created: str


class CameraOut(Out):
    """The camera's stream and frames; `camera` false (and `message`) when there is none."""

    camera: bool
    message: str | None = None
    url: str | None = None
    stream_url: str | None = None
    connected: bool | None = None
    fps: float | None = None
    age_s: float | None = Field(None, description="how old the newest frame taken in is, s")
    received_age_s: float | None = None
    frames: int | None = None
    recorded_frames: int | None = Field(None, description="a replay's")
    reconnects: int | None = None
    errors: int | None = None
    stale: int | None = None
    skipped_bytes: int | None = None
    clock_restarts: int | None = None
    last_error: str | None = None
    state: Literal["seeing", "blind"] | None = None
    problem: str | None = Field(None, description="why it is blind")
    worker: Literal["running", "stopped", "ended"] | None = None
    base_url: str | None = None
    decoded: int | None = None
    taken: int | None = None
    refused: int | None = None
    decode_errors: int | None = None
    processor_errors: int | None = None
    overlay_errors: int | None = None
    worker_errors: int | None = None
    skipped: int | None = None
    process_ms: float | None = None
    processors: int | None = None
    width: int | None = None
    height: int | None = None
    viewers: int | None = None
    calibration: CalibrationOut | None = None


# -- the firmware and the settings -----------------------------------------------------------------
class FirmwareSettingOut(Out):
    id: int
    name: str
    unit: str
    min: float
    max: float
    default: float
    doc: str
    value: float


class SettingValueOut(Out):
    value: float = Field(description="the value the firmware took")


class UpdateOut(Out):
    state: Literal["idle", "running", "done", "failed"]
    error: str = Field(description="why it failed, a sentence")
    log: list[str] = Field(description="avrdude's last lines")
    elapsed_s: float


class NetworkOut(Out):
    host: str = Field(description="bind address: an IP address or a host name")
    port: int


class NetworkSavedOut(NetworkOut):
    result: str


class CameraSettingsOut(Out):
    url: str | None = Field(description="the ESP32-CAM's base URL")
    stream_url: str | None = Field(description="an MJPEG stream outright")


class SettingsOut(Out):
    """The settings file's gateway part (POST /api/settings/file's schema) without the token; a
    replay's has its `network` only."""

    version: int | None = None
    network: NetworkOut
    map: dict[str, Any] | None = Field(None, description="the map as the settings file keeps it")
    camera: CameraSettingsOut | None = None


class SettingChangedOut(Out):
    id: int
    name: str
    from_: float = Field(alias="from")
    to: float


class RestoredOut(Out):
    changed: list[SettingChangedOut]
    unchanged: int
    skipped: list[str]
    refused: list[str]


class SettingsImportedOut(Out):
    result: str
    firmware: RestoredOut | None = Field(
        description="the firmware's settings written back, if the file has them"
    )
    words: str


class FaultRangeOut(Out):
    name: str
    min: float
    max: float
    default: float
    unit: str
    whole: bool
    doc: str


class FaultsOut(Out):
    faults: dict[str, float] = Field(description="the faults on now")
    available: list[FaultRangeOut]
