"""The /ws fan-out's work is bounded per frame, whatever the viewers and the message rate (issue
22: 200 viewers held the stop up to 5 s). A fake source and fake WebSockets: what is counted is
sends and encodings, not time."""

from __future__ import annotations

import asyncio
import json
from collections import Counter
from collections.abc import Callable
from typing import Any

import pytest

from cart2d.server.live import (
    BURST_SAMPLES,
    LAG_S,
    MAX_FRAME_S,
    MIN_FRAME_S,
    ON_TIME_FRAMES,
    SAMPLE_RATE_HZ,
    SENDS_PER_S,
    Frame,
    LoopFanout,
    SampleBudget,
    Viewer,
    Viewers,
)

Listener = Callable[[dict[str, Any]], None]


class Source:
    def __init__(self) -> None:
        self.listeners: list[Listener] = []

    def subscribe(self, listener: Listener) -> Callable[[], None]:
        self.listeners.append(listener)
        return lambda: self.listeners.remove(listener)

    def mission_view(self) -> dict[str, Any]:
        return {"state": "idle", "goal": None, "reason": "", "elapsed_s": 0.0, "plan": None, "replans": []}

    def publish(self, message: dict[str, Any]) -> None:
        for listener in self.listeners:
            listener(message)


class FakeSocket:
    """What Viewers.serve uses of a starlette WebSocket; send_text waits while `full` is clear."""

    def __init__(self) -> None:
        self.frames: list[list[dict[str, Any]]] = []
        self.full = asyncio.Event()
        self.full.set()
        self.gone = asyncio.Event()

    async def send_text(self, text: str) -> None:
        await self.full.wait()
        self.frames.append(json.loads(text))

    async def receive(self) -> dict[str, Any]:
        await self.gone.wait()
        return {"type": "websocket.disconnect"}

    async def close(self) -> None:
        self.gone.set()

    def messages(self) -> list[dict[str, Any]]:
        return [m for frame in self.frames for m in frame]


async def served(viewers: Viewers, count: int) -> tuple[list[FakeSocket], list[asyncio.Task[None]]]:
    sockets = [FakeSocket() for _ in range(count)]
    tasks = [asyncio.create_task(viewers.serve(ws)) for ws in sockets]  # type: ignore[arg-type]
    await until(lambda: all(ws.frames for ws in sockets))  # each has its hello
    return sockets, tasks


async def until(condition: Callable[[], bool], wall_timeout_s: float = 20.0) -> None:
    async with asyncio.timeout(wall_timeout_s):
        while not condition():
            await asyncio.sleep(0.005)


async def closed(sockets: list[FakeSocket], tasks: list[asyncio.Task[None]]) -> None:
    for ws in sockets:
        ws.gone.set()
    await asyncio.gather(*tasks)


def burst(source: Source, truths: int, frames: int, events: int) -> None:
    """Ground truth and telemetry far faster than real time, and a few events among them."""
    for k in range(max(truths, frames)):
        if k < truths:
            source.publish({"type": "truth", "t": k * 0.02})
        if k < frames:
            source.publish({"type": "telemetry", "tick": k})
        if k % 100 == 0 and k // 100 < events:
            source.publish({"type": "mission", "n": k // 100})


def test_a_burst_reaches_every_viewer_as_one_frame_with_every_event_and_the_newest_samples(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    encoded: list[str] = []

    def dumps(message: Any) -> str:
        encoded.append(message.get("type", ""))
        return json.JSONEncoder().encode(message)

    async def scenario() -> None:
        source = Source()
        viewers = Viewers(source)
        sockets, tasks = await served(viewers, 50)
        monkeypatch.setattr(json, "dumps", dumps)  # the json module live.py calls
        burst(source, truths=1000, frames=500, events=5)  # one step of the loop: one frame
        await until(lambda: all(len(ws.frames) == 2 for ws in sockets))
        await asyncio.sleep(0.2)  # nothing more comes
        for ws in sockets:
            assert len(ws.frames) == 2  # the hello, then the burst's one frame
            frame = ws.frames[1]
            assert [m["n"] for m in frame if m["type"] == "mission"] == [0, 1, 2, 3, 4]
            truths = [m["t"] for m in frame if m["type"] == "truth"]
            ticks = [m["tick"] for m in frame if m["type"] == "telemetry"]
            # the newest, in their order, up to the rate over the frame's time
            assert truths == [k * 0.02 for k in range(1000 - len(truths), 1000)]
            assert ticks == list(range(500 - len(ticks), 500))
            assert len(truths) == len(ticks) == BURST_SAMPLES
            assert frame == sockets[0].frames[1]
        # each message kept encoded once, for every viewer together
        assert len(encoded) == len(sockets[0].frames[1])
        await closed(sockets, tasks)
        assert not viewers.viewers and not source.listeners

    asyncio.run(scenario())


def test_a_viewer_behind_gets_what_it_missed_in_one_frame_every_event_kept() -> None:
    async def scenario() -> None:
        source = Source()
        viewers = Viewers(source)
        sockets, tasks = await served(viewers, 2)
        slow, quick = sockets
        slow.full.clear()  # its socket is full: its sends wait
        for n in range(40):  # 40 frames' worth, each on its own frame
            source.publish({"type": "mission", "n": n})
            source.publish({"type": "truth", "t": n})
            source.publish({"type": "camera", "n": n})
            await until(lambda n=n: quick.messages()[-1].get("n") == n)  # type: ignore[misc]
        slow.full.set()
        await until(lambda: any(m.get("n") == 39 for m in slow.messages()))
        events = [m["n"] for m in slow.messages() if m["type"] == "mission"]
        cameras = [m["n"] for m in slow.messages() if m["type"] == "camera"]
        assert events == list(range(40))  # every event, in order
        assert len(slow.frames) < 1 + 40 and cameras[-1] == 39  # merged; the newest state kept
        assert len(cameras) < 40  # superseded states of the frames it missed are not sent
        assert [m["n"] for m in quick.messages() if m["type"] == "mission"] == list(range(40))
        await closed(sockets, tasks)

    asyncio.run(scenario())


def fanout_of(viewers: int) -> LoopFanout:
    fanout = LoopFanout(asyncio.new_event_loop())
    fanout.viewers = frozenset(Viewer() for _ in range(viewers))
    return fanout


def test_the_viewers_together_get_at_most_their_sends_a_second() -> None:
    for count, interval in ((1, MIN_FRAME_S), (50, 0.02), (100, 0.04), (200, 0.08)):
        fanout = fanout_of(count)
        try:
            assert fanout.interval == pytest.approx(interval)
            assert count / fanout.interval <= SENDS_PER_S
        finally:
            fanout.loop.close()


def test_frames_come_less_often_while_the_loop_is_late_and_again_when_it_is_on_time() -> None:
    fanout = fanout_of(100)  # 25 frames a second each while on time
    base = fanout.interval
    try:
        intervals = []
        for _ in range(6):  # a busy machine: every frame late
            fanout._adapt(LAG_S * 2)
            intervals.append(fanout.interval)
        assert intervals == [min(base * 2**k, MAX_FRAME_S) for k in range(1, 7)]
        fanout._adapt(LAG_S * 2)
        for _ in range(ON_TIME_FRAMES - 1):
            fanout._adapt(0.0)
        assert fanout.interval == MAX_FRAME_S  # not yet: on time for a while first
        fanout._adapt(0.0)
        assert fanout.interval == MAX_FRAME_S / 2
        for _ in range(10 * ON_TIME_FRAMES):
            fanout._adapt(0.0)
        assert fanout.interval == base
        assert fanout.late_frames == 7
    finally:
        fanout.loop.close()


def sent_over(
    rates_hz: dict[str, float], frame_s: float, seconds: float
) -> tuple[Counter[str], Counter[str]]:
    """Messages of each kind at these rates, framed every frame_s on a fake clock for `seconds`:
    how many of each came, and how many the frames carried."""
    budget = SampleBudget()
    came: Counter[str] = Counter()
    carried: Counter[str] = Counter()
    due = dict.fromkeys(rates_hz, 0.0)
    t = 0.0
    while t < seconds:
        t += frame_s
        messages: list[dict[str, Any]] = []
        for kind, hz in rates_hz.items():
            while due[kind] <= t:
                messages.append({"type": kind, "at": due[kind]})
                came[kind] += 1
                due[kind] += 1.0 / hz
        frame = Frame.encoded(messages, budget.allowed(frame_s))
        budget.spend(frame)
        carried.update(kind for kind, _ in frame.items)
    return came, carried


def test_samples_at_the_firmwares_and_the_simulators_rates_all_reach_the_viewers() -> None:
    for frame_s in (MIN_FRAME_S, 0.04, MAX_FRAME_S):  # one viewer, 100 on time, the slowest
        came, carried = sent_over({"telemetry": 25.0, "truth": 50.0}, frame_s, 60.0)
        assert carried == came and came["truth"] >= 50 * 60


def test_a_simulator_at_full_speed_is_thinned_to_the_sample_rate() -> None:
    came, carried = sent_over({"telemetry": 750.0, "truth": 1500.0}, 0.04, 60.0)  # 30 x real time
    for kind in ("telemetry", "truth"):
        assert came[kind] >= 7.5 * SAMPLE_RATE_HZ * 60
        assert SAMPLE_RATE_HZ * 60 - BURST_SAMPLES <= carried[kind] <= SAMPLE_RATE_HZ * 60 + BURST_SAMPLES
