"""Paths of any length through the firmware's waypoint window, and paths replaced while they are
driven: the real firmware in the simulator, streamed by the gateway's uploader (PathStream) in
real time as on a cart, judged by ground truth and telemetry (docs/protocol.md, "Paths and the
waypoint window")."""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from bench.streaming import (
    ROW_FLOOR_MPS,
    ROW_X_M,
    TURN_FLOOR_MPS,
    drive,
    serpentine,
    speed_floors,
    start_sim,
)
from cart2d.link import Link, firmware, path_stream
from cart2d.link.protocol import Telemetry
from cart2d.params import settings_table
from cart2d.simulation.simulator import Simulator
from cart2d.spec import load_spec
from tests.support.waiting import wait_for

DEFAULTS = {s["name"]: float(s["default"]) for s in settings_table()}
A_MAX = DEFAULTS["a_max_mps2"]
TICK_S = 0.008
START = (ROW_X_M[0], 0.6, 0.0)


@pytest.fixture
def cart(tmp_path: Path) -> Iterator[tuple[Simulator, Link]]:
    """The firmware in the 4 m arena, in real time, at the serpentine's start."""
    sim = start_sim(tmp_path, START)
    try:
        with Link(sim.pty) as link:
            link.call("SET_POSE", *START)
            yield sim, link
    finally:
        sim.stop()


def line(x0: float, x1: float, y: float, step: float = 0.05) -> list[tuple[float, float]]:
    n = round(abs(x1 - x0) / step)
    return [(x0 + math.copysign(step, x1 - x0) * k, y) for k in range(1, n + 1)]


def test_a_long_serpentine_is_streamed_without_slowing_at_window_boundaries(
    cart: tuple[Simulator, Link],
) -> None:
    sim, link = cart
    points = serpentine(3)
    window = firmware.read_version(link).waypoint_capacity
    assert len(points) > 6 * window  # 210 waypoints, a window boundary every few
    d = drive(sim, link, points)
    assert d.status is not None and d.status.has("ARRIVED")
    assert d.status.waypoint_index == len(points) == d.status.waypoints_received
    assert d.stream is not None and d.stream.sent == len(points) and not d.stream.failure
    assert d.stream.appends >= (len(points) - window) / 15  # it did stream
    truth = sim.truth()
    assert math.dist((truth["x"], truth["y"]), points[-1]) < 0.01
    assert truth["collisions"] == 0 and truth["wall_contacts"] == 0
    # Never short of points to brake from v_max, never below the floors: full speed in the rows'
    # middles, no stop in the turns.
    assert d.starved_frames() == 0
    floors = speed_floors(d)
    assert floors["rows_min_mps"] >= ROW_FLOOR_MPS, floors
    assert floors["overall_min_mps"] >= TURN_FLOOR_MPS, floors


def _frames(link: Link) -> list[Telemetry]:
    frames: list[Telemetry] = []
    link.subscribe(frames.append)
    return frames


def _truth(sim: Simulator) -> list[dict[str, Any]]:
    samples: list[dict[str, Any]] = []
    lock = threading.Lock()
    assert sim.side is not None

    def keep(message: dict[str, Any]) -> None:
        if message.get("type") == "truth":
            with lock:
                samples.append(message)

    sim.side.subscribe(keep)
    return samples


def _wait_path_end(link: Link) -> firmware.Status:
    status: firmware.Status | None = None

    def ended() -> bool:
        nonlocal status
        status = firmware.read_status(link)
        return status.mode != "PATH"

    wait_for(ended, 120.0, 0.05)
    assert status is not None
    return status


def _reference_steps_within_the_limits(frames: list[Telemetry]) -> None:
    """Telemetry's target v (after the acceleration limiter) changes by at most a_max per tick."""
    for a, b in itertools.pairwise(frames):
        ticks = (b.tick - a.tick) % 65536
        if a.mode == b.mode == 2 and ticks:
            assert abs(b.v_target - a.v_target) <= A_MAX * TICK_S * ticks + 1e-4, (a, b)


def test_a_path_replaced_mid_drive_is_followed_at_once_without_a_speed_jump(
    cart: tuple[Simulator, Link],
) -> None:
    # Driving east along y = 0.6 towards x = 3.5 (a streamed path of 60 points); at x = 1.5 the
    # gateway replaces it: on east to x = 2.6, a left turn of 0.25 m radius, then north to
    # y = 2.0 (60 points). The new path starts in the direction the cart drives, so the cart must
    # not slow down before the turn, and it must never head on for the old path's points.
    sim, link = cart
    link.call("TELEMETRY", 50.0)
    frames, truth = _frames(link), _truth(sim)
    old = path_stream.upload_path(link, line(ROW_X_M[0], 3.5, 0.6))
    wait_for(lambda: sim.truth()["x"] > 1.5, 30.0, 0.005)
    x_new = round(sim.truth()["x"], 2) + 0.15  # just ahead of the cart
    turn = [
        (2.6 + 0.25 * math.sin(a), 0.85 - 0.25 * math.cos(a)) for a in (math.pi / 16 * k for k in range(1, 9))
    ]
    north = [(2.85, 0.85 + 0.05 * k) for k in range(1, 24)]
    new_points = [*line(x_new - 0.05, 2.6, 0.6), *turn, *north]
    old.cancel()  # as the gateway does: the old stream stops before the new path is sent
    replaced_t = sim.truth()["t"]
    new = path_stream.upload_path(link, new_points)
    status = _wait_path_end(link)
    assert old.ended == "cancelled" and not new.failure and new.sent == len(new_points)
    assert status.has("ARRIVED") and status.waypoint_count == len(new_points)
    end = sim.truth()
    assert math.dist((end["x"], end["y"]), new_points[-1]) < 0.01
    _reference_steps_within_the_limits(frames)
    after = [s for s in truth if s["t"] >= replaced_t]
    # On the straight part of the new path: at full speed (no stop, no slow-down for the swap).
    straight = [s for s in after if s["x"] < 2.3]
    assert straight and min(s["v"] for s in straight) > 0.45
    # The cart follows the new path only: it turns north at x = 2.85 and never drives on east
    # along the old one (to x = 3.5).
    assert max(s["x"] for s in after) < 2.85 + 0.02
    assert all(abs(s["y"] - 0.6) < 0.02 for s in straight)
    # Ground truth: no jump in speed; the body's acceleration stays near a_max (over 40 ms).
    for a, b in zip(truth, truth[4:], strict=False):
        assert abs(b["v"] - a["v"]) <= 1.5 * A_MAX * (b["t"] - a["t"]) + 0.01, (a, b)


def test_refused_path_requests_change_nothing_while_a_path_streams(cart: tuple[Simulator, Link]) -> None:
    # While a 120-point path streams, requests the firmware must refuse: a path longer than
    # 65 535 points, a frame with half a point, an append out of order. None may disturb the path:
    # the same count, the stream unharmed, the cart on at full speed and arriving.
    sim, link = cart
    reasons = load_spec().reasons
    truth = _truth(sim)
    points = [*line(ROW_X_M[0], 3.5, 0.6), *line(3.5, 0.5, 1.1)]
    stream = path_stream.upload_path(link, [*points[:60], (3.5, 0.85), *points[60:]])
    wait_for(lambda: sim.truth()["x"] > 1.5, 30.0, 0.005)
    refused = [
        link.request("WAIT_XY_ARRAY", [65536.0]),
        link.request("WAIT_XY_ARRAY", [3.0, 1.0, 1.0, 2.0]),
        link.request("XY_APPEND", [60000.0, 1.0, 1.0]),
    ]
    assert [reasons[int(r.results[0])] for r in refused if r.status == 1] == [
        "OVER_CAPACITY",
        "ARG_COUNT",
        "OUT_OF_ORDER",
    ]
    status = firmware.read_status(link)
    assert status.mode == "PATH" and status.waypoint_count == stream.count
    refused_t = sim.truth()["t"]
    status = _wait_path_end(link)
    assert status.has("ARRIVED") and not stream.failure and stream.sent == stream.count
    end = sim.truth()
    assert math.dist((end["x"], end["y"]), points[-1]) < 0.01
    row = [s for s in truth if refused_t - 0.5 <= s["t"] and s["y"] < 0.65 and s["x"] < 3.0]
    assert row and min(s["v"] for s in row) > 0.45


class StatusOnlyLink:
    """Answers STATUS with the firmware's state as given (a PATH of `count` points at `index`,
    `received` of them in); the stream's progress from telemetry is fed to it by hand."""

    def __init__(self, count: int, index: int, received: int) -> None:
        self.state = (count, index, received)
        self.status_calls = 0

    def motion_token(self) -> int:
        return 0

    def call(self, command: str, *args: float, **options: Any) -> tuple[float, ...]:
        assert command == "STATUS"
        self.status_calls += 1
        count, index, received = self.state
        mode = next(code for code, name in load_spec().modes.items() if name == "PATH")
        return (mode, 0, index, count, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, received)


def test_a_telemetry_frame_older_than_an_append_does_not_end_the_stream() -> None:
    # Frames reach the stream through the link's telemetry thread and may wait behind a reply on
    # the wire: one from before the last XY_APPEND's reply (an index behind, or IDLE from before
    # the path began) is stale. It ended the stream ("replaced by another sender"), and the cart
    # stopped at the window's end with the rest of the path unsent.
    link = StatusOnlyLink(count=210, index=18, received=49)
    stream = path_stream.PathStream(link, [(0.01 * k, 0.0) for k in range(210)])  # type: ignore[arg-type]
    stream.sent, stream.index, stream.window = 49, 18, 32
    stream._follow("PATH", 17)
    assert not stream.done.is_set() and stream.index == 18
    stream._follow("IDLE", 0)  # checked with STATUS, which says PATH at 18
    assert not stream.done.is_set() and link.status_calls == 1
    link.state = (300, 0, 15)  # another sender's path
    stream._follow("PATH", 19)
    stream._follow("IDLE", 0)
    assert stream.done.is_set() and stream.failure == "the path was replaced by another sender"
