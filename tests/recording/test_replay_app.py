"""The replay answers the live gateway's reading routes from its recording, through the same route
modules (cart2d/server/routes), and refuses every change the live API has with a sentence (issue
23). A recording made up here: no simulator, no mission."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from unittest.mock import MagicMock

import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient

from cart2d.recording.channels import TOPIC_MAP_VIEW, TOPIC_WS
from cart2d.recording.recorded import Entry, Recorded
from cart2d.recording.replay import Player
from cart2d.recording.replay_app import create_replay_app
from cart2d.server import create_app

BASE_URL = "http://127.0.0.1:8310"
JSON = {"Content-Type": "application/json"}

MAP: dict[str, Any] = {
    "version": 3,
    "cols": 5,
    "rows": 4,
    "step_m": 0.2,
    "origin_m": [0.0, 0.0],
    "arena": {"x_min": -0.3, "y_min": -0.3, "x_max": 1.1, "y_max": 0.9},
    "footprint_radius_m": 0.12,
    "planning_radius_m": 0.14,
    "obstacles": [[0.4, 0.2]],
    "floor_plan": None,
    "unknown_is_free": False,
}
MISSION: dict[str, Any] = {
    "type": "mission",
    "state": "driving",
    "goal": [0.8, 0.6],
    "reason": "",
    "elapsed_s": 1.5,
    "plan": None,
    "replans": [],
}
PERCEIVED: dict[str, Any] = {"type": "perceived", "resolution": 0.05, "cells": [[0.6, 0.4, 0.9]]}


@pytest.fixture
def replay(tmp_path: Path) -> Iterator[tuple[Player, TestClient]]:
    recorded = Recorded(
        tmp_path / "made-up.mcap",
        [Entry(0.0, TOPIC_MAP_VIEW, MAP), Entry(1.0, TOPIC_WS, MISSION), Entry(2.0, TOPIC_WS, PERCEIVED)],
        duration_s=3.0,
    )
    player = Player(recorded)
    try:
        yield player, TestClient(create_replay_app(player), base_url=BASE_URL, headers=JSON)
    finally:
        player.close()


def test_the_live_reads_answer_the_recorded_state_at_the_position(replay: tuple[Player, TestClient]) -> None:
    player, client = replay
    player.seek(3.0)
    mission = {k: v for k, v in MISSION.items() if k != "type"}
    status = client.get("/api/status").json()
    assert status["mission"] == mission and status["replay"]["position_s"] == 3.0
    assert status["pose_trust"] == {"trusted": True, "reason": "", "how": "replay"}
    assert client.get("/api/mission").json() == mission
    assert client.get("/api/map").json() == MAP
    assert client.get("/api/perception").json() == {
        "enabled": True,
        "resolution": 0.05,
        "cells": [[0.6, 0.4, 0.9]],
    }
    assert client.get("/api/firmware/settings").json() == []
    assert client.get("/api/map/image").status_code == 404  # a grid of nodes: no plan
    player.seek(0.5)  # before the mission and the cells
    assert client.get("/api/mission").json()["state"] == "idle"
    assert client.get("/api/perception").json()["cells"] == []


def test_every_change_of_the_live_api_is_refused_with_a_sentence(replay: tuple[Player, TestClient]) -> None:
    player, client = replay
    live = create_app(MagicMock())
    changes = [
        (method, re.sub(r"\{[^}]+\}", "x", route.path))
        for route in live.routes
        if isinstance(route, APIRoute)
        for method in sorted(route.methods or ())
        if method not in ("GET", "HEAD")
    ]
    assert len(changes) > 20  # every one the live API has
    for method, path in changes:
        answer = client.request(method, path, json={})
        assert answer.status_code == 409, (method, path, answer.text)
        assert "this is a replay of made-up.mcap" in answer.json()["detail"], (method, path)
    assert player.state == "waiting" and player.sent == 0


def test_what_only_a_live_gateway_reads_is_not_there(replay: tuple[Player, TestClient]) -> None:
    _, client = replay
    for path in ("/api/firmware/update", "/api/sim/faults", "/api/settings/file"):
        answer = client.get(path)
        assert answer.status_code == 404 and "not part of a replay" in answer.json()["detail"], path
