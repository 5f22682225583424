"""A cart as a VDA 5050 2.1.0 vehicle on an MQTT broker: `connection` (ONLINE retained, its
last will CONNECTIONBROKEN, OFFLINE when it closes), `state` on every change and at least every
30 s, `visualization` at 5 Hz, `factsheet` at connection and on request; `order`s and
`instantActions` executed by order.py's Executor.

Everything the Executor does runs on one thread (the vehicle's): MQTT's messages, the cart's
mission ends and the timers are queued to it, so that nothing blocks paho's loop or the
gateway's bus, and the order's state needs no lock."""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from cart2d.fleet import vda5050
from cart2d.fleet.mqtt import Broker, Connection
from cart2d.fleet.order import INSTANT_ACTIONS, Cart, Executor
from cart2d.params import robot, settings_table

log = logging.getLogger(__name__)

STATE_EVERY_S = 30.0  # VDA 5050: a state at least this often when nothing changes
VISUALIZATION_EVERY_S = 0.2  # 5 Hz


class Vehicle:
    """`pose()`: (x, y, theta, v, omega) in the map frame; `pose_trusted()`: positionInitialized."""

    def __init__(
        self,
        broker: Broker,
        serial_number: str,
        cart: Cart,
        pose: Callable[[], tuple[float, float, float, float, float]],
        pose_trusted: Callable[[], bool],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.serial_number = serial_number
        self.executor = Executor(cart)
        self._pose = pose
        self._pose_trusted = pose_trusted
        self._clock = clock
        self._headers = vda5050.Headers(serial_number)
        self._inbox: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._thread = threading.Thread(target=self._run, name=f"vda5050 {serial_number}", daemon=True)
        self.connection = Connection(
            broker,
            f"cart2d-{serial_number}",
            will=(self._topic("connection"), self._connection("CONNECTIONBROKEN")),
            on_connect=lambda: self._inbox.put(self._announce),
        )
        self.connection.subscribe(self._topic("order"), lambda _t, m: self._inbox.put(lambda: self._order(m)))
        self.connection.subscribe(
            self._topic("instantActions"), lambda _t, m: self._inbox.put(lambda: self._instant(m))
        )
        self._last_state_s = -math.inf
        self._published_changes = -1
        self._published_initialized: bool | None = None  # positionInitialized as last published

    def _topic(self, name: str) -> str:
        return vda5050.topic(self.serial_number, name)

    # -- life --------------------------------------------------------------------------------
    def start(self) -> Vehicle:
        self._thread.start()
        self.connection.start()
        return self

    def close(self) -> None:
        """OFFLINE (retained), then the connection closed in order (no last will)."""
        self._inbox.put(None)
        self._thread.join(5)
        self.connection.close(last=(self._topic("connection"), self._connection("OFFLINE")))

    def mission_ended(self, goal: tuple[float, float] | None, arrived: bool, reason: str) -> None:
        """The cart's mission ended (from the gateway's bus: returns at once)."""
        self._inbox.put(lambda: self.executor.mission_ended(goal, arrived, reason))

    def moved(self) -> None:
        """The cart's pose changed (its telemetry: returns at once). While an order is driven the
        nodes on the way are looked for at once, not only at the 5 Hz of `visualization`: a node
        passed is reported as soon as it is, and its successors released in time. Reading
        driving_to from this thread is a hint only: a stale value costs one look or one delay."""
        if self.executor.driving_to is not None:
            self._inbox.put(self._tick)

    def _run(self) -> None:
        next_visualization = self._clock()
        while True:
            try:
                job = self._inbox.get(timeout=max(0.0, next_visualization - self._clock()))
            except queue.Empty:
                job = _nothing
            if job is None:
                return
            due = self._clock() >= next_visualization
            try:
                job()
                if due:  # the nodes passed on the way are looked for as often as the pose is sent
                    self._tick()
                self._publish_state_if_due()
            except Exception:  # a fault in one message must not end the vehicle
                log.exception("the VDA 5050 vehicle %s failed on a message", self.serial_number)
            if due:
                self._publish("visualization", self._visualization())
                next_visualization = self._clock() + VISUALIZATION_EVERY_S

    def _tick(self) -> None:
        x, y, theta, _v, _omega = self._pose()
        self.executor.moved((x, y, theta))

    # -- in ----------------------------------------------------------------------------------
    def _order(self, message: dict[str, Any]) -> None:
        self._tick()
        self.executor.order(message)

    def _instant(self, message: dict[str, Any]) -> None:
        self._tick()
        self.executor.instant_actions(message)
        for request in self.executor.requests:
            if request == "factsheet":
                self._publish("factsheet", self.factsheet())
            else:
                self._last_state_s = -math.inf  # stateRequest: the state now
        self.executor.requests.clear()

    # -- out ---------------------------------------------------------------------------------
    def _announce(self) -> None:
        """At every connection: ONLINE (retained: a restarted broker forgot it), the factsheet,
        the state."""
        self._publish("connection", self._connection("ONLINE"), retain=True)
        self._publish("factsheet", self.factsheet(), retain=True)
        self._last_state_s = -math.inf

    def _publish(self, name: str, payload: dict[str, Any], retain: bool = False) -> None:
        self.connection.publish(self._topic(name), payload, retain=retain)

    def _publish_state_if_due(self) -> None:
        initialized = self._pose_trusted()  # its change is a change of the state too
        changed = (
            self.executor.changes != self._published_changes or initialized != self._published_initialized
        )
        if changed or self._clock() - self._last_state_s >= STATE_EVERY_S:
            self._published_changes, self._published_initialized = self.executor.changes, initialized
            self._last_state_s = self._clock()
            self._publish("state", self.state())

    def _connection(self, state: str) -> dict[str, Any]:
        return {**self._headers.header("connection"), "connectionState": state}

    def _position(self) -> tuple[dict[str, Any], dict[str, Any]]:
        x, y, theta, v, omega = self._pose()
        position = {
            "x": x, "y": y, "theta": math.remainder(theta, math.tau),
            "mapId": vda5050.MAP_ID, "positionInitialized": self._pose_trusted(),
        }  # fmt: skip
        velocity = {"vx": v, "vy": 0.0, "omega": omega}  # in the cart's frame
        return position, velocity

    def _visualization(self) -> dict[str, Any]:
        position, velocity = self._position()
        return {**self._headers.header("visualization"), "agvPosition": position, "velocity": velocity}

    def state(self) -> dict[str, Any]:
        position, velocity = self._position()
        return {
            **self._headers.header("state"),
            **self.executor.state_fields(),
            "agvPosition": position,
            "velocity": velocity,
            "operatingMode": "AUTOMATIC",
            # the cart measures no battery: VDA 5050 requires the field, 0 % charge says nothing
            "batteryState": {"batteryCharge": 0.0, "charging": False},
            "safetyState": {"eStop": "NONE", "fieldViolation": False},
        }

    def factsheet(self) -> dict[str, Any]:
        return {**self._headers.header("factsheet"), **factsheet_body()}


def _nothing() -> None:
    pass


def _setting_default(name: str) -> float:
    return float(next(s["default"] for s in settings_table() if s["name"] == name))


def factsheet_body() -> dict[str, Any]:
    """What a cart is, from config/robot.toml (VDA 5050 2.1, 6.17)."""
    radius = float(robot()["body"]["footprint_radius_m"])
    a_max = _setting_default("a_max_mps2")
    return {
        "typeSpecification": {
            "seriesName": "cart2d",
            "agvKinematic": "DIFF",
            "agvClass": "CARRIER",
            "maxLoadMass": 0.0,
            "localizationTypes": ["NATURAL"],
            "navigationTypes": ["AUTONOMOUS"],
        },
        "physicalParameters": {
            "speedMin": 0.0,
            "speedMax": _setting_default("v_max_mps"),
            "accelerationMax": a_max,
            "decelerationMax": a_max,
            "heightMax": float(robot()["camera"]["height_m"]),  # the camera on top
            "width": 2 * radius,
            "length": 2 * radius,
        },
        "protocolLimits": {
            "maxStringLens": {},
            "maxArrayLens": {},
            "timing": {"minOrderInterval": 0.1, "minStateInterval": 0.1},
        },
        "protocolFeatures": {
            "optionalParameters": [],
            "agvActions": [{"actionType": kind, "actionScopes": ["INSTANT"]} for kind in INSTANT_ACTIONS],
        },
        "agvGeometry": {},
        "loadSpecification": {},
    }
