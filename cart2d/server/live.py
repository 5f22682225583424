"""The live data on /ws: telemetry, ground truth and the gateway's events, fanned out to viewers.

Every WebSocket message is a **frame**: a JSON array of messages (`{"type": ...}` objects, oldest
first; the first frame starts with the `hello`). What a viewer costs the gateway is mostly the
send itself (websockets' framing, a write system call), not the bytes, so the fan-out sends one
frame per viewer at most every `interval`, whatever the rate of the messages (telemetry at 25 Hz,
ground truth at 50 simulated Hz: hundreds a second at full simulator speed):

- the gateway's threads only append each message to a queue (one hop into the event loop per
  frame, none per message);
- each frame keeps every **event** (mission, replan, reset, map, ...), of each **sample** kind
  (telemetry, truth) the newest within a budget of SAMPLE_RATE_HZ on average, in bursts of up
  to BURST_SAMPLES (every one at the firmware's 25 Hz and the simulator's 50 Hz in real time,
  and the bursts of a replay; a simulator at full speed is thinned), and the newest of each
  **state** kind (camera, perceived); each message kept is encoded once, and the frame's text is
  built once for every viewer;
- the interval keeps all the viewers together at SENDS_PER_S frames a second at most (one
  viewer: a frame as messages come, 5 ms apart at the least; 100 viewers: 25 frames a second
  each; 200: 12.5), and doubles, up to MAX_FRAME_S, while the event loop is late by more than
  LAG_S (the machine or the loop is busy), so viewers get fewer frames rather than the stop
  waiting for them (the stop's own path is server/motion.py's);
- a viewer whose socket is still full when the next frame comes (it reads slower than frames
  come) gets the frames it missed merged into one, by the same rule: its events all, the newest
  samples. At most MAX_EVENTS_BEHIND events wait for one viewer (one that reads nothing); older
  ones are dropped and counted.

At most MAX_VIEWERS viewers at a time; one more is told so and closed (code 1013, "try again
later"). Below this, the kernel's send buffer of each connection is capped too
(serving.listening_socket).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from starlette.websockets import WebSocket, WebSocketDisconnect

from cart2d.gateway.messages import HelloMessage, wire

MAX_VIEWERS = 256
TRY_AGAIN_LATER = 1013  # RFC 6455 §7.4.1 / IANA: the server is overloaded, try again later
# Frames sent per second, all viewers together: at ~30 us a send (yappi), 75 ms a second of the
# event loop and the GIL. 100 viewers get 25 frames a second, telemetry's own rate.
SENDS_PER_S = 2500.0
MIN_FRAME_S = 0.005  # a burst of messages (truth and telemetry of one tick) in one frame
MAX_FRAME_S = 0.64  # under load: 1.6 frames a second at the least
LAG_S = 0.015  # a frame this late means the loop or the machine is busy
ON_TIME_FRAMES = 25  # frames on time in a row before the interval halves again
SAMPLE_RATE_HZ = 100.0  # of each sample kind on average, at most: truth is 50 Hz, telemetry 25 Hz
BURST_SAMPLES = 64  # of each sample kind in one frame, at most
SAMPLE_KINDS = frozenset({"telemetry", "truth"})
STATE_KINDS = frozenset({"camera", "perceived"})  # each supersedes the one before
MAX_EVENTS_BEHIND = 256  # events held for one viewer that does not read
MERGE_AFTER = 8  # frames a viewer may be behind before they are merged (each merge costs kept())


class Source(Protocol):
    """What the fan-out needs of a gateway (or of a replay's player)."""

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]: ...

    def mission_view(self) -> dict[str, Any]: ...


Item = tuple[str, Any]  # (the message's type, the message or its JSON text)


BURST = {kind: BURST_SAMPLES for kind in SAMPLE_KINDS}


def kept(
    items: Sequence[Item], samples: Mapping[str, int] = BURST, max_events: int = MAX_EVENTS_BEHIND
) -> tuple[list[Item], int]:
    """The items a frame carries, in their order (this module's docstring): every event (at most
    `max_events`, the newest), the newest `samples[kind]` of each sample kind, the newest of each
    state kind; and how many events were dropped."""
    seen: Counter[str] = Counter()
    events = 0
    chosen: list[Item] = []
    for kind, value in reversed(items):  # newest first: the newest of each kind are kept
        seen[kind] += 1
        if kind in SAMPLE_KINDS:
            keep = seen[kind] <= samples.get(kind, 0)
        elif kind in STATE_KINDS:
            keep = seen[kind] == 1
        else:
            events += 1
            keep = events <= max_events
        if keep:
            chosen.append((kind, value))
    chosen.reverse()
    return chosen, max(0, events - max_events)


@dataclass(frozen=True)
class Frame:
    """One WebSocket message: its items (type, JSON text) and the text sent."""

    items: tuple[Item, ...]
    text: str

    @staticmethod
    def of(items: Iterable[Item]) -> Frame:
        texts = tuple(items)
        return Frame(texts, "[" + ",".join(text for _, text in texts) + "]")

    @staticmethod
    def encoded(messages: Sequence[dict[str, Any]], samples: Mapping[str, int] = BURST) -> Frame:
        """The frame of these messages: what it keeps of them (kept()), each encoded once."""
        chosen, _ = kept([(str(m.get("type")), m) for m in messages], samples)
        return Frame.of((kind, json.dumps(m)) for kind, m in chosen)


class SampleBudget:
    """How many messages of each sample kind the next frame may carry: SAMPLE_RATE_HZ on
    average, in bursts of up to BURST_SAMPLES (a token bucket per kind)."""

    def __init__(self) -> None:
        self.left = {kind: float(BURST_SAMPLES) for kind in SAMPLE_KINDS}

    def allowed(self, since_s: float) -> dict[str, int]:
        for kind, left in self.left.items():
            self.left[kind] = min(float(BURST_SAMPLES), left + SAMPLE_RATE_HZ * since_s)
        return {kind: int(left) for kind, left in self.left.items()}

    def spend(self, frame: Frame) -> None:
        for kind, _ in frame.items:
            if kind in self.left:
                self.left[kind] -= 1.0


class Viewer:
    """One /ws connection: the frames it has not been sent yet."""

    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.ready = asyncio.Event()
        self.sent = 0  # frames sent
        self.merged = 0  # frames it was too far behind to be sent one by one
        self.dropped = 0  # events it lost because it read too slowly
        self.thinned = 0  # samples and superseded states left out of its merged frames

    def put(self, frame: Frame) -> None:
        self.frames.append(frame)
        if len(self.frames) > MERGE_AFTER:  # far behind: what it missed, merged (bounded by kept())
            self.frames = [self._merged()]
        self.ready.set()

    def take(self) -> str:
        text = self.frames[0].text if len(self.frames) == 1 else self._merged().text
        self.frames = []
        return text

    def _merged(self) -> Frame:
        self.merged += len(self.frames)
        items = [item for frame in self.frames for item in frame.items]
        chosen, dropped = kept(items)
        self.dropped += dropped
        self.thinned += len(items) - len(chosen) - dropped
        return Frame.of(chosen)


class LoopFanout:
    """The frames of one event loop (uvicorn's; a test client may run several): the queue the
    gateway's threads append to, and the timer that turns it into frames."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = loop
        self.viewers: frozenset[Viewer] = frozenset()
        self.slowdown = 1  # doubles while frames are late (_adapt)
        self.frames = 0
        self.late_frames = 0  # frames more than LAG_S late (the loop or the machine was busy)
        self.thinned = 0  # samples over the budget and superseded states left out of frames
        self._queue: deque[dict[str, Any]] = deque()
        self._lock = threading.Lock()
        self._scheduled = False
        self._last_frame = 0.0
        self._on_time = 0
        self._budget = SampleBudget()

    def publish(self, message: dict[str, Any]) -> None:
        """Any thread: queues the message; wakes the loop only if no frame is due yet."""
        self._queue.append(message)
        with self._lock:
            if self._scheduled:
                return
            self._scheduled = True
        with contextlib.suppress(RuntimeError):  # the loop is closing
            self.loop.call_soon_threadsafe(self._schedule)

    def _schedule(self) -> None:
        due = max(self.loop.time(), self._last_frame + self.interval)
        self.loop.call_at(due, self._frame, due)

    def _frame(self, due: float) -> None:
        now = self.loop.time()
        self._adapt(now - due)
        since, self._last_frame = now - self._last_frame, now
        with self._lock:
            self._scheduled = False  # a message queued from now on schedules the next frame
        messages = []
        while self._queue:
            messages.append(self._queue.popleft())
        if not messages or not self.viewers:
            return
        frame = Frame.encoded(messages, self._budget.allowed(since))
        self.thinned += len(messages) - len(frame.items)
        self._budget.spend(frame)
        self.frames += 1
        for viewer in self.viewers:
            viewer.put(frame)

    @property
    def interval(self) -> float:
        """The time between two frames: SENDS_PER_S shared by the viewers, times the slowdown."""
        base = max(MIN_FRAME_S, len(self.viewers) / SENDS_PER_S)
        return min(base * self.slowdown, MAX_FRAME_S)

    def _adapt(self, late_s: float) -> None:
        """Doubles the interval when a frame is late; halves it after ON_TIME_FRAMES on time."""
        if late_s > LAG_S:
            self.late_frames += 1
            self._on_time = 0
            if self.interval < MAX_FRAME_S:
                self.slowdown *= 2
        else:
            self._on_time += 1
            if self._on_time >= ON_TIME_FRAMES and self.slowdown > 1:
                self._on_time = 0
                self.slowdown //= 2


class Viewers:
    """Every /ws viewer of one gateway."""

    def __init__(self, gateway: Source) -> None:
        self.gateway = gateway
        # Replaced, never changed in place: the gateway's threads read it without a lock.
        self.fanouts: dict[asyncio.AbstractEventLoop, LoopFanout] = {}
        self._lock = threading.Lock()  # viewers joining and leaving
        self._unsubscribe: Callable[[], None] | None = None

    @property
    def viewers(self) -> frozenset[Viewer]:
        return frozenset(v for fanout in self.fanouts.values() for v in fanout.viewers)

    async def serve(self, ws: WebSocket) -> None:
        """Streams to an accepted WebSocket until it closes, or refuses it beyond MAX_VIEWERS."""
        if len(self.viewers) >= MAX_VIEWERS:
            await ws.close(
                code=TRY_AGAIN_LATER,
                reason=f"this gateway serves at most {MAX_VIEWERS} viewers at a time: try again later",
            )
            return
        viewer = Viewer()
        self._join(viewer, asyncio.get_running_loop())
        try:
            # The mission's view takes the gateway's lock, which planning may hold: not on the loop.
            hello = await asyncio.to_thread(self.gateway.mission_view)
            # first, before what came meanwhile
            viewer.frames.insert(0, Frame.encoded([wire(HelloMessage(**hello))]))
            viewer.ready.set()
            sending = asyncio.create_task(self._send(ws, viewer))
            receiving = asyncio.create_task(self._receive(ws))
            _, pending = await asyncio.wait({sending, receiving}, return_when=asyncio.FIRST_COMPLETED)
            for task in pending:
                task.cancel()
            await asyncio.gather(*pending, return_exceptions=True)
        finally:
            self._leave(viewer, asyncio.get_running_loop())
            # The viewer may have gone first (a closed tab): starlette then turns the close into
            # a WebSocketDisconnect, which is no error of ours.
            with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
                await ws.close()

    @staticmethod
    async def _send(ws: WebSocket, viewer: Viewer) -> None:
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                await viewer.ready.wait()
                viewer.ready.clear()
                if viewer.frames:
                    await ws.send_text(viewer.take())
                    viewer.sent += 1

    @staticmethod
    async def _receive(ws: WebSocket) -> None:
        """Reads (and ignores) what the viewer sends, until it goes away."""
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while (await ws.receive())["type"] != "websocket.disconnect":
                pass

    def _join(self, viewer: Viewer, loop: asyncio.AbstractEventLoop) -> None:
        with self._lock:
            fanout = self.fanouts.get(loop) or LoopFanout(loop)
            fanout.viewers = fanout.viewers | {viewer}
            self.fanouts = {**self.fanouts, loop: fanout}
            if self._unsubscribe is None:
                self._unsubscribe = self.gateway.subscribe(self._from_gateway)

    def _leave(self, viewer: Viewer, loop: asyncio.AbstractEventLoop) -> None:
        with self._lock:
            fanout = self.fanouts[loop]
            fanout.viewers = fanout.viewers - {viewer}
            if not fanout.viewers:
                self.fanouts = {k: v for k, v in self.fanouts.items() if k is not loop}
            if not self.fanouts and self._unsubscribe is not None:
                self._unsubscribe()
                self._unsubscribe = None

    def _from_gateway(self, message: dict[str, Any]) -> None:
        """Called in the gateway's threads: queued for each event loop's next frame."""
        for fanout in self.fanouts.values():
            fanout.publish(message)
