"""The ROS 2 bridge: a subscriber of the gateway's messages that publishes them on DDS, and the
readers that take commands from the ROS 2 graph (inbound.py).

It never holds up the control path: the gateway's listener only queues the message (its
listeners run in the link's and the simulator's reader threads); one worker turns messages into
ROS 2 messages and writes them; a full queue drops the newest and counts them (`dropped`). DDS
writes never wait for a reader (qos.py: reliable writers with a keep-last history)."""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from cart2d.maps.occupancy import OccupancyMap
from cart2d.perception.camera_model import Intrinsics
from cart2d.ros2 import convert, grids, qos, sensors
from cart2d.ros2 import types as t
from cart2d.ros2.action import ActionGateway, NavigateToPose
from cart2d.ros2.frames import stamp, static_transforms
from cart2d.ros2.inbound import CommandsGateway, Inbound
from cart2d.ros2.names import Ros2Options
from cart2d.ros2.node import RosNode
from cart2d.ros2.services import ServiceGateway, TriggerServices
from cart2d.ros2.urdf import robot_description

log = logging.getLogger(__name__)

DIAGNOSTICS_PERIOD_S = 1.0  # diagnostic_aggregator's default rate
QUEUE_LENGTH = 2048  # ~40 s of telemetry (25 Hz) and truth (50 Hz) with a stalled worker
_STOP = object()


class GatewayLike(CommandsGateway, ServiceGateway, ActionGateway, Protocol):
    """What the bridge needs of a Gateway (cart2d/gateway/core.py)."""

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]: ...
    def mission_view(self) -> dict[str, Any]: ...
    def map_view(self) -> dict[str, Any]: ...
    def floor_plan(self) -> OccupancyMap | None: ...


class Writers:
    """The bridge's publishers, one a topic."""

    def __init__(self, node: RosNode) -> None:
        o = node.options
        self.odom = node.writer(o.topic("odom"), t.Odometry, qos.stream())
        self.tf = node.writer(o.topic("tf"), t.TFMessage, qos.stream(100))
        self.tf_static = node.writer(o.topic("tf_static"), t.TFMessage, qos.latched())
        self.joint_states = node.writer(o.topic("joint_states"), t.JointState, qos.stream())
        self.robot_description = node.writer(o.topic("robot_description"), t.String, qos.latched())
        # the map and the plan: cart2d's own, not a base's (Nav2 or slam_toolbox publish them then)
        self.plan = None if o.base_only else node.writer(o.topic("plan"), t.Path, qos.stream(1))
        self.map = None if o.base_only else node.writer(o.topic("map"), t.OccupancyGrid, qos.latched())
        self.perceived_map = (
            None if o.base_only else node.writer(o.topic("perceived_map"), t.OccupancyGrid, qos.latched())
        )
        # the pose filter's pose in map (AMCL's amcl_pose, robot_localization's): a base leaves it
        self.pose = (
            None if o.base_only else node.writer(o.topic("pose"), t.PoseWithCovarianceStamped, qos.stream(1))
        )
        self.scan = node.writer(o.topic("scan"), t.LaserScan, qos.stream(5))
        self.image = node.writer(o.topic("camera/image/compressed"), t.CompressedImage, qos.stream(2))
        self.camera_info = node.writer(o.topic("camera/camera_info"), t.CameraInfo, qos.stream(2))
        self.diagnostics = node.writer(o.topic("diagnostics"), t.DiagnosticArray, qos.stream())
        self.rosout = node.writer(o.topic("rosout"), t.Log, qos.rosout())


@dataclass(frozen=True)
class _CameraFrame:
    jpeg: bytes


@dataclass(frozen=True)
class _LogLine:
    record: logging.LogRecord


class _RosoutHandler(logging.Handler):
    """The gateway's log lines for /rosout (not the bridge worker's own: a line it logs while
    publishing one would come round again)."""

    def __init__(self, bridge: Bridge) -> None:
        super().__init__(logging.INFO)
        self.bridge = bridge

    def emit(self, record: logging.LogRecord) -> None:
        if threading.current_thread() is not self.bridge.worker:
            self.bridge.put(_LogLine(record))


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
        self.services = TriggerServices(self.inbound, gateway)
        self.action = None if options.base_only else NavigateToPose(self.inbound, gateway, clock)
        self.published = 0
        self.dropped = 0
        self._queue: queue.Queue[Any] = queue.Queue(QUEUE_LENGTH)
        self._angles = convert.WheelAngles()
        self._pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the latest telemetry's
        self._resets: list[dict[str, Any]] = []
        self._map_to_odom = (0.0, 0.0, 0.0)  # the pose filter's (a "localisation" message), else none
        self._diagnosed_s = -math.inf
        self.worker = threading.Thread(target=self._work, name="ros2 publisher", daemon=True)
        self._log_handler = _RosoutHandler(self)
        self._unsubscribe: list[Callable[[], None]] = []

    def start(self) -> Bridge:
        now = stamp(self.clock())
        self.writers.tf_static.write(static_transforms(self.options, now))
        self.writers.robot_description.write(t.String(robot_description(self.options)))
        self.node.announce()
        self.worker.start()
        self.inbound.start()
        self.put({"type": "map"})
        self._unsubscribe.append(self.gateway.subscribe(self.on_message))
        add_camera_sink = getattr(self.gateway, "add_camera_sink", None)  # a gateway that may see
        if add_camera_sink is not None:
            self._unsubscribe.append(add_camera_sink(lambda shown: self.put(_CameraFrame(shown.jpeg))))
        self.put({"type": "mission", **self.gateway.mission_view()})
        logging.getLogger("cart2d").addHandler(self._log_handler)
        return self

    def close(self) -> None:
        logging.getLogger("cart2d").removeHandler(self._log_handler)
        while self._unsubscribe:
            self._unsubscribe.pop()()
        if self.worker.is_alive():
            self._queue.put(_STOP)
            self.worker.join(timeout=5.0)
        self.inbound.close()
        self.node.close()
        if self.dropped:
            log.warning("the ROS 2 bridge dropped %d messages it could not keep up with", self.dropped)

    def on_message(self, message: dict[str, Any]) -> None:
        """The gateway's listener: queues, never waits."""
        self.put(message)

    def put(self, item: Any) -> None:
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
                log.exception("the ROS 2 bridge could not publish %s", type(item).__name__)

    def _publish(self, item: Any) -> None:
        now = stamp(self.clock())
        w = self.writers
        if isinstance(item, _CameraFrame):
            w.image.write(sensors.compressed_image(self.options, now, item.jpeg))
            w.camera_info.write(sensors.camera_info(self.options, now, self._intrinsics()))
        elif isinstance(item, _LogLine):
            w.rosout.write(sensors.log_line(now, item.record))
        else:
            self._publish_message(now, item)
        self.published += 1

    def _publish_message(self, now: t.Time, message: dict[str, Any]) -> None:
        if self.action is not None:
            self.action.on_message(message)
        kind = message.get("type")
        w = self.writers
        if kind == "telemetry":
            self._publish_telemetry(message)
        elif kind in ("hello", "mission") and w.plan is not None:
            w.plan.write(convert.path(self.options, now, message.get("plan")))
        elif kind == "map" and w.map is not None:
            w.map.write(grids.map_grid(self.options, now, self.gateway.map_view(), self.gateway.floor_plan()))
        elif kind == "perceived" and w.perceived_map is not None:
            w.perceived_map.write(grids.perceived_grid(self.options, now, self.gateway.map_view(), message))
        elif kind == "camera":
            w.scan.write(sensors.virtual_scan(self.options, now, message, self._pose))
        elif kind == "reset":
            self._resets = [*self._resets[-9:], message]
        elif kind == "localisation":
            self._localised(now, message)

    def _localised(self, now: t.Time, message: dict[str, Any]) -> None:
        """The pose filter's map -> odom, sent with every odom -> base_footprint from now on; its
        pose and covariance while the pose is trusted."""
        x, y, yaw = (float(v) for v in message["map_to_odom"])
        if all(math.isfinite(v) for v in (x, y, yaw)):
            self._map_to_odom = (x, y, yaw)
        pose, covariance = message.get("pose"), message.get("covariance") or []
        if (
            self.writers.pose is not None
            and message.get("trusted")
            and pose is not None
            and len(covariance) == 9
        ):
            self.writers.pose.write(convert.pose_with_covariance(self.options, now, pose, covariance))

    def _intrinsics(self) -> Intrinsics | None:
        seeing = getattr(self.gateway, "seeing", None)
        calibration = getattr(seeing, "calibration", None)
        return calibration.intrinsics if calibration is not None else None

    def _publish_telemetry(self, tel: dict[str, Any]) -> None:
        seconds = self.clock()
        now = stamp(seconds)
        self._angles.update(tel)
        self._pose = (float(tel["x"]), float(tel["y"]), float(tel["theta"]))
        w = self.writers
        w.odom.write(convert.odometry(self.options, now, tel))
        w.tf.write(convert.moving_transforms(self.options, now, tel, self._angles, self._map_to_odom))
        w.joint_states.write(convert.joint_state(now, self._angles, tel))
        if seconds - self._diagnosed_s >= DIAGNOSTICS_PERIOD_S:
            self._diagnosed_s = seconds
            w.diagnostics.write(sensors.diagnostics(now, tel, self._resets, link_up=True))
