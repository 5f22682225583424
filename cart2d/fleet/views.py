"""The fleet manager's JSON (GET /api/fleet, POST /api/fleet/goals ..., the /ws stream's
messages), declared once: the API answers with these models, and the fleet page's TypeScript
types (web/src/generated/fleet.ts) are generated from their JSON schema (`make ws-types`, as the
/ws messages' are), so the page and the manager cannot drift apart silently."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from cart2d.gateway.messages import for_typescript

Point = tuple[float, float]

# What the page shows of a cart, in this order of precedence: not ONLINE; paused (startPause,
# STOP ALL); stopped with an error it reported; driving its order; waiting at the end of its
# base for a node another cart holds; idle.
CartState = Literal["offline", "paused", "error", "driving", "waiting", "idle"]
GoalStatus = Literal["waiting", "driving", "reached", "cancelled", "failed"]


class _View(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class GoalRequest(_View):
    """A goal at the lattice node nearest (x, y), for `cart` or the nearest idle one."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
    x: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    y: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    cart: str | None = Field(
        None, max_length=64, description="the cart to send (default: the nearest idle one)"
    )


class LatticeView(_View):
    spacing_m: float
    nodes: list[Point]


class CartError(_View):
    """An entry of the cart's VDA 5050 state.errors (what it refused or could not do)."""

    type: str
    level: str
    description: str


class CartView(_View):
    name: str
    connection: str  # VDA 5050: ONLINE, OFFLINE, CONNECTIONBROKEN (UNKNOWN before it said)
    state: CartState
    position: tuple[float, float, float] | None  # x, y (m), theta (rad) in the map frame
    order_id: str | None  # the order it drives for the manager
    goal: int | None  # that order's goal
    errors: list[CartError]
    held: list[Point]  # the lattice nodes it holds
    route: list[Point]  # the rest of its route, from the node it last passed
    waiting_for: str | None  # the cart holding the node it needs next
    off_traffic: str | None  # why it is not on the shared lattice (it takes no goal), in a sentence


class GoalView(_View):
    id: int
    at: Point
    cart: str | None
    status: GoalStatus
    waited_s: float
    reason: str | None  # why it waits (no cart free, a node held) or failed (the cart's refusal)


class CartTruth(_View):
    """A simulated cart's ground truth (cart2d/simulation/shared_arena.py)."""

    t: float | None
    x: float | None
    y: float | None
    theta: float | None
    v: float | None
    collisions: int | None
    wall_contacts: int | None
    box_contacts: int | None
    rtf: float | None


class TruthView(_View):
    carts: dict[str, CartTruth]
    cart_contacts: int
    touching: list[tuple[str, str]]


class FleetView(_View):
    """GET /api/fleet: every cart, the last goals, the deadlocks resolved; `truth` under
    `cart2d fleet sim`."""

    lattice: LatticeView
    carts: list[CartView]
    goals: list[GoalView]
    deadlocks: int
    truth: TruthView | None = None


class GoalAccepted(_View):
    """POST /api/fleet/goals: the goal's id, the node it was put on, the cart named (if any)."""

    id: int
    at: Point
    cart: str | None


class PauseRequest(_View):
    """POST /api/fleet/carts/NAME/pause: startPause (true) or stopPause (false)."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)
    paused: bool


class CartAnswer(_View):
    """What was sent to one cart (POST /api/fleet/carts/NAME/cancel or /pause)."""

    cart: str
    sent: Literal["cancelOrder", "startPause", "stopPause"]


class StopAnswer(_View):
    stopped: Literal["all"]


class RemovedAnswer(_View):
    removed: str


class FleetUpdate(_View):
    """A message of the manager's live stream (the WebSocket /ws, cart2d/fleet/stream.py): the
    whole view, as GET /api/fleet answers it, at connection and whenever it changes."""

    type: Literal["fleet"]
    view: FleetView


FleetAnswer = (
    FleetView
    | GoalRequest
    | GoalAccepted
    | PauseRequest
    | CartAnswer
    | StopAnswer
    | RemovedAnswer
    | FleetUpdate
)


def json_schema() -> dict[str, Any]:
    """The API's bodies as one schema, titled FleetAnswer, for json-schema-to-typescript."""
    schema = TypeAdapter(FleetAnswer).json_schema(mode="serialization")
    return {"title": "FleetAnswer", **for_typescript(schema)}
