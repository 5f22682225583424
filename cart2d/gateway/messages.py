"""The /ws messages (server/live.py; the recording's /ws channel): one discriminated union,
`LiveMessage`, tagged by `type`. The gateway publishes these models; viewers get them as JSON
(ViewerMessage.wire). The panel's TypeScript types (web/src/generated/live.ts) are generated from
the union's JSON schema (`make ws-types`), and `make test` fails when they differ, so the two
sides cannot drift apart silently.

A model refuses a field it does not declare (extra="forbid") and a number given as a string
(Number: strict). Numbers keep their JSON type (an int stays an int), so the JSON on /ws and in
recordings is what the dicts these models replaced gave. A field that was left out of a message
when it had nothing to say (a box's `solid`, a goal's `reason`) is left out still (_absent)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, TypeAdapter, WithJsonSchema

# A JSON number, kept as given (3 stays 3, not 3.0); a string or a bool is refused.
Number = Annotated[StrictInt | StrictFloat, WithJsonSchema({"type": "number"})]
Point = tuple[Number, Number]


def _absent() -> Any:
    """A field left out of the JSON when it is None (as the dicts left it out)."""
    return Field(None, exclude_if=lambda value: value is None)


def _type_first_and_required(schema: dict[str, Any]) -> None:
    """`type` has its tag as a default (a site never spells it) but is always sent: required."""
    required = [name for name in schema.get("required", []) if name != "type"]
    schema["required"] = ["type", *required]


class _Message(BaseModel):
    """A /ws message: its `type` first (each kind narrows it to its tag), as in its JSON."""

    model_config = ConfigDict(extra="forbid", frozen=True, json_schema_extra=_type_first_and_required)
    type: str


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# -- samples ------------------------------------------------------------------------------------
class TelemetryMessage(_Message):
    """A telemetry frame of the firmware (docs/protocol.md, Telemetry), with its mode and flags
    in words."""

    type: Literal["telemetry"] = "telemetry"
    x: Number
    y: Number
    theta: Number
    v_left: Number
    v_right: Number
    v_left_target: Number
    v_right_target: Number
    pwm_left: Number
    pwm_right: Number
    v: Number
    omega: Number
    v_target: Number
    omega_target: Number
    distance_to_waypoint: Number
    waypoint_index: Number
    state: Number
    tick: int
    mode_name: str
    flag_names: list[str]


class CpuLoad(_Strict):
    mean: Number
    max: Number
    ticks: int


class TruthMessage(_Message):
    """The simulator's ground truth (sim/src/truth.cpp; sim/README.md)."""

    type: Literal["truth"] = "truth"
    t: Number
    x: Number
    y: Number
    theta: Number
    v: Number
    omega: Number
    wheel_l: Number
    wheel_r: Number
    slip_l: Number
    slip_r: Number
    caster: Number
    duty_l: Number
    duty_r: Number
    current_l: Number
    current_r: Number
    switch_l: bool
    switch_r: bool
    enc_l: Number
    enc_r: Number
    collisions: int
    wall_contacts: int  # touches of a wall, and of a box the map may not know
    box_contacts: int
    in_collision: bool
    in_wall_contact: bool
    in_box_contact: bool
    boxes: int
    first_collision_t: Number | None
    first_wall_contact_t: Number | None
    cpu: CpuLoad
    rtf: Number
    mcu: str


# -- the mission --------------------------------------------------------------------------------
class PlanView(_Strict):
    start: Point
    waypoints: list[Point]
    grid_path: list[Point]
    length_m: Number
    grid_length_m: Number


class ReplanView(_Strict):
    """One replan of a mission (gateway/live_map.py, Replan)."""

    reason: str
    at_s: Number
    sim_t: Number | None
    plan_time_s: Number
    length_m: Number
    waypoints: int
    outcome: str


class _MissionView(_Message):
    """The mission (Gateway.mission_view): the first message a viewer gets (hello) and each change."""

    state: Literal["idle", "driving", "arrived", "failed"]
    goal: Point | None
    reason: str
    elapsed_s: Number
    plan: PlanView | None
    replans: list[ReplanView]


class HelloMessage(_MissionView):
    type: Literal["hello"] = "hello"


class MissionMessage(_MissionView):
    type: Literal["mission"] = "mission"


class ReplanMessage(ReplanView, _Message):
    """A mission was replanned (one of the mission's `replans`, with its `type` first)."""

    model_config = _Message.model_config
    type: Literal["replan"] = "replan"


class RoutineMessage(_Message):
    """The reset routine, squaring the cart up after a restart."""

    type: Literal["routine"] = "routine"
    state: Literal["idle", "running", "done", "failed"]
    words: str


# -- restarts and the pose's trust ----------------------------------------------------------------
class Pose(_Strict):
    x: Number
    y: Number
    theta: Number


class PoseTrustView(_Strict):
    trusted: bool
    reason: str  # why not, in words


class PoseTrustMessage(_Message):
    """The pose is trusted again (`how`, in words)."""

    type: Literal["pose_trust"] = "pose_trust"
    trusted: bool
    reason: str
    how: str


class MarkerView(_Strict):
    id: int
    size_m: Number
    x: Number
    y: Number
    yaw_deg: Number
    on: Literal["wall", "floor"]


class LocalisationMessage(_Message):
    """The pose filter (cart2d/gateway/localisation.py): the cart's pose in `map`, its
    uncertainty (the covariance of x, y and theta, row by row, m and rad), map -> odom, and the
    markers it knows (to draw)."""

    type: Literal["localisation"] = "localisation"
    trusted: bool
    pose: Pose | None
    covariance: list[Number]
    map_to_odom: Pose
    accepted: int
    doubted: int
    last: str  # the last fix, in words
    markers: list[MarkerView]


class ResetMessage(_Message):
    """A restart of the controller the gateway noticed (gateway/state.py, ResetReport)."""

    type: Literal["reset"] = "reset"
    time: str  # ISO 8601, UTC
    cause: list[str]
    cause_words: str
    expected: bool  # the gateway caused it (a soft reset, a firmware update)
    caused_by: str
    boot_count: int
    pose_restored: bool
    pose: Pose | None
    mission_ended: bool
    message: str
    pose_trust: PoseTrustView


class SimulatorMessage(_Message):
    """The simulator the gateway started exited on its own, or was started again."""

    type: Literal["simulator"] = "simulator"
    state: Literal["running", "restarting", "failed"]
    restarts: int
    message: str


# -- the map, perception, the simulated world -----------------------------------------------------
class MapMessage(_Message):
    """The map changed (GET /api/map has the new one)."""

    type: Literal["map"] = "map"
    version: int
    why: str


class PerceivedMessage(_Message):
    """The live map's perceived layer: [x, y, p_occupied] a cell."""

    type: Literal["perceived"] = "perceived"
    resolution: Number
    cells: list[tuple[Number, Number, Number]]


class CameraMessage(_Message):
    """A processed camera frame: its field of view and the obstacle bases it saw, map m."""

    type: Literal["camera"] = "camera"
    t: Number | None
    fov: list[Point]
    hits: list[Point]


class SimBox(_Strict):
    """A box standing in the simulated world: centre and size, m; height, m."""

    id: str
    x: Number
    y: Number
    sx: Number
    sy: Number
    height: Number
    colour: str
    solid: bool | None = _absent()


class SimWorldMessage(_Message):
    """The simulated world's boxes changed (GET /api/sim/world)."""

    type: Literal["sim_world"] = "sim_world"
    version: int | None
    boxes: list[SimBox]


class SetAside(_Strict):
    """A frontier exploration will not drive to again, and why."""

    x: Number
    y: Number
    reason: str


class ExplorationMessage(_Message):
    """Exploration's progress (cart2d/gateway/exploration_service.py; GET /api/explore): the
    floor seen free (m², and % of the arena's), frontiers left, those set aside with why, time
    spent (simulated: None on a real cart), and the sentence it ended with."""

    type: Literal["exploration"] = "exploration"
    state: Literal["idle", "exploring", "stopped", "finished", "failed"]
    seen_m2: Number
    seen_percent: Number
    frontiers: int
    goals: int
    set_aside: list[SetAside]
    elapsed_s: Number
    elapsed_sim_s: Number | None
    sentence: str
    saved: str | None  # the saved map's YAML


# -- recordings -----------------------------------------------------------------------------------
class ReplayMessage(_Message):
    """`cart2d replay`'s state changed; after a seek (and to a panel that opens) also the cart's
    trails up to the position, before the state there."""

    type: Literal["replay"] = "replay"
    state: Literal["waiting", "playing", "paused", "ended"]
    position_s: Number
    duration_s: Number
    seeks: int
    version: int
    trail: list[Point] | None = _absent()  # odometry
    truth_trail: list[Point] | None = _absent()


class GoalMessage(_Message):
    """A recorded mission's goal started or ended (`cart2d mission`'s recordings)."""

    type: Literal["goal"] = "goal"
    index: int
    of: int
    goal: Point
    state: Literal["started", "reached", "failed"]
    reason: str | None = _absent()


LiveMessage = Annotated[
    TelemetryMessage
    | TruthMessage
    | HelloMessage
    | MissionMessage
    | ReplanMessage
    | RoutineMessage
    | PoseTrustMessage
    | LocalisationMessage
    | ResetMessage
    | SimulatorMessage
    | MapMessage
    | PerceivedMessage
    | CameraMessage
    | SimWorldMessage
    | ReplayMessage
    | GoalMessage
    | ExplorationMessage,
    Field(discriminator="type"),
]
LIVE_MESSAGE: TypeAdapter[LiveMessage] = TypeAdapter(LiveMessage)


def wire(message: BaseModel) -> dict[str, Any]:
    """The message as /ws and the recordings carry it (JSON types)."""
    return message.model_dump(mode="json")


def json_schema() -> dict[str, Any]:
    """The union's JSON schema, as the JSON the viewers get (serialization), titled LiveMessage,
    in the draft json-schema-to-typescript reads (web/src/generated/live.ts)."""
    schema = LIVE_MESSAGE.json_schema(mode="serialization")
    return {"title": "LiveMessage", **for_typescript(schema)}


def for_typescript(schema: Any) -> Any:
    """A tuple's `prefixItems` (2020-12) as `items` (draft 7, which the generator reads); a
    field's title dropped (the generator would name a type after each), a model's kept."""
    if isinstance(schema, list):
        return [for_typescript(item) for item in schema]
    if not isinstance(schema, dict):
        return schema
    out = {key: for_typescript(value) for key, value in schema.items()}
    if "prefixItems" in out:
        out["items"] = out.pop("prefixItems")
    if "properties" in out:
        out["properties"] = {name: _untitled(field) for name, field in out["properties"].items()}
    return out


def _untitled(schema: dict[str, Any]) -> dict[str, Any]:
    return {key: value for key, value in schema.items() if key != "title"}
