"""The ROS 2 bridge: a subscriber of the gateway's messages that publishes them on DDS, and the
readers that take commands from the ROS 2 graph (inbound.py).

It never holds up the control path: the gateway's listener only queues the message (its
listeners run in the link's and the simulator's reader threads); one worker turns messages into
ROS 2 messages and writes them; a full queue drops the newest and counts them (`dropped`). DDS
writes never wait for a reader (qos.py: reliable writers with a keep-last history)."""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from cart2d.ros2 import convert, qos
from cart2d.ros2 import types as t
from cart2d.ros2.frames import stamp, static_transforms
from cart2d.ros2.inbound import CommandsGateway, Inbound
from cart2d.ros2.names import Ros2Options
from cart2d.ros2.node import RosNode
from cart2d.ros2.urdf import robot_description

log = logging.getLogger(__name__)

QUEUE_LENGTH = 2048  # ~40 s of telemetry (25 Hz) and truth (50 Hz) with a stalled worker
_STOP = object()


class GatewayLike(CommandsGateway, Protocol):
    """What the bridge needs of a Gateway (cart2d/gateway/core.py)."""

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]: ...
    def mission_view(self) -> dict[str, Any]: ...


class Writers:
    """The bridge's publishers, one a topic."""

    def __init__(self, node: RosNode) -> None:
        o = node.options
        self.odom = node.writer(o.topic("odom"), t.Odometry, qos.stream())
        self.tf = node.writer(o.topic("tf"), t.TFMessage, qos.stream(100))
        self.tf_static = node.writer(o.topic("tf_static"), t.TFMessage, qos.latched())
        self.joint_states = node.writer(o.topic("joint_states"), t.JointState, qos.stream())
        self.robot_description = node.writer(o.topic("robot_description"), t.String, qos.latched())
        self.plan = node.writer(o.topic("plan"), t.Path, qos.stream(1))


class Bridge:
    """One gateway's ROS 2 node, from start() to close()."""

    def __init__(
        self,
        gateway: GatewayLike,
        options: Ros2Options,
        clock: Callable[[], float] = time.time,
        command_clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.gateway = gateway
        self.options = options
        self.clock = clock  # stamps: the wall clock, as ROS tools without /clock expect
        self.node = RosNode(options)
        self.writers = Writers(self.node)
        self.inbound = Inbound(self.node, gateway, command_clock)  # the clock of cmd_vel's silences
        self.published = 0
        self.dropped = 0
        self._queue: queue.Queue[Any] = queue.Queue(QUEUE_LENGTH)
        self._angles = convert.WheelAngles()
        self._worker = threading.Thread(target=self._work, name="ros2 publisher", daemon=True)
        self._unsubscribe: Callable[[], None] | None = None

    def start(self) -> Bridge:
        now = stamp(self.clock())
        self.writers.tf_static.write(static_transforms(self.options, now))
        self.writers.robot_description.write(t.String(robot_description(self.options)))
        self.node.announce()
        self._worker.start()
        self.inbound.start()
        self._unsubscribe = self.gateway.subscribe(self.on_message)
        self._put({"type": "mission", **self.gateway.mission_view()})
        return self

    def close(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        if self._worker.is_alive():
            self._queue.put(_STOP)
            self._worker.join(timeout=5.0)
        self.inbound.close()
        self.node.close()
        if self.dropped:
            log.warning("the ROS 2 bridge dropped %d messages it could not keep up with", self.dropped)

    def on_message(self, message: dict[str, Any]) -> None:
        """The gateway's listener: queues, never waits."""
        self._put(message)

    def _put(self, item: Any) -> None:
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1

    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            try:
                self._publish(item)
            except Exception:  # one bad message must not end the bridge
                log.exception("the ROS 2 bridge could not publish a %s message", item.get("type"))

    def _publish(self, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "telemetry":
            self._publish_telemetry(message)
        elif kind in ("hello", "mission"):
            self.writers.plan.write(convert.path(self.options, stamp(self.clock()), message.get("plan")))
        else:
            return
        self.published += 1

    def _publish_telemetry(self, tel: dict[str, Any]) -> None:
        now = stamp(self.clock())
        self._angles.update(tel)
        w = self.writers
        w.odom.write(convert.odometry(self.options, now, tel))
        w.tf.write(convert.moving_transforms(self.options, now, tel, self._angles))
        w.joint_states.write(convert.joint_state(now, self._angles, tel))
