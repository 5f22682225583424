"""A stop is the last word the motors hear (issue 11, finding 4), against a real gateway over HTTP.

Each trial sends motion requests (goto, manual drive) from their own connections and, once
every one of them has been written to its socket, a stop a random few milliseconds later, so
the stop lands anywhere in their handling: before the goto has read the pose, between the pose
and the path upload, during the upload, after it; with a drive waiting for the link or on it.
Ground truth judges: from one control tick after the stop's answer (the firmware replies to
STOP at once and sets the motors at its next tick) to half a simulated second later, past the
firmware's manual-drive timeout, both H-bridge duties are zero in every sample. Nothing is sent
after the stop, so nothing may move the cart after its answer."""

from __future__ import annotations

import random
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from cart2d.simulation.side_channel import SideChannel
from tests.support.live import Http, LiveGateway, wait_sim_time

TICK_S = 0.008  # one control tick
JUDGE_S = 0.6  # simulated seconds watched after each stop: past the 0.5 s manual-drive timeout
TRUTH_HZ = 500.0  # ground-truth samples per simulated second
GOALS = [(1.6, 1.6), (0.2, 0.2)]


@dataclass
class Trial:
    motions: list[str]
    answered_s: float = 0.0  # simulated time just after the stop's answer
    statuses: dict[str, int] = field(default_factory=dict)
    details: dict[str, str] = field(default_factory=dict)  # what an answer other than 200 said
    moving: list[dict[str, Any]] = field(default_factory=list)  # truth samples with the motors on


class Truth:
    """Every ground-truth sample at TRUTH_HZ, from a side-channel client of its own."""

    def __init__(self, address: str) -> None:
        self.samples: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self.side = SideChannel(address)
        self.side.subscribe(self._keep)
        self.side.request({"type": "truth_rate", "hz": TRUTH_HZ})

    def _keep(self, message: dict[str, Any]) -> None:
        with self._lock:
            self.samples.append({key: message[key] for key in ("t", "duty_l", "duty_r")})

    def between(self, t0: float, t1: float) -> list[dict[str, Any]]:
        with self._lock:
            return [s for s in self.samples if t0 < s["t"] <= t1]

    def close(self) -> None:
        self.side.close()


@pytest.fixture
def live(tmp_path: Path) -> Iterator[LiveGateway]:
    # In real time, as on the robot: the truth judges every sample at 500 Hz, and at full speed a
    # busy machine's test process (this one, which also serves the gateway) fell seconds behind
    # the simulator's telemetry and truth (a STOP unanswered for 6.5 s: its replies queued).
    gateway = LiveGateway(tmp_path, speed="1")
    yield gateway
    gateway.close()


def run_trial(live: LiveGateway, truth: Truth, motions: list[str], n: int, delay_s: float) -> Trial:
    trial = Trial(motions)
    clients = [live.http() for _ in motions]
    stopper = live.http()

    def move(index: int, kind: str, client: Http) -> None:
        if kind == "goto":
            x, y = GOALS[n % 2]
            status, body = client.call("POST", "/api/goto", {"x": x, "y": y})
        else:
            v = 0.3 if (n + index) % 2 == 0 else -0.3  # back and forth: the cart stays in the arena
            status, body = client.call("POST", "/api/drive", {"v": v, "omega": 0.0})
        trial.statuses[f"{kind} {index}"] = status
        if status != 200:
            trial.details[f"{kind} {index}"] = str(body)

    threads = [
        threading.Thread(target=move, args=(i, kind, client), daemon=True)
        for i, (kind, client) in enumerate(zip(motions, clients, strict=True))
    ]
    for thread in threads:
        thread.start()
    for client in clients:
        assert client.sent.wait(10), "a motion request was not sent"
    threading.Event().wait(delay_s)
    status, body = stopper.call("POST", "/api/stop")
    trial.answered_s = float(live.sim.truth()["t"])
    assert status == 200, body
    for thread in threads:
        thread.join(30)
    end_s = wait_sim_time(live.sim, JUDGE_S)
    trial.moving = [
        s for s in truth.between(trial.answered_s + TICK_S, end_s) if s["duty_l"] != 0 or s["duty_r"] != 0
    ]
    for client in (*clients, stopper):
        client.close()
    return trial


class Readers:
    """Clients reading the firmware settings and the status as fast as they are answered."""

    def __init__(self, live: LiveGateway, count: int) -> None:
        self.stop = threading.Event()
        self.errors: list[str] = []
        self.threads = [
            threading.Thread(target=self._read, args=(live.http(), i), daemon=True) for i in range(count)
        ]
        for thread in self.threads:
            thread.start()

    def _read(self, client: Http, index: int) -> None:
        path = "/api/firmware/settings" if index % 2 == 0 else "/api/status"
        while not self.stop.is_set():
            status, body = client.call("GET", path)
            if status != 200:
                self.errors.append(f"{path}: {status} {body}")
        client.close()

    def close(self) -> None:
        self.stop.set()
        for thread in self.threads:
            thread.join(30)


@pytest.mark.parametrize(
    ("motions", "readers", "trials", "max_delay_s"),
    [
        (["goto"], 0, 30, 0.025),
        (["drive", "drive"], 0, 30, 0.010),
        (["goto", "drive", "drive"], 4, 30, 0.025),
    ],
    ids=["goto", "drives", "goto-drives-readers"],
)
def test_after_the_stops_answer_the_cart_never_moves(
    live: LiveGateway, motions: list[str], readers: int, trials: int, max_delay_s: float
) -> None:
    truth = Truth(live.sim.control_address)
    background = Readers(live, readers)
    jitter = random.Random(11)
    failed: list[Trial] = []
    try:
        for n in range(trials):
            trial = run_trial(live, truth, motions, n, jitter.uniform(0.0, max_delay_s))
            assert all(status in (200, 409) for status in trial.statuses.values()), trial.details
            if trial.moving:
                failed.append(trial)
    finally:
        background.close()
        truth.close()
    assert not background.errors, background.errors[:3]
    assert not failed, [
        f"{t.statuses}: motors on {t.moving[-1]['t'] - t.answered_s:.3f} s after the stop's answer"
        for t in failed
    ]
