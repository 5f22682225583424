"""The gateway's live data on Foxglove channels (channels.py): a listener of Gateway.subscribe.

The gateway's listeners must not block (they run in the link's and the simulator's reader
threads), so the listener only stamps a message and queues it; one worker thread turns the
messages into Foxglove messages and logs them, in the order they came. A full queue (a worker
that cannot keep up) drops the newest messages and counts them (`dropped`).

Times: every message's log time (and the timestamp of its header) is the session's clock
(clock.py: the wall clock, or in simulation the simulator's time) when the gateway handed it
over; it never decreases within a session. A camera frame's header keeps the time it was taken.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol

import foxglove
from foxglove import messages as fm

from cart2d.gateway.messages import SimWorldMessage, wire
from cart2d.recording import channels as c
from cart2d.recording.clock import SessionClock

QUEUE_LENGTH = 4096  # ~40 s of telemetry (25 Hz) and truth (50 Hz) with a stalled worker
_STOP = object()

# The gateway's events, as a line of the Log channel (the panel shows them as toasts).
_LOG_LEVELS = {
    logging.DEBUG: fm.LogLevel.Debug,
    logging.INFO: fm.LogLevel.Info,
    logging.WARNING: fm.LogLevel.Warning,
    logging.ERROR: fm.LogLevel.Error,
    logging.CRITICAL: fm.LogLevel.Fatal,
}


class GatewayLike(Protocol):
    """What the publisher needs of a Gateway (cart2d/gateway/core.py)."""

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]: ...
    def map_view(self) -> dict[str, Any]: ...
    def floor_plan(self) -> Any: ...


class Publisher:
    """Publishes one gateway's live data on the channels of `context` until close()."""

    def __init__(self, gateway: GatewayLike, context: foxglove.Context, simulated: bool = False) -> None:
        self.gateway = gateway
        self.clock = SessionClock(simulated)
        self.channels = c.Channels(context)
        self.published = 0  # messages handed to the worker
        self.dropped = 0
        self._queue: queue.Queue[tuple[int, Any]] = queue.Queue(QUEUE_LENGTH)
        self._stamp_lock = threading.Lock()  # stamped and queued in one order
        self._mission_state = ""
        self._plan: Any = None
        self._worker = threading.Thread(target=self._work, name="foxglove publisher", daemon=True)
        self._log_handler = _LogHandler(self)
        self._unsubscribe: Callable[[], None] | None = None

    def start(self) -> Publisher:
        self._worker.start()
        self.refresh_map()
        self._put_world()
        self._unsubscribe = self.gateway.subscribe(self.on_message)
        logging.getLogger("cart2d").addHandler(self._log_handler)
        return self

    def close(self) -> None:
        """Stops listening and publishes what is queued."""
        logging.getLogger("cart2d").removeHandler(self._log_handler)
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        if self._worker.is_alive():
            self._queue.put((0, _STOP))
            self._worker.join(timeout=10.0)

    # -- the producers' side: never blocks ------------------------------------------------------
    def _put(self, item: Any) -> None:
        with self._stamp_lock:
            truth_t = item.get("t") if isinstance(item, dict) and item.get("type") == "truth" else None
            ns = self.clock.truth_ns(float(truth_t)) if truth_t is not None else self.clock.now_ns()
            try:
                self._queue.put_nowait((ns, item))
                self.published += 1
            except queue.Full:
                self.dropped += 1

    def on_message(self, message: dict[str, Any]) -> None:
        """A /ws message of the gateway (Gateway.subscribe's listener)."""
        self._put(message)

    def refresh_map(self) -> None:
        """Publishes the map again (at start, and for a viewer that subscribes to it later)."""
        self._put(_MapRefresh())

    def _put_world(self) -> None:
        """In simulation, the boxes standing at the start, as a /ws `sim_world` message (the panel
        fetches them; viewers are told only of changes)."""
        world = getattr(self.gateway, "world", None)  # collaborators.SimulatedWorld, in simulation
        view = world.boxes_view() if world is not None else None
        if view is not None:
            self._put(wire(SimWorldMessage(**view)))

    def publish_camera_jpeg(self, jpeg: bytes, stamp_ns: int) -> None:
        """A camera frame, JPEG-encoded, taken at `stamp_ns` (wall clock, ns)."""
        self._put(_CameraFrame(jpeg, stamp_ns))

    def publish_log(self, level: int, name: str, text: str) -> None:
        self._put(_LogLine(level, name, text))

    # -- the worker ----------------------------------------------------------------------------
    def _work(self) -> None:
        while True:
            ns, item = self._queue.get()
            if item is _STOP:
                return
            try:
                self._publish(ns, item)
            except Exception:  # one bad message must not end the recording
                logging.getLogger(__name__).exception("could not publish %r", item)

    def _publish(self, ns: int, item: Any) -> None:
        ch = self.channels
        if isinstance(item, _MapRefresh):
            self._publish_map(ns, self.gateway.map_view())
        elif isinstance(item, _CameraFrame):
            image = fm.CompressedImage(
                timestamp=c.stamp(item.stamp_ns), frame_id=c.CAMERA_FRAME, data=item.jpeg, format="jpeg"
            )
            ch.camera.log(image, log_time=ns)
        elif isinstance(item, _LogLine):
            line = fm.Log(
                timestamp=c.stamp(ns),
                level=_LOG_LEVELS.get(item.level, fm.LogLevel.Info),
                message=item.text,
                name=item.name,
            )
            ch.log.log(line, log_time=ns)
        else:
            self._publish_ws(ns, item)

    def _publish_ws(self, ns: int, message: dict[str, Any]) -> None:
        ch = self.channels
        kind = message.get("type")
        if kind == "map":
            self._publish_map(ns, self.gateway.map_view())  # before the message that says it changed
        ch.ws.log(message, log_time=ns)
        if kind == "telemetry":
            x, y, theta = (float(message[k]) for k in ("x", "y", "theta"))
            ch.tf.log(c.frame_tree(ns, x, y, theta), log_time=ns)
            ch.odom_pose.log(
                fm.PoseInFrame(timestamp=c.stamp(ns), frame_id=c.ODOM_FRAME, pose=c.pose(x, y, theta)),
                log_time=ns,
            )
            ch.telemetry.log({k: v for k, v in message.items() if k != "type"}, log_time=ns)
        elif kind == "truth":
            x, y, theta = (float(message[k]) for k in ("x", "y", "theta"))
            ch.truth_pose.log(
                fm.PoseInFrame(timestamp=c.stamp(ns), frame_id=c.MAP_FRAME, pose=c.pose(x, y, theta)),
                log_time=ns,
            )
        elif kind == "mission":
            self._publish_mission(ns, message)
        elif kind in _EVENT_WORDS:
            self._log_event(ns, logging.INFO, _EVENT_WORDS[kind](message))

    def _publish_mission(self, ns: int, message: dict[str, Any]) -> None:
        plan = message.get("plan")
        if plan != self._plan:
            self._plan = plan
            points = [plan["start"], *plan["waypoints"]] if plan else []
            self.channels.plan_scene.log(c.path_scene(ns, points), log_time=ns)
            poses = fm.PosesInFrame(
                timestamp=c.stamp(ns), frame_id=c.MAP_FRAME, poses=[c.pose(p[0], p[1]) for p in points]
            )
            self.channels.plan_poses.log(poses, log_time=ns)
        state = str(message.get("state", ""))
        if state != self._mission_state:
            self._mission_state = state
            reason = message.get("reason") or ""
            level = logging.WARNING if state == "failed" else logging.INFO
            self._log_event(ns, level, f"mission {state}" + (f": {reason}" if reason else ""))

    def _log_event(self, ns: int, level: int, text: str) -> None:
        line = fm.Log(timestamp=c.stamp(ns), level=_LOG_LEVELS[level], message=text, name="cart2d.gateway")
        self.channels.log.log(line, log_time=ns)

    def _publish_map(self, ns: int, view: dict[str, Any]) -> None:
        ch = self.channels
        ch.map_view.log(view, log_time=ns)
        ch.map_nodes.log(c.node_grid(ns, view), log_time=ns)
        plan = self.gateway.floor_plan()
        if plan is not None:
            grid = c.occupancy_grid(
                ns, plan.origin_m, plan.resolution_m, plan.width, plan.cells.tobytes(), signed=True
            )
            ch.map_floor_plan.log(grid, log_time=ns)


_EVENT_WORDS: dict[str, Callable[[dict[str, Any]], str]] = {
    "replan": lambda m: f"replanned ({m.get('reason', '')}): {m.get('outcome', '')}",
    "reset": lambda m: str(m.get("message") or f"the MCU restarted ({m.get('cause_words', '')})"),
    "routine": lambda m: f"reset routine {m.get('state', '')}: {m.get('words', '')}",
    "pose_trust": lambda m: f"pose trusted ({m.get('how', '')})" if m.get("trusted") else "pose untrusted",
    "simulator": lambda m: f"simulator {m.get('state', '')}: {m.get('message', '')}",
    "goal": lambda m: (
        f"goal {m.get('index')} of {m.get('of')} {m.get('goal')} {m.get('state', '')}"
        + (f": {m['reason']}" if m.get("reason") else "")
    ),
}


class _MapRefresh:
    pass


class _CameraFrame:
    def __init__(self, jpeg: bytes, stamp_ns: int) -> None:
        self.jpeg = jpeg
        self.stamp_ns = stamp_ns


class _LogLine:
    def __init__(self, level: int, name: str, text: str) -> None:
        self.level = level
        self.name = name
        self.text = text


class _LogHandler(logging.Handler):
    """The cart2d loggers' records on the Log channel."""

    def __init__(self, publisher: Publisher) -> None:
        super().__init__(logging.INFO)
        self.publisher = publisher

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.startswith("cart2d.recording"):
            return  # the publisher's own troubles would feed themselves
        self.publisher.publish_log(record.levelno, record.name, record.getMessage())
