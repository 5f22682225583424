"""The fleet manager, VDA 5050's master control: it hears every vehicle's connection, state and
visualization on the broker, gives goals to carts (the nearest idle one, or the one named) as
orders on the shared lattice, and releases each route a few nodes at a time as traffic.py
allows, in order updates. STOP ALL cancels every order (and calls each gateway's own stop when
it runs beside them, `cart2d fleet sim`).

Its state is changed under one lock, by paho's thread (what vehicles say) and by step() (the
manager's thread, every STEP_S, or a test's fake clock)."""

from __future__ import annotations

import itertools
import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cart2d.fleet import vda5050, views
from cart2d.fleet.lattice import Cell, Lattice, node_id
from cart2d.fleet.mqtt import Broker, Connection
from cart2d.fleet.traffic import Traffic, TrafficError

log = logging.getLogger(__name__)

STEP_S = 0.1
# How far from an order's node a cart may stand and still take it (allowedDeviationXY): a cart
# whose nearest node another cart holds joins the traffic at a free node this near, if any
DEVIATION_M = 0.3
ALL_VEHICLES = f"{vda5050.INTERFACE}/{vda5050.MAJOR}/+/+/+"


@dataclass
class CartView:
    name: str
    manufacturer: str = vda5050.MANUFACTURER
    connection: str = "UNKNOWN"
    position: tuple[float, float, float] | None = None
    state: dict[str, Any] = field(default_factory=dict)
    off_traffic: str | None = None  # why it could not join the traffic, while it cannot

    @property
    def online(self) -> bool:
        return self.connection == "ONLINE"


@dataclass
class Goal:
    goal_id: int
    cell: Cell
    cart: str | None  # named by the user, or the one it was given to
    asked_s: float
    assigned_s: float | None = None  # given to a cart
    ordered_s: float | None = None  # its order sent
    accepted_s: float | None = None  # the cart's state shows the order
    reached_s: float | None = None
    status: views.GoalStatus = "waiting"
    waited_s: float = 0.0  # for reservations, on its way
    reason: str | None = None  # why it waits or failed, in a sentence


@dataclass
class Sent:
    """The order a cart drives: its id, update, the route's base end already sent."""

    order_id: str
    update_id: int
    base_end: int
    goal: Goal


class FleetManager:
    def __init__(
        self,
        lattice: Lattice,
        broker: Broker | None = None,
        clock: Callable[[], float] = time.monotonic,
        publish: Callable[[str, dict[str, Any]], None] | None = None,
    ) -> None:
        """`publish(topic, message)`: how messages leave (default: the broker's connection)."""
        self.lattice = lattice
        self.traffic = Traffic(lattice)
        self.carts: dict[str, CartView] = {}
        self.goals: list[Goal] = []
        self.sent: dict[str, Sent] = {}
        self.stoppers: list[Callable[[], None]] = []  # each gateway's own stop, where it runs beside us
        self._clock = clock
        self._lock = threading.RLock()
        self._ids = itertools.count(1)
        self._headers: dict[str, vda5050.Headers] = {}
        self.connection = (
            None
            if broker is None
            else Connection(broker, f"cart2d-fleet-{time.time_ns()}", on_connect=self.ask_states)
        )
        self._publish = publish or self._to_broker
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fleet manager", daemon=True)
        if self.connection is not None:
            self.connection.subscribe(ALL_VEHICLES, self.heard)

    # -- life --------------------------------------------------------------------------------
    def start(self) -> FleetManager:
        if self.connection is not None:
            self.connection.start()
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        if self.connection is not None:
            self.connection.close()

    def _run(self) -> None:
        while not self._stop.wait(STEP_S):
            try:
                self.step()
            except Exception:  # one bad step must not end the manager
                log.exception("the fleet manager's step failed")

    def _to_broker(self, topic: str, message: dict[str, Any]) -> None:
        assert self.connection is not None
        self.connection.publish(topic, message)

    # -- what vehicles say ---------------------------------------------------------------------
    def heard(self, topic: str, message: dict[str, Any]) -> None:
        where = vda5050.vehicle_of(topic)
        if where is None:
            return
        name, kind = where
        with self._lock:
            cart = self.carts.setdefault(name, CartView(name, str(message.get("manufacturer", ""))))
            if kind == "connection":
                cart.connection = str(message.get("connectionState"))
                if cart.name in self.traffic.standing:
                    self.traffic.set_online(name, cart.online)
            elif kind in ("state", "visualization"):
                self._position(cart, message)
                if kind == "state":
                    if cart.connection == "UNKNOWN":
                        cart.connection = "ONLINE"  # a state before its (retained) connection
                    cart.state = message
                    self._progress(cart, message)

    def _position(self, cart: CartView, message: dict[str, Any]) -> None:
        p = message.get("agvPosition")
        if not p or not p.get("positionInitialized"):
            return
        cart.position = (float(p["x"]), float(p["y"]), float(p["theta"]))
        try:
            cell = self.lattice.nearest(p["x"], p["y"])
        except ValueError:
            return
        # an idle cart moved (initPosition, by hand, stopped past the node it last reported on
        # a cancelled order's base): its node follows, or its next order's first node would be
        # refused as too far from it
        if (
            self.traffic.idle(cart.name)
            and self.traffic.standing[cart.name] != cell
            and not self.traffic.stands_at(cart.name, cell)
            and cell not in self.traffic.holds
        ):
            self.traffic.remove(cart.name)
        if cart.name not in self.traffic.standing:
            self._join(cart, cell)

    def _join(self, cart: CartView, cell: Cell) -> None:
        """The cart joins the traffic at `cell`, or, if another cart holds it, at the nearest free
        node within DEVIATION_M of it (its next order can start there); else it stays off, and
        the page says why."""
        assert cart.position is not None
        at = cart.position[:2]
        holder = self.traffic.holds.get(cell)
        if holder not in (None, cart.name):
            near = [
                c
                for c in self.lattice.free
                if c not in self.traffic.holds and math.dist(self.lattice.position(c), at) <= DEVIATION_M
            ]
            if not near:
                why = (
                    f"it stands nearest node {node_id(cell)}, which {holder} holds, and no free node is "
                    f"within {DEVIATION_M:g} m: move it, or remove {holder} if it is gone"
                )
                if cart.off_traffic != why:
                    log.warning("%s cannot join the traffic: %s", cart.name, why)
                cart.off_traffic = why
                return
            cell = min(near, key=lambda c: (math.dist(self.lattice.position(c), at), c))
        self.traffic.join(cart.name, cell)
        cart.off_traffic = None

    def _progress(self, cart: CartView, state: dict[str, Any]) -> None:
        sent = self.sent.get(cart.name)
        if sent is None:
            return
        if state.get("orderId") != sent.order_id:
            if sent.order_id in _references(state):  # the vehicle refused the order
                sent.goal.status = "failed"
                sent.goal.reason = _refusal(state, sent.order_id)
                self.traffic.cancel(cart.name)
                del self.sent[cart.name]
            return
        if sent.goal.accepted_s is None:
            sent.goal.accepted_s = self._clock()
        index = int(state.get("lastNodeSequenceId", 0)) // 2
        if self.traffic.reached(cart.name, index):
            goal = sent.goal
            goal.status, goal.reached_s = "reached", self._clock()
            journey = next(j for c, j in reversed(self.traffic.finished) if c == cart.name)
            goal.waited_s = journey.waited_s
            del self.sent[cart.name]

    # -- goals -------------------------------------------------------------------------------
    def add_goal(self, x: float, y: float, cart: str | None = None) -> Goal:
        """A goal at the lattice node nearest (x, y), for `cart` or the nearest idle one;
        ValueError (a sentence) for an unknown cart or a point off the lattice."""
        with self._lock:
            if cart is not None and cart not in self.carts:
                raise ValueError(f"there is no cart {cart!r} ({self._names()})")
            cell = self.lattice.nearest(x, y)
            if math.dist(self.lattice.position(cell), (x, y)) > self.lattice.spacing_m:
                raise ValueError(f"({x:.2f}, {y:.2f}) is not in the arena's free space")
            goal = Goal(next(self._ids), cell, cart, self._clock())
            self.goals.append(goal)
            return goal

    def _assign(self) -> None:
        waiting = [g for g in self.goals if g.status == "waiting"]
        leaving = frozenset(g.cart for g in waiting if g.cart is not None)  # named carts leave soon
        for goal in waiting:
            idle = [c for c in self.carts.values() if c.online and self.traffic.idle(c.name)]
            if goal.cart is not None:
                idle = [c for c in idle if c.name == goal.cart]
            if not idle:
                goal.reason = self._why_not_idle(goal.cart)
                continue
            target = self.lattice.position(goal.cell)
            chosen = min(
                idle, key=lambda c: math.dist(self.lattice.position(self.traffic.standing[c.name]), target)
            )
            try:
                self.traffic.send(chosen.name, goal.cell, leaving - {chosen.name})
            except TrafficError as exc:
                if goal.reason != str(exc):
                    log.info("goal %d waits: %s", goal.goal_id, exc)
                goal.reason = str(exc)
                continue
            goal.cart, goal.status, goal.assigned_s = chosen.name, "driving", self._clock()
            goal.reason = None
            self.sent[chosen.name] = Sent(f"{chosen.name}-{goal.goal_id}", 0, 0, goal)

    def _why_not_idle(self, name: str | None) -> str:
        """Why no cart (or not cart `name`) can take a goal now."""
        if name is None:
            return "every cart is busy, offline or off the traffic"
        cart = self.carts[name]
        if not cart.online:
            return f"{name} is {cart.connection}"
        if cart.off_traffic is not None:
            return f"{name} is off the traffic: {cart.off_traffic}"
        if name not in self.traffic.standing:
            return f"{name} has not said where it is yet"
        return f"{name} is busy with another goal"

    # -- orders --------------------------------------------------------------------------------
    def step(self) -> None:
        with self._lock:
            self._assign()
            changed = self.traffic.step(self._clock())
            for name, sent in self.sent.items():
                if sent.goal.ordered_s is None or name in changed:
                    self._send_order(name, sent)

    def _send_order(self, name: str, sent: Sent) -> None:
        journey = self.traffic.journeys.get(name)
        if journey is None:
            return
        first = 0 if sent.goal.ordered_s is None else sent.base_end
        if sent.goal.ordered_s is not None:
            sent.update_id += 1
        route = journey.route
        nodes: list[dict[str, Any]] = [
            {
                "nodeId": node_id(cell),
                "sequenceId": 2 * i,
                "released": i < journey.released,
                "nodePosition": {"x": x, "y": y, "mapId": vda5050.MAP_ID, "allowedDeviationXY": DEVIATION_M},
                "actions": [],
            }
            for i in range(first, len(route))
            for cell in [route[i]]
            for x, y in [self.lattice.position(cell)]
        ]
        edges = [
            {
                "edgeId": f"{a['nodeId']}-{b['nodeId']}",
                "sequenceId": a["sequenceId"] + 1,
                "released": b["released"],
                "startNodeId": a["nodeId"],
                "endNodeId": b["nodeId"],
                "actions": [],
            }
            for a, b in itertools.pairwise(nodes)
        ]
        body = {"orderId": sent.order_id, "orderUpdateId": sent.update_id, "nodes": nodes, "edges": edges}
        self._send(name, "order", body)
        sent.base_end = journey.released - 1
        if sent.goal.ordered_s is None:
            sent.goal.ordered_s = self._clock()

    def _send(self, name: str, topic: str, body: dict[str, Any]) -> None:
        cart = self.carts[name]
        headers = self._headers.setdefault(name, vda5050.Headers(name, cart.manufacturer))
        self._publish(vda5050.topic(name, topic, cart.manufacturer), {**headers.header(topic), **body})

    def ask_states(self) -> None:
        """stateRequest to every cart known (at every connection: what they said while the
        broker was away, or before this manager subscribed again, is not lost for 30 s)."""
        with self._lock:
            for name in self.carts:
                self._instant(name, "stateRequest", "NONE")

    # -- STOP ALL, and one cart's cancel and pause --------------------------------------------
    def stop_all(self) -> None:
        """Every gateway's own stop first (where it runs beside us), then cancelOrder to each
        vehicle; goals not reached are cancelled, and the carts keep the nodes they hold."""
        for stop in self.stoppers:
            try:
                stop()
            except Exception:  # one cart's failure must not keep the others going
                log.exception("a gateway's stop failed")
        with self._lock:
            for name in self.carts:
                self._cancel(name)
            for goal in self.goals:
                if goal.status in ("waiting", "driving"):
                    goal.status = "cancelled"

    def cancel(self, name: str) -> None:
        """cancelOrder to one cart: its goal cancelled, the nodes it stands on still held;
        ValueError (a sentence) for a cart unknown or driving no order, and nothing sent."""
        with self._lock:
            self._known(name)
            if name not in self.sent:
                raise ValueError(f"there is nothing to cancel: {name} drives no order")
            self.sent[name].goal.status = "cancelled"
            self._cancel(name)

    def pause(self, name: str, paused: bool) -> None:
        """startPause (or stopPause) to one cart, which keeps its order and the nodes it holds;
        ValueError (a sentence) for a cart unknown or not ONLINE, and nothing sent."""
        with self._lock:
            cart = self._known(name)
            if not cart.online:
                raise ValueError(f"cart {name} is {cart.connection}: it hears no pause until it is back")
            self._instant(name, "startPause" if paused else "stopPause", "HARD")

    def _known(self, name: str) -> CartView:
        if name not in self.carts:
            raise KeyError(f"there is no cart {name!r} ({self._names()})")
        return self.carts[name]

    def _names(self) -> str:
        return f"carts: {', '.join(sorted(self.carts)) or 'none'}"

    def _cancel(self, name: str) -> None:
        self._instant(name, "cancelOrder", "HARD")
        self.traffic.cancel(name)
        self.sent.pop(name, None)

    def _instant(self, name: str, action_type: str, blocking: str) -> None:
        action = {
            "actionId": f"{action_type}-{time.time_ns()}",
            "actionType": action_type,
            "blockingType": blocking,
        }
        self._send(name, "instantActions", {"actions": [action]})

    def remove(self, name: str) -> None:
        """Forgets a cart (an OFFLINE one's nodes are free again)."""
        with self._lock:
            self.traffic.remove(name)
            self.carts.pop(name, None)
            sent = self.sent.pop(name, None)
            if sent is not None:
                sent.goal.status = "cancelled"

    # -- views ---------------------------------------------------------------------------------
    def view(self) -> views.FleetView:
        with self._lock:
            return views.FleetView(
                lattice=views.LatticeView(
                    spacing_m=self.lattice.spacing_m,
                    nodes=sorted(self.lattice.position(c) for c in self.lattice.free),
                ),
                carts=[self._cart_view(c) for c in self.carts.values()],
                goals=[self._goal_view(g) for g in self.goals[-200:]],
                deadlocks=self.traffic.deadlocks,
            )

    def _cart_view(self, cart: CartView) -> views.CartView:
        journey = self.traffic.journeys.get(cart.name)
        held = sorted(self.lattice.position(c) for c, h in self.traffic.holds.items() if h == cart.name)
        sent = self.sent.get(cart.name)
        errors = [_error_view(e) for e in cart.state.get("errors", [])]
        waiting_for = journey.waiting_for if journey else None
        return views.CartView(
            name=cart.name,
            connection=cart.connection,
            state=_cart_state(cart, errors, journey is not None, waiting_for),
            position=cart.position,
            order_id=sent.order_id if sent else None,
            goal=sent.goal.goal_id if sent else None,
            errors=errors,
            held=held,
            route=[self.lattice.position(c) for c in journey.route[journey.passed :]] if journey else [],
            waiting_for=waiting_for,
            off_traffic=cart.off_traffic,
        )

    def _goal_view(self, goal: Goal) -> views.GoalView:
        return views.GoalView(
            id=goal.goal_id,
            at=self.lattice.position(goal.cell),
            cart=goal.cart,
            status=goal.status,
            waited_s=round(goal.waited_s, 3),
            reason=goal.reason,
        )


def _cart_state(
    cart: CartView, errors: list[views.CartError], routed: bool, waiting_for: str | None
) -> views.CartState:
    """One word for the cart (views.CartState says the precedence)."""
    driving = bool(cart.state.get("driving"))
    if not cart.online:
        return "offline"
    if cart.state.get("paused"):
        return "paused"
    if errors and not driving:
        return "error"
    if waiting_for is not None and not driving:
        return "waiting"
    return "driving" if driving or routed else "idle"


def _error_view(entry: dict[str, Any]) -> views.CartError:
    return views.CartError(
        type=str(entry.get("errorType", "")),
        level=str(entry.get("errorLevel", "")),
        description=str(entry.get("errorDescription") or ""),
    )


def _refusal(state: dict[str, Any], order_id: str) -> str:
    """The vehicle's own words for refusing order `order_id` (its state's error about it)."""
    for e in state.get("errors", []):
        if any(str(r.get("referenceValue")) == order_id for r in e.get("errorReferences", [])):
            words = e.get("errorDescription") or e.get("errorType") or "no reason given"
            return f"the cart refused the order: {words}"
    return "the cart refused the order"


def _references(state: dict[str, Any]) -> set[str]:
    """The values the state's errors refer to (orderIds, nodeIds)."""
    return {
        str(ref.get("referenceValue"))
        for e in state.get("errors", [])
        for ref in e.get("errorReferences", [])
    }
