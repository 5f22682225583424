"""The stop's answer does not wait for the gateway's lock (issue 22: with 20 clients, goals being
sent and obstacles' route checks held it, each reading the link, and the stop's answer waited
0.1-0.5 s behind them after the firmware had stopped). Judged by order, with the lock held by
the test itself, not by time."""

from __future__ import annotations

import threading
from typing import Any

from tests.support.server import Rig
from tests.support.waiting import wait_for


def stop_in_thread(rig: Rig) -> tuple[threading.Thread, list[Any]]:
    answers: list[Any] = []
    thread = threading.Thread(target=lambda: answers.append(rig.client.post("/api/stop")), daemon=True)
    thread.start()
    return thread, answers


def firmware_mode(rig: Rig) -> float:
    return rig.link.call("STATUS")[0]  # the link directly: no gateway lock (0: IDLE)


def test_the_stop_is_answered_while_the_gateways_lock_is_held(rig: Rig) -> None:
    assert rig.client.post("/api/goto", json={"x": 1.6, "y": 0.0}).status_code == 200
    assert rig.mission_state() == "driving"
    with rig.gateway._lock:  # as a goal being planned, or a route check reading the link
        thread, answers = stop_in_thread(rig)
        thread.join(20)
        assert answers and answers[0].status_code == 200, "the stop waited for the lock"
        assert firmware_mode(rig) == 0
    # once the lock is free, the mission the stop ended is recorded as ended by it
    wait_for(lambda: rig.mission_state() == "failed", 10)
    assert rig.client.get("/api/mission").json()["reason"] == "stopped by the user"


def test_a_mission_begun_after_the_stop_is_not_ended_by_it(rig: Rig) -> None:
    assert rig.client.post("/api/goto", json={"x": 1.6, "y": 0.0}).status_code == 200
    with rig.gateway._lock:
        thread, answers = stop_in_thread(rig)
        thread.join(20)
        assert answers and answers[0].status_code == 200
        rig.gateway.go_to(0.2, 0.6)  # a new goal after the stop, before its mission is recorded
    wait_for(lambda: not rig.gateway.missions.stops_pending(), 10)
    mission = rig.client.get("/api/mission").json()
    assert mission["state"] == "driving" and mission["goal"] == [0.2, 0.6]
    assert rig.client.post("/api/stop").status_code == 200
