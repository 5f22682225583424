"""The bridge's services for rmw_cyclonedds_cpp clients: `stop` and `reset_odometry`
(std_srvs/Trigger). A request arrives on `rq/<name>Request` with the client's header (its
writer's id and the request's number); the reply goes to `rr/<name>Reply` with the same header,
which is how the client knows it for its own. (Fast DDS frames requests in its own way: its
clients and this bridge do not talk.)

The stop is answered on the reading thread, before anything else it has to do; resetting the
odometry waits for the link on the requests' worker."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any, Protocol

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.inbound import Inbound

log = logging.getLogger(__name__)


class ServiceGateway(Protocol):
    def stop(self, reason: str = "stopped by the user") -> Any: ...
    def set_pose(self, x: float, y: float, theta: float) -> dict[str, float]: ...


def reply(request: t.TriggerRequest, success: bool, message: str) -> t.TriggerResponse:
    return t.TriggerResponse(guid=request.guid, seq=request.seq, success=success, message=message)


class TriggerServices:
    """stop and reset_odometry on `inbound`'s node."""

    def __init__(self, inbound: Inbound, gateway: ServiceGateway) -> None:
        self.inbound = inbound
        self.gateway = gateway
        self._serve("stop", self._stop, at_once=True)
        self._serve("reset_odometry", self._reset_odometry, at_once=False)

    def _serve(
        self, name: str, answer: Callable[[t.TriggerRequest], t.TriggerResponse], at_once: bool
    ) -> None:
        node = self.inbound.node
        o = node.options
        replies = node.writer(o.reply(name), t.TriggerResponse, qos.requests())

        def on_request(request: t.TriggerRequest) -> None:
            if at_once:
                replies.write(answer(request))
            else:
                self.inbound.tasks.offer(name, lambda: replies.write(answer(request)))

        self.inbound.add(node.reader(o.request(name), t.TriggerRequest, qos.requests()), on_request)

    def _stop(self, request: t.TriggerRequest) -> t.TriggerResponse:
        try:
            self.gateway.stop("stopped through ROS 2 (the stop service)")
        except Exception as exc:  # the link is down: the cart may not have stopped
            log.warning("the stop service could not stop the cart: %s", exc)
            return reply(request, False, f"not stopped: {exc}")
        return reply(request, True, "stopped")

    def _reset_odometry(self, request: t.TriggerRequest) -> t.TriggerResponse:
        """The odometry's pose back to (0, 0, 0): where the map's origin is (SET_POSE)."""
        try:
            pose = self.gateway.set_pose(0.0, 0.0, 0.0)
        except Exception as exc:
            return reply(request, False, f"not reset: {exc}")
        return reply(request, True, f"the pose is ({pose['x']:g}, {pose['y']:g}, {pose['theta']:g})")
