"""Paths of any length streamed into the firmware's waypoint window (docs/protocol.md, "Paths and
the waypoint window"), over a line that may lose requests and replies: frames sized to the
line's measured error rate, and a stream that rides out a link that recovers within
LINK_GRACE_S."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence

from cart2d.link.firmware import mode_name, read_status, read_version
from cart2d.link.transport import CommandRefused, Link, LinkError, LinkTimeout, MotionCancelled

# How many (x, y) points one frame carries (31 floats at most: the count or index, then pairs).
POINTS_PER_FRAME = 15

# docs/protocol.md, "Paths and the waypoint window": a path has at most this many points.
MAX_PATH_POINTS = 65535
# How often the stream looks at the cart's progress (the latest telemetry frame), and after how
# long without a frame it reads STATUS instead (telemetry off, or late).
STREAM_POLL_S = 0.005
TELEMETRY_STALE_S = 0.15
STATUS_POLL_S = 0.04
# A stream whose requests go unanswered this long (timeouts, a port reopening) ends, and says so;
# a link that recovers sooner costs the cart a slowdown at most (it stops on the last point it has).
LINK_GRACE_S = 5.0
# The bytes of an XY_APPEND of k points (0x7E, LEN, SEQ, CMD, ARGC, the index, 2k floats, CRC)
# and of its reply (three results).
APPEND_BYTES = 11
APPEND_BYTES_PER_POINT = 8
APPEND_REPLY_BYTES = 20

Point = tuple[float, float]


def frame_points(byte_error_rate: float) -> int:
    """Points per frame that move the most points per try when each byte is lost with this
    probability: every byte of the frame and of its reply must arrive, so k points get through
    with probability q^(31 + 8k), q = 1 - e, and k q^(31 + 8k) is largest at k = -1 / (8 ln q):
    12 points at 1 %, 2 at 5 %, every 15 on a clean line."""
    if byte_error_rate <= 0.0:
        return POINTS_PER_FRAME
    best = -1.0 / (APPEND_BYTES_PER_POINT * math.log1p(-min(byte_error_rate, 0.5)))
    return max(1, min(POINTS_PER_FRAME, int(best)))


class PathStream:
    """A path of any length streamed into the firmware's waypoint window (docs/protocol.md,
    "Paths and the waypoint window"). start() sends WAIT_XY_ARRAY with the first frame and
    XY_APPEND while the window has room; if points remain, a thread of its own keeps the window
    full as the cart passes waypoints, until every point is sent, the firmware leaves PATH mode,
    the path is replaced, or cancel(). It follows the cart by telemetry's waypoint index and
    mode, and by STATUS when no frame has come for TELEMETRY_STALE_S (telemetry off). Its
    requests go through the link, one outstanding at a time like any other, and belong to the
    stop generation `token` (Link.motion_token(); default: now): a STOP ends the stream, and
    none of its frames follows that STOP. Its frames carry as many points as the line's error
    rate makes worth it (frame_points); a request whose reply never came is settled by STATUS
    (did it arrive?), and only LINK_GRACE_S without any answer ends the stream."""

    def __init__(self, link: Link, points: Sequence[Point], token: int | None = None) -> None:
        if not 1 <= len(points) <= MAX_PATH_POINTS:
            raise ValueError(f"a path has 1 to {MAX_PATH_POINTS} points, not {len(points)}")
        self.link = link
        self.token = link.motion_token() if token is None else token
        self.points = [(float(x), float(y)) for x, y in points]
        self.sent = 0  # points the firmware has received
        self.index = 0  # the current waypoint, as last seen
        self.window = 0  # the window's size W, learnt from the first reply (0: the path fitted)
        self.appends = 0
        self.status_reads = 0
        self.ended = ""  # why it stopped before every point was sent ("" while running or when done)
        self.failure = ""  # the same when it leaves the cart waiting for points it will not get
        self.done = threading.Event()  # nothing more will be sent
        self._cancelled = threading.Event()
        self._send_lock = threading.Lock()  # held from the cancel check to the append's reply
        self._thread: threading.Thread | None = None
        self._answered = time.monotonic()  # when the firmware last answered the stream

    @property
    def count(self) -> int:
        return len(self.points)

    @property
    def sending(self) -> bool:
        """Points are still to be sent (and the stream has not ended)."""
        return not self.done.is_set()

    def start(self) -> PathStream:
        """Sends the path's beginning; raises CommandRefused, LinkError or MotionCancelled (then
        nothing of it, or only its first frame, reached the firmware: a refused WAIT_XY_ARRAY
        changes nothing)."""
        first = self.points[: self._frame()]
        args = [self.count, *[c for p in first for c in p]]
        deadline = time.monotonic() + LINK_GRACE_S
        while True:
            try:
                reply = self.link.call("WAIT_XY_ARRAY", *args, token=self.token)
            except LinkTimeout:
                arrived = self._begun(len(first))  # its reply was lost: did it arrive?
                while arrived is None and time.monotonic() < deadline:
                    arrived = self._begun(len(first))
                if arrived:
                    return self._go_on(self._room())
                if arrived is None or time.monotonic() > deadline:
                    raise
                continue  # it did not arrive: sent again, as a new request
            received, index, room = (int(v) for v in reply)
            self.sent, self.index = received, index
            if received + room < self.count:
                self.window = received + room  # at index 0 the window starts at point 0
            return self._go_on(room)

    def _begun(self, first: int) -> bool | None:
        """After a WAIT_XY_ARRAY whose reply never came: whether STATUS shows the firmware
        driving a path of this count with the first frame's points (then the stream goes on from
        there; else it is sent again, as a new request: the firmware has forgotten the lost one);
        None if STATUS went unanswered too (sent again, it could restart a path begun)."""
        try:
            status = read_status(self.link)
        except LinkTimeout:
            return None
        if status.mode != "PATH" or status.waypoint_count != self.count or status.waypoints_received != first:
            return False
        self.sent, self.index = first, status.waypoint_index
        if first < self.count:
            self.window = read_version(self.link).waypoint_capacity
        return True

    def _frame(self) -> int:
        return frame_points(self.link.line.byte_error_rate())

    def resumed(self, index: int, received: int, token: int | None = None) -> PathStream:
        """A stream of the rest of this path, from the firmware's `index` and `received` on, once
        a START resumed the path that a STOP ended this stream of; its frames belong to `token`."""
        stream = PathStream(self.link, self.points, token)
        stream.sent, stream.index, stream.window = received, index, self.window
        return stream._go_on(stream._room())

    def _go_on(self, room: int) -> PathStream:
        """Fills the window's `room` now; the rest, if any, from a thread of its own."""
        frames_seen = self.link.telemetry_count
        self._fill(room)
        if self.sent >= self.count:
            self.done.set()
        elif not self.done.is_set():
            self._thread = threading.Thread(
                target=self._run, args=(frames_seen,), name="path stream", daemon=True
            )
            self._thread.start()
        return self

    def cancel(self) -> None:
        """Stops streaming: no XY_APPEND is sent once this returns (send it before replacing the
        path: the firmware would take an old append whose index fits for the new path's)."""
        self._cancelled.set()
        with self._send_lock:
            pass
        if not self.done.is_set():
            self._end("cancelled")

    def join(self, timeout_s: float | None = None) -> bool:
        """Waits until nothing more will be sent; True if so."""
        return self.done.wait(timeout_s)

    # -- the thread ------------------------------------------------------------------------------
    @property
    def _batch(self) -> int:
        # Points worth a request of their own: a quarter of the window (8 of 32) keeps at least
        # three quarters of it ahead of the cart with a quarter of the requests of one per point.
        return max(1, self.window // 4)

    def _room(self) -> int:
        base = max(self.index - 1, 0)
        return max(0, min(self.count, base + self.window) - self.sent)

    def _end(self, why: str, failure: bool = False) -> None:
        self.ended = why
        if failure:
            self.failure = why
        self.done.set()

    def _fill(self, room: int) -> None:
        """XY_APPEND frames while the window has room (as the last reply said)."""
        while room > 0 and self.sent < self.count:
            chunk = self.points[self.sent : self.sent + min(room, self._frame())]
            with self._send_lock:
                if self._cancelled.is_set():
                    return
                try:
                    reply = self.link.call(
                        "XY_APPEND", self.sent, *[c for p in chunk for c in p], token=self.token
                    )
                except MotionCancelled:
                    self._end("stopped")
                    return
                except CommandRefused as exc:
                    self._end(
                        f"the firmware refused the path's points {self.sent} on ({exc}): "
                        "the path was replaced or changed by another sender",
                        failure=True,
                    )
                    return
                except LinkError:
                    self._resync()  # did it arrive? (a port reopening: STATUS fails too, and waits)
                    return
            self._answered = time.monotonic()
            self.appends += 1
            received, index, room = (int(v) for v in reply)
            if received != self.sent + len(chunk):
                self._end(f"the firmware holds {received} points, not {self.sent + len(chunk)}", failure=True)
                return
            self.sent, self.index = received, max(self.index, index)

    def _resync(self) -> None:
        """STATUS: the cart's progress, and after an XY_APPEND whose reply never came, whether it
        arrived. Unanswered, the stream waits for the link to recover (the thread asks again)
        and ends only once LINK_GRACE_S have passed without any answer."""
        try:
            status = read_status(self.link)
        except (LinkError, CommandRefused) as exc:
            silent_s = time.monotonic() - self._answered
            if silent_s > LINK_GRACE_S:
                self._end(
                    f"the link failed while streaming the path: no answer for {silent_s:.1f} s ({exc})",
                    failure=True,
                )
            return
        self._answered = time.monotonic()
        self.status_reads += 1
        self._follow(status.mode, status.waypoint_index, status.waypoint_count, status.waypoints_received)

    def _follow(self, mode: str, index: int, count: int | None = None, received: int | None = None) -> None:
        """The cart's progress, from telemetry (mode and index) or STATUS (all four). A telemetry
        frame may be older than the last XY_APPEND's reply (frames reach the listeners through a
        thread of their own, and one may wait behind a reply on the wire): an index behind the
        one known is stale, not a sign of another path, and a mode other than PATH is checked with
        STATUS. STATUS is answered in turn with the appends: a count or an index that went back
        there means another sender's path."""
        stale = count is None and index < self.index
        if mode != "PATH" and count is None:
            self._resync()  # a frame from before the path began says IDLE too: STATUS decides
        elif mode != "PATH":
            self._end(f"the firmware left PATH mode ({mode}) with {self.count - self.sent} points unsent")
        elif count is not None and (index < self.index or count != self.count):
            self._end("the path was replaced by another sender", failure=True)
        elif stale:
            return
        elif received is not None and received != self.sent:
            if self.sent <= received <= self.sent + POINTS_PER_FRAME:
                self.sent = received  # an append whose reply was lost had arrived
            else:
                self._end(f"the firmware holds {received} points, {self.sent} were sent", failure=True)
        else:
            self.index = index

    def _run(self, frames_seen: int) -> None:
        last_news = time.monotonic()
        last_status = 0.0
        while not self._cancelled.is_set() and not self.done.is_set():
            now = time.monotonic()
            frame = self.link.telemetry
            if self.link.telemetry_count != frames_seen and frame is not None:
                frames_seen = self.link.telemetry_count
                last_news = now
                self._follow(mode_name(frame.mode), int(frame.waypoint_index))
            elif now - last_news > TELEMETRY_STALE_S and now - last_status > STATUS_POLL_S:
                last_status = now
                self._resync()
            else:
                time.sleep(STREAM_POLL_S)
                continue
            room = self._room()
            if not self.done.is_set() and room >= min(self._batch, self.count - self.sent):
                self._fill(room)
                if self.sent >= self.count:
                    self.done.set()


def upload_path(link: Link, points: Sequence[Point], token: int | None = None) -> PathStream:
    """Sends a path of any length (PathStream): returns once its first frame and as many points
    as the window holds have arrived; the rest follows from the stream's thread. Its frames
    belong to the stop generation `token` (default: now): a STOP before the first raises
    MotionCancelled, and the path never starts; a STOP later ends the stream."""
    return PathStream(link, points, token).start()
