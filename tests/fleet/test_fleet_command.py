"""`cart2d fleet` and `cart2d fleet sim`: what is refused before anything starts (a sentence, exit
status 2), and the manager's API (goals, STOP ALL, a cart removed) on fake vehicles."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest
from fastapi.testclient import TestClient

from cart2d.fleet import vda5050
from cart2d.fleet.api import fleet_app
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.tools.cli import main
from tests.support.sim import require_builds
from tests.support.sockets import free_port
from tests.support.waiting import wait_for


def test_the_manager_needs_a_broker(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fleet"]) == 2
    assert "--mqtt URL names the broker" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("world", "sentence"),
    [
        ({"carts": [{"id": "a", "x": 1, "y": 1}, {"id": "b", "x": 1.2, "y": 1}]}, "start 0.20 m apart"),
        ({"carts": [{"id": "a", "x": 1, "y": 1}, {"id": "a", "x": 2, "y": 2}]}, "two carts have one id"),
        ({"cars": []}, "unknown key"),
        ({"carts": [{"id": "a", "x": 1, "y": 1}]}, "places 1 carts, not 3"),
    ],
)
def test_a_bad_fleet_world_is_refused(
    tmp_path: Path, world: dict[str, Any], sentence: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "world.json"
    path.write_text(json.dumps(world))
    assert main(["fleet", "sim", "--carts", "3", "--world", str(path)]) == 2
    assert sentence in capsys.readouterr().err


def test_too_many_carts_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["fleet", "sim", "--carts", "9"])
    assert exit_.value.code == 2
    assert "9 carts: 1 to 8" in capsys.readouterr().err


def test_the_api_takes_goals_refuses_bad_ones_and_stops_all() -> None:
    sent: list[tuple[str, dict[str, Any]]] = []
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(4) for j in range(4)))
    manager = FleetManager(lattice, publish=lambda t, m: sent.append((t, m)))
    for name, (x, y) in {"c1": (0.25, 0.25), "c2": (1.75, 1.75)}.items():
        position = {"x": x, "y": y, "theta": 0.0, "mapId": "arena", "positionInitialized": True}
        manager.heard(vda5050.topic(name, "connection"), {"connectionState": "ONLINE"})
        manager.heard(vda5050.topic(name, "state"), {"agvPosition": position, "orderId": ""})
    client = TestClient(
        fleet_app(manager, "127.0.0.1"),
        base_url="http://127.0.0.1",
        headers={"Content-Type": "application/json"},  # every change is JSON (the server's guards)
    )
    assert client.get("/").status_code == 200
    answer = client.post("/api/fleet/goals", json={"x": 0.3, "y": 1.2})
    assert answer.status_code == 201 and answer.json()["at"] == [0.25, 1.25]
    assert client.post("/api/fleet/goals", json={"x": 1.0, "y": 1.0, "cart": "c9"}).status_code == 400
    assert client.post("/api/fleet/goals", json={"x": 9.0, "y": 9.0}).json()["detail"].endswith("free space")
    assert client.post("/api/fleet/goals", json={"x": "a", "y": 1}).status_code == 422
    manager.step()
    assert [t.rsplit("/", 1)[1] for t, _ in sent] == ["order"] and sent[0][0].split("/")[3] == "c1"
    assert client.post("/api/fleet/stop", json={}).status_code == 200
    assert sorted(t.split("/")[3] for t, m in sent if t.endswith("instantActions")) == ["c1", "c2"]
    assert [g["status"] for g in client.get("/api/fleet").json()["goals"]] == ["cancelled"]
    manager.heard(vda5050.topic("c2", "connection"), {"connectionState": "CONNECTIONBROKEN"})
    assert manager.traffic.holds[(3, 3)] == "c2"  # an OFFLINE cart keeps its node
    assert client.delete("/api/fleet/carts/c2").status_code == 200
    assert (3, 3) not in manager.traffic.holds
    assert client.delete("/api/fleet/carts/c2").status_code == 404


def test_the_page_listens_on_loopback_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fleet", "--mqtt", "mqtt://127.0.0.1:1", "--host", "0.0.0.0"]) == 2
    assert "loopback only" in capsys.readouterr().err


def test_fleet_sim_starts_its_broker_carts_and_page_and_stops_on_sigterm(tmp_path: Path) -> None:
    require_builds()
    port, broker_port = free_port(), free_port()
    command = ["fleet", "sim", "--carts", "2", f"--port={port}", f"--broker-port={broker_port}"]
    process = subprocess.Popen(
        [sys.executable, "-m", "cart2d.tools.cli", *command],
        env={**os.environ, "CART2D_HOME": str(tmp_path)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        lines = [process.stdout.readline() for _ in range(3)]
        assert f"mosquitto on mqtt://127.0.0.1:{broker_port}" in lines[0], lines
        assert "2 carts" in lines[1] and f"http://127.0.0.1:{port}/" in lines[2], lines
        with httpx.Client(base_url=f"http://127.0.0.1:{port}") as client:
            wait_for(lambda: len(client.get("/api/fleet").json()["carts"]) == 2, 30)
            assert set(client.get("/api/fleet").json()["truth"]["carts"]) == {"cart1", "cart2"}
    finally:
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "Traceback" not in err, err
