"""What the ROS 2 graph asks of the cart: cmd_vel (Twist, Jazzy's teleop; TwistStamped, Kilted's),
goal_pose (RViz's "2D Goal Pose"), initialpose (RViz's "2D Pose Estimate"), on one reading thread.

Nothing here waits on the link: cmd_vel goes to the driver (drive.py), goals and poses to a
worker of their own (a goal is planned, which takes time). A sample that cannot be read (a writer
of another layout under the same type name), or whose numbers are not finite, is dropped with a
log line and changes nothing."""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.sub import DataReader
from cyclonedds.util import duration

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.drive import CmdVelGate, Driver
from cart2d.ros2.frames import yaw_of
from cart2d.ros2.limits import KnownLimits
from cart2d.ros2.node import RosNode

log = logging.getLogger(__name__)

POLL_S = 0.1  # the reading thread looks for close() this often
TAKEN_A_ROUND = 64  # samples of one reader taken before the next reader's
TASKS = 16  # goals and poses waiting for the worker; more are dropped (a flood of clicks)
_STOP = object()


class CommandsGateway(Protocol):
    def drive(self, v_mps: float, omega_radps: float, token: int | None = None) -> None: ...
    def motion_token(self) -> int: ...
    def firmware_settings(self) -> list[dict[str, object]]: ...
    def go_to(self, x: float, y: float, token: int | None = None) -> Any: ...
    def set_pose(self, x: float, y: float, theta: float) -> dict[str, float]: ...


def finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


class Tasks:
    """Goals and poses, one at a time on a thread of their own."""

    def __init__(self) -> None:
        self._queue: queue.Queue[Any] = queue.Queue(TASKS)
        self._thread = threading.Thread(target=self._run, name="ros2 requests", daemon=True)

    def start(self) -> Tasks:
        self._thread.start()
        return self

    def offer(self, what: str, task: Callable[[], None]) -> None:
        try:
            self._queue.put_nowait((what, task))
        except queue.Full:
            log.warning("%s dropped: %d requests are waiting already", what, TASKS)

    def close(self) -> None:
        self._queue.put(_STOP)
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while (item := self._queue.get()) is not _STOP:
            what, task = item
            try:
                task()
            except Exception as exc:  # the gateway's refusal: a pose beyond the walls, no route
                log.warning("%s failed: %s", what, exc)


class Inbound:
    """The readers of one node, and the thread that takes their samples."""

    def __init__(
        self, node: RosNode, gateway: CommandsGateway, clock: Callable[[], float] = time.monotonic
    ) -> None:
        o = node.options
        self.node = node
        self.gateway = gateway
        self.limits = KnownLimits(gateway.firmware_settings)  # never read on the command's path
        self.gate = CmdVelGate(gateway.motion_token, self.limits, clock)
        self.driver = Driver(self._drive)
        self.tasks = Tasks()
        self.dropped = 0  # malformed samples
        self.handlers: list[tuple[DataReader[Any], Callable[[Any], None]]] = []
        self.add(node.reader(o.topic("cmd_vel"), t.Twist, qos.commands()), self._on_twist)
        self.add(node.reader(o.topic("cmd_vel"), t.TwistStamped, qos.commands()), self._on_twist_stamped)
        if not o.base_only:  # goals and the pose are Nav2's otherwise
            self.add(node.reader(o.topic("goal_pose"), t.PoseStamped, qos.requests()), self._on_goal)
            self.add(
                node.reader(o.topic("initialpose"), t.PoseWithCovarianceStamped, qos.requests()),
                self._on_pose,
            )
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ros2 readers", daemon=True)

    def add(self, reader: DataReader[Any], handler: Callable[[Any], None]) -> None:
        """Calls handler(sample) on the reading thread for each sample of `reader` (before start())."""
        self.handlers.append((reader, handler))

    def start(self) -> Inbound:
        self.limits.start()
        self.driver.start()
        self.tasks.start()
        self._thread.start()
        return self

    def close(self) -> None:
        self._closed.set()
        self._thread.join(timeout=5.0)
        self.driver.close()
        self.limits.close()
        self.tasks.close()

    # -- the reading thread --------------------------------------------------------------------
    def _run(self) -> None:
        waitset = WaitSet(self.node.participant)
        mask = SampleState.NotRead | ViewState.Any | InstanceState.Any
        for reader, _ in self.handlers:
            waitset.attach(ReadCondition(reader, mask))
        while not self._closed.is_set():
            waitset.wait(duration(seconds=POLL_S))
            for reader, handler in self.handlers:
                self._take(reader, handler)

    def _take(self, reader: DataReader[Any], handler: Callable[[Any], None]) -> None:
        for _ in range(TAKEN_A_ROUND):  # then the other readers' turn: a flood on one starves none
            try:
                samples = reader.take(1)
            except Exception as exc:  # a sample of another layout: cyclonedds cannot read it
                self.dropped += 1
                log.warning("a malformed sample on %s was dropped: %s", reader.topic.name, exc)
                continue
            if not samples:
                return
            if not isinstance(samples[0], reader.topic.data_type):
                continue  # a writer gone (an InvalidSample: no data)
            try:
                handler(samples[0])
            except Exception:
                log.exception("a sample on %s could not be handled", reader.topic.name)

    # -- the topics ----------------------------------------------------------------------------
    def _on_twist(self, twist: t.Twist) -> None:
        command = self.gate.admit(twist.linear.x, twist.angular.z)
        if command is not None:
            self.driver.offer(command)

    def _drive(self, v_mps: float, omega_radps: float, token: int) -> None:
        """The driver's send; the limits are read again after it, behind it on the link (a
        setting may have changed: they are the next command's)."""
        try:
            self.gateway.drive(v_mps, omega_radps, token)
        finally:
            self.limits.wake()

    def _on_twist_stamped(self, message: t.TwistStamped) -> None:
        self._on_twist(message.twist)

    def planar(self, topic: str, header: t.Header, pose: t.Pose) -> tuple[float, float, float] | None:
        """(x, y, yaw) of a pose in the map (or odom: the same frame today), else None, logged."""
        o = self.node.options
        if header.frame_id not in (o.frame("map"), o.frame("odom"), ""):
            log.warning("%s dropped: its frame %r is not %r", topic, header.frame_id, o.frame("map"))
            return None
        p, q = pose.position, pose.orientation
        if not finite(p.x, p.y, q.x, q.y, q.z, q.w) or abs(q.x**2 + q.y**2 + q.z**2 + q.w**2 - 1.0) > 0.1:
            log.warning("%s dropped: its position or orientation is not a pose", topic)
            return None
        return p.x, p.y, yaw_of(q)

    def _on_goal(self, goal: t.PoseStamped) -> None:
        where = self.planar("goal_pose", goal.header, goal.pose)
        if where is not None:
            x, y, _ = where
            token = self.gateway.motion_token()  # a stop after this click cancels it
            self.tasks.offer(f"goal_pose ({x:.2f}, {y:.2f})", lambda: self.gateway.go_to(x, y, token))

    def _on_pose(self, message: t.PoseWithCovarianceStamped) -> None:
        where = self.planar("initialpose", message.header, message.pose.pose)
        if where is not None:
            x, y, theta = where
            self.tasks.offer(f"initialpose ({x:.2f}, {y:.2f})", lambda: self._set_pose(x, y, theta))

    def _set_pose(self, x: float, y: float, theta: float) -> None:
        self.gateway.set_pose(x, y, theta)
        log.info("the pose was set from initialpose: (%.3f, %.3f, %.1f deg)", x, y, math.degrees(theta))
