"""A gateway as a VDA 5050 vehicle: the Executor drives the gateway's missions service and
hears its ends on the event bus; the pose comes from the telemetry the viewers get."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from cart2d.fleet.mqtt import Broker
from cart2d.fleet.order import Refused
from cart2d.fleet.vehicle import Vehicle
from cart2d.gateway import Gateway, PoseOutsideArena, PoseUntrusted
from cart2d.gateway.bus import MissionEnded
from cart2d.link import CommandRefused, LinkError, MotionCancelled
from cart2d.planning import PlanError


class GatewayCart:
    """order.py's Cart over a Gateway."""

    def __init__(self, gateway: Gateway) -> None:
        self.gateway = gateway
        self.last: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
        self.heard = False  # no telemetry yet: the position is not known (positionInitialized false)

    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        """One mission of the gateway's missions service through every point to the last."""
        *via, (x, y) = points
        try:
            self.gateway.missions.go_to(x, y, via=tuple(via))
        except (PlanError, PoseUntrusted, MotionCancelled, LinkError, CommandRefused) as exc:
            raise Refused(f"the cart cannot drive to ({x:.2f}, {y:.2f}): {exc}") from exc

    def passed(self, x: float, y: float) -> None:
        self.gateway.missions.passed((x, y))

    def stop(self, reason: str) -> None:
        try:
            self.gateway.stop(reason)
        except (LinkError, CommandRefused) as exc:
            raise Refused(f"the cart did not take the stop: {exc}") from exc

    def set_pose(self, x: float, y: float, theta: float) -> None:
        try:
            self.gateway.set_pose(x, y, theta)
        except (PoseOutsideArena, LinkError, CommandRefused) as exc:
            raise Refused(f"the pose ({x:.2f}, {y:.2f}, {theta:.2f}) was not taken: {exc}") from exc

    def telemetry(self, message: dict[str, Any]) -> None:
        if message.get("type") == "telemetry":
            self.last = (message["x"], message["y"], message["theta"], message["v"], message["omega"])
            self.heard = True


def join_fleet(gateway: Gateway, broker: Broker, fleet_id: str) -> Vehicle:
    """The gateway's vehicle, started: closed with vehicle.close() before the gateway closes."""
    cart = GatewayCart(gateway)
    vehicle = Vehicle(
        broker, fleet_id, cart, lambda: cart.last, lambda: cart.heard and gateway.pose_trust.trusted
    )

    def heard(message: dict[str, Any]) -> None:
        cart.telemetry(message)
        if message.get("type") == "telemetry":
            vehicle.moved()  # the nodes on the way looked for at the telemetry's rate

    gateway.subscribe(heard)
    gateway.bus.subscribe(
        MissionEnded, lambda e: vehicle.mission_ended(e.goal, e.outcome == "arrived", e.reason)
    )
    return vehicle.start()
