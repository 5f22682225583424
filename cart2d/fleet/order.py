"""A VDA 5050 vehicle's order and instant actions, as one cart executes them: pure logic over a
`Cart` (what drives: the gateway's missions, or a fake in tests), called from one thread.

The released base is driven as ONE path through its nodes (the gateway's go-to with the nodes
before the last as stops on the way: its planner's route round obstacles between each two), so
that the cart keeps its speed through them; it stops only at the last released node and waits
there for an order update that extends the base (VDA 5050 2.1, 6.6). An update that comes
before the cart gets there replaces its path at speed with one through the longer base. The
nodes are still reported one by one: a node on the way counts as traversed once the cart,
within the node's allowedDeviationXY, has reached the line through it across its route (the
bisector of its edges in and out), never before. The path ends at the base's end: the cart
never passes a node not released to it. What it refuses is answered with a VDA 5050 error in
its state, changing nothing."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from cart2d.fleet.vda5050 import MAP_ID, error

DEFAULT_DEVIATION_M = 0.3  # a new order's first node counts as where the cart is within this
INSTANT_ACTIONS = (
    "cancelOrder",
    "startPause",
    "stopPause",
    "initPosition",
    "stateRequest",
    "factsheetRequest",
)


class Refused(Exception):
    """What the cart refuses (a go-to it cannot plan, a pose it will not take), in a sentence."""


class Cart(Protocol):
    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        """Starts driving through `points` to the last, stopping only there (replacing the path
        it drives, at speed); its end comes through Executor.mission_ended. Refused."""

    def passed(self, x: float, y: float) -> None:
        """The cart passed (x, y), a point of its route before the last: a replan leaves it out."""

    def stop(self, reason: str) -> None: ...

    def set_pose(self, x: float, y: float, theta: float) -> None:
        """Refused if the pose is not one the cart takes."""


@dataclass
class Node:
    node_id: str
    sequence_id: int
    released: bool
    x: float
    y: float
    deviation_m: float
    raw: dict[str, Any]


@dataclass
class Edge:
    edge_id: str
    sequence_id: int
    released: bool
    start: str
    end: str
    raw: dict[str, Any]


@dataclass
class Executor:
    """The order state of one vehicle (state.json's orderId ... actionStates, errors)."""

    cart: Cart
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    order_id: str = ""
    order_update_id: int = 0
    last_node_id: str = ""
    last_node_sequence_id: int = 0
    nodes: list[Node] = field(default_factory=list)  # not yet traversed, in order
    edges: list[Edge] = field(default_factory=list)
    paused: bool = False
    driving_to: Node | None = None  # the last node of the path the cart's mission drives now
    stuck: bool = False  # a mission to a node failed: no retry until the master says (an update, stopPause)
    action_states: dict[str, dict[str, Any]] = field(default_factory=dict)
    errors: list[dict[str, Any]] = field(default_factory=list)
    changes: int = 0  # counts changes of the state (a state message is due after each)
    requests: list[str] = field(default_factory=list)  # "state" / "factsheet" asked for
    last_xy: tuple[float, float] = (0.0, 0.0)  # where the last node traversed is

    # -- orders ------------------------------------------------------------------------------
    def order(self, message: dict[str, Any]) -> None:
        """A new order or an update of the running one (VDA 5050 2.1, 6.6.3)."""
        self.errors = []
        try:
            nodes, edges = _parse(message)
            order_id, update_id = str(message["orderId"]), int(message["orderUpdateId"])
            if order_id == self.order_id:
                if update_id == self.order_update_id:
                    return  # the same update again: discarded, as the standard says
                if update_id < self.order_update_id:
                    raise _OrderError("orderUpdateError", f"orderUpdateId {update_id} is older", order_id)
                self._update(nodes, edges, order_id)
            else:
                self._start(nodes, edges, order_id)
            self.order_update_id = update_id
            self.stuck = False
        except _OrderError as exc:
            self.errors = [exc.entry]
        self.changes += 1
        self._drive_on()

    def _start(self, nodes: list[Node], edges: list[Edge], order_id: str) -> None:
        if self._base_left():
            raise _OrderError(
                "orderError", f"order {self.order_id} is still being driven: cancel it first", order_id
            )
        first = nodes[0]
        off = math.dist((first.x, first.y), self.pose[:2])
        if off > first.deviation_m:
            raise _OrderError(
                "noRouteError", f"the first node {first.node_id} is {off:.2f} m from the cart", order_id
            )
        self.order_id, self.order_update_id = order_id, 0
        self.nodes, self.edges = nodes[1:], edges
        self.driving_to = None
        self._traversed(first)

    def _update(self, nodes: list[Node], edges: list[Edge], order_id: str) -> None:
        """An update starts at the base's last node (traversed or not) and replaces the rest."""
        released = [n for n in self.nodes if n.released]
        end = released[-1] if released else None
        end_id, end_seq = (
            (end.node_id, end.sequence_id) if end else (self.last_node_id, self.last_node_sequence_id)
        )
        first = nodes[0]
        if (first.node_id, first.sequence_id) != (end_id, end_seq):
            raise _OrderError(
                "orderUpdateError",
                f"the update starts at {first.node_id}/{first.sequence_id}, "
                f"the base ends at {end_id}/{end_seq}",
                order_id,
            )
        self.nodes = released + nodes[1:]  # the horizon is replaced, the base extended
        self.edges = [e for e in self.edges if e.released] + edges

    def _base_left(self) -> bool:
        return any(n.released for n in self.nodes)

    # -- driving -----------------------------------------------------------------------------
    def _released_run(self) -> list[Node]:
        """The nodes ahead that the cart may drive through: released, and their edges in too."""
        run = []
        for node, edge in zip(self.nodes, self.edges, strict=False):
            if not (node.released and edge.released):
                break
            run.append(node)
        return run

    def _drive_on(self) -> None:
        """Sends the cart through the released nodes ahead, if it is not paused or stuck and not
        already driving to the base's end (an update that extended the base: the path replaced)."""
        if self.paused or self.stuck:
            return
        run = self._released_run()
        if not run or run[-1] is self.driving_to:
            return  # the base ends here (wait for an update), or is driven already
        try:
            self._send(run)
        except Refused as exc:
            self.errors.append(error("noRouteError", str(exc), "WARNING", nodeId=run[0].node_id))
            # a refused extension leaves the cart on its path to the base's old end: it tries
            # again from there; a refused start waits for the master (an update, stopPause)
            self.stuck = self.driving_to is None
        self.changes += 1

    def _send(self, run: list[Node]) -> None:
        self.cart.go_through([(n.x, n.y) for n in run])
        self.driving_to = run[-1]

    def moved(self, pose: tuple[float, float, float]) -> None:
        """The cart's pose now: the nodes on the way it passed since the last pose are traversed."""
        before, self.pose = self.pose, pose
        while self.driving_to is not None and self.nodes and self.nodes[0] is not self.driving_to:
            node = self.nodes[0]
            after = self.nodes[1]  # there is one: the path's last node comes later
            if not _passed(self.last_xy, node, (after.x, after.y), before[:2], pose[:2]):
                return
            self._next_traversed()
            self.cart.passed(node.x, node.y)

    def _next_traversed(self) -> None:
        node = self.nodes.pop(0)
        if self.edges:
            self.edges.pop(0)
        self._traversed(node)
        self.changes += 1

    def mission_ended(self, goal: tuple[float, float] | None, arrived: bool, reason: str) -> None:
        """The cart's mission to `goal` ended (the gateway's MissionEnded)."""
        target = self.driving_to
        if target is None or goal is None or math.dist(goal, (target.x, target.y)) > 1e-6:
            return  # not this order's (a stale end, a path replaced since, or one the user drove)
        self.driving_to = None
        if arrived:
            while self.nodes and self.nodes[0] is not target:  # passed between two looks
                self._next_traversed()
            self._next_traversed()
        elif not self.paused:  # a pause stops the cart: that end is expected
            where = self.nodes[0].node_id if self.nodes else target.node_id
            self.errors.append(error("navigationError", reason, "WARNING", nodeId=where))
            self.stuck = True  # it waits where it stopped: the master decides (stopPause retries)
        self.changes += 1
        self._drive_on()

    def _traversed(self, node: Node) -> None:
        self.last_node_id, self.last_node_sequence_id = node.node_id, node.sequence_id
        self.last_xy = (node.x, node.y)

    # -- instant actions -----------------------------------------------------------------------
    def instant_actions(self, message: dict[str, Any]) -> None:
        for action in message.get("actions", []):
            self._instant(action)
        self.changes += 1

    def _instant(self, action: dict[str, Any]) -> None:
        kind, action_id = str(action.get("actionType")), str(action.get("actionId"))
        state = {"actionId": action_id, "actionType": kind, "actionStatus": "FINISHED"}
        try:
            self._run(kind, _parameters(action))
        except (Refused, _OrderError) as exc:
            entry = exc.entry if isinstance(exc, _OrderError) else error("actionError", str(exc))
            entry.setdefault("errorReferences", []).append(
                {"referenceKey": "actionId", "referenceValue": action_id}
            )
            self.errors.append(entry)
            state.update(actionStatus="FAILED", resultDescription=entry["errorDescription"])
        self.action_states[action_id] = state

    def _run(self, kind: str, params: dict[str, Any]) -> None:
        if kind == "cancelOrder":
            if not self.nodes and self.driving_to is None:
                raise _OrderError("noOrderToCancel", "there is no order to cancel", self.order_id)
            self.cart.stop("the order was cancelled")
            self.nodes, self.edges, self.driving_to, self.stuck = [], [], None, False
            # the failure to reach a node of the order goes with it (STOP ALL: a stop, then this)
            self.errors = [e for e in self.errors if e.get("errorType") != "navigationError"]
        elif kind == "startPause":
            self.paused = True
            self.cart.stop("paused by the fleet")
        elif kind == "stopPause":
            self.paused, self.stuck = False, False
            run = self._released_run()
            if self.driving_to is not None and run:
                self.driving_to = None
                self._send(run)  # on through the same nodes (refused: this action's error)
            self._drive_on()
        elif kind == "initPosition":
            x, y, theta = (float(params[k]) for k in ("x", "y", "theta"))
            self.cart.set_pose(x, y, theta)
            self.pose = (x, y, theta)
            self.last_node_id = str(params.get("lastNodeId", self.last_node_id))
        elif kind in ("stateRequest", "factsheetRequest"):
            self.requests.append(kind.removesuffix("Request"))
        else:
            raise Refused(f"{kind} is not an instant action of this vehicle ({', '.join(INSTANT_ACTIONS)})")

    # -- the state message's order part ----------------------------------------------------------
    def state_fields(self) -> dict[str, Any]:
        return {
            "orderId": self.order_id,
            "orderUpdateId": self.order_update_id,
            "lastNodeId": self.last_node_id,
            "lastNodeSequenceId": self.last_node_sequence_id,
            "nodeStates": [_node_state(n) for n in self.nodes],
            "edgeStates": [
                {"edgeId": e.edge_id, "sequenceId": e.sequence_id, "released": e.released} for e in self.edges
            ],
            "driving": self.driving_to is not None and not self.paused,
            "paused": self.paused,
            "actionStates": list(self.action_states.values()),
            "errors": list(self.errors),
        }


Point = tuple[float, float]


def _passed(before: Point, node: Node, after: Point, was: Point, now: Point) -> bool:
    """Whether a cart that moved from `was` to `now` has passed `node` on its route from
    `before` to `after`: it is on or beyond the line through the node that halves the turn
    between the node's edges (on a straight route the perpendicular, on a rounded corner its
    middle), and it crossed that line (or stands beyond it) within the node's deviation. The
    crossing, not the pose, is checked: poses a long way apart (a busy machine, a simulator at
    full speed) still see the node passed."""
    ax, ay = _unit(node.x - before[0], node.y - before[1])
    bx, by = _unit(after[0] - node.x, after[1] - node.y)
    nx, ny = ax + bx, ay + by
    s_was = (was[0] - node.x) * nx + (was[1] - node.y) * ny
    s_now = (now[0] - node.x) * nx + (now[1] - node.y) * ny
    if s_now < 0.0:
        return False
    if s_was >= 0.0:
        at = now
    else:  # where the move crossed the line
        t = s_was / (s_was - s_now)
        at = (was[0] + t * (now[0] - was[0]), was[1] + t * (now[1] - was[1]))
    return math.dist(at, (node.x, node.y)) <= node.deviation_m


def _unit(x: float, y: float) -> tuple[float, float]:
    length = math.hypot(x, y)
    return (x / length, y / length) if length > 1e-9 else (0.0, 0.0)


class _OrderError(Exception):
    def __init__(self, error_type: str, description: str, order_id: str) -> None:
        super().__init__(description)
        self.entry = error(error_type, description, "WARNING", orderId=order_id)


def _node_state(node: Node) -> dict[str, Any]:
    return {
        "nodeId": node.node_id,
        "sequenceId": node.sequence_id,
        "released": node.released,
        "nodePosition": {"x": node.x, "y": node.y, "mapId": MAP_ID},
    }


def _parameters(action: dict[str, Any]) -> dict[str, Any]:
    return {str(p.get("key")): p.get("value") for p in action.get("actionParameters", []) or []}


def _parse(message: dict[str, Any]) -> tuple[list[Node], list[Edge]]:
    """The order's nodes and edges, checked: positions on our map, sequence ids alternating
    node (even) and edge (odd), each edge between its neighbours, the base before the horizon,
    and no actions (this vehicle has none on nodes or edges)."""
    order_id = str(message.get("orderId", ""))
    try:
        nodes = [_node(n) for n in message["nodes"]]
        edges = [_edge(e) for e in message["edges"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise _OrderError("validationError", f"a node or an edge lacks {exc}", order_id) from exc
    problem = _sequence_problem(nodes, edges) or _action_problem(message)
    if problem:
        raise _OrderError("validationError", problem, order_id)
    return nodes, edges


def _node(raw: dict[str, Any]) -> Node:
    position = raw["nodePosition"]
    if position.get("mapId", MAP_ID) != MAP_ID:
        raise ValueError(f"a position on map {position.get('mapId')!r} (this cart's is {MAP_ID!r})")
    deviation = float(position.get("allowedDeviationXY") or DEFAULT_DEVIATION_M)
    return Node(
        str(raw["nodeId"]), int(raw["sequenceId"]), bool(raw["released"]),
        float(position["x"]), float(position["y"]), deviation, raw,
    )  # fmt: skip


def _edge(raw: dict[str, Any]) -> Edge:
    return Edge(
        str(raw["edgeId"]), int(raw["sequenceId"]), bool(raw["released"]),
        str(raw["startNodeId"]), str(raw["endNodeId"]), raw,
    )  # fmt: skip


def _sequence_problem(nodes: list[Node], edges: list[Edge]) -> str:
    if not nodes or len(edges) != len(nodes) - 1:
        return f"{len(nodes)} nodes need {max(len(nodes) - 1, 0)} edges between them, not {len(edges)}"
    for i, edge in enumerate(edges):
        a, b = nodes[i], nodes[i + 1]
        if not (a.sequence_id < edge.sequence_id < b.sequence_id) or (edge.start, edge.end) != (
            a.node_id,
            b.node_id,
        ):
            return f"edge {edge.edge_id} does not join {a.node_id} and {b.node_id} in sequence"
        if edge.released and not b.released:
            return f"edge {edge.edge_id} is released but its end node {b.node_id} is not"
    if not nodes[0].released:
        return "the first node must be released"
    flags = [n.released for n in nodes]
    if flags != sorted(flags, reverse=True):
        return "a released node follows the horizon"
    return ""


def _action_problem(message: dict[str, Any]) -> str:
    for item in [*message["nodes"], *message["edges"]]:
        if item.get("actions"):
            kinds = ", ".join(str(a.get("actionType")) for a in item["actions"])
            return f"actions on nodes and edges are not supported by this vehicle ({kinds})"
    return ""
