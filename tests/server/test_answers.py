"""What the routes answer is declared (cart2d/server/answers.py, issue 23): /openapi.json gives
each JSON answer's schema, the gateway's views pass through unchanged, and a view that drifts from
its model (a key it does not declare) fails instead of losing the key. A fake gateway: no simulator."""

from __future__ import annotations

from typing import Any
from unittest.mock import MagicMock

import pytest
from fastapi.exceptions import ResponseValidationError
from fastapi.testclient import TestClient

from cart2d.server import create_app
from cart2d.server.deps import gateway_of, source_of
from cart2d.server.routes import ROUTERS, source_reads

BASE_URL = "http://127.0.0.1:8310"
# sim_world.py's routes move into the simulation package (issue 23's simulator part): typed there
UNTYPED_ELSEWHERE = {("get", "/api/sim/world"), ("post", "/api/sim/boxes"), ("delete", "/api/sim/boxes")}
UNTYPED_ELSEWHERE |= {("delete", "/api/sim/boxes/{box_id}")}

MISSION: dict[str, Any] = {
    "state": "driving",
    "goal": [1.0, 0.5],
    "reason": "",
    "elapsed_s": 2.5,
    "plan": {
        "start": [0.0, 0.0],
        "waypoints": [[1.0, 0.5]],
        "grid_path": [[0.0, 0.0], [1.0, 0.5]],
        "length_m": 1.118,
        "grid_length_m": 1.2,
    },
    "replans": [],
}
STATUS: dict[str, Any] = {
    "link": {"state": "connected", "port": "/dev/ttyUSB0", "simulated": False},
    "firmware": None,
    "mission": MISSION,
    "pose": {"x": 0.5, "y": 0.25, "theta": 0.1},
    "reset": {"last": None, "noticed": 0},
    "pose_trust": {"trusted": False, "reason": "the controller restarted"},
    "routine": {"state": "idle", "words": ""},
}


def client_of(gateway: MagicMock) -> TestClient:
    return TestClient(create_app(gateway), base_url=BASE_URL)


def test_every_json_answer_has_its_schema_in_the_openapi_document() -> None:
    paths = client_of(MagicMock()).get("/openapi.json").json()["paths"]
    untyped = set()
    for path, operations in paths.items():
        for method, operation in operations.items():
            for status, response in operation["responses"].items():
                schema = response.get("content", {}).get("application/json", {}).get("schema")
                if not status.startswith("2") or schema is None:
                    continue
                items = schema.get("items", schema)  # a list's
                declared = "$ref" in items or "properties" in items  # a model's, or inlined
                if not declared and (method, path) not in UNTYPED_ELSEWHERE:
                    untyped.add(f"{method.upper()} {path}")
    assert not untyped, sorted(untyped)


def test_a_view_passes_unchanged_and_absent_keys_stay_absent() -> None:
    gateway = MagicMock()
    gateway.status_view_unless_busy.return_value = STATUS
    gateway.mission_view.return_value = MISSION
    client = client_of(gateway)
    assert client.get("/api/status").json() == STATUS  # no simulator, status nor how added
    assert client.get("/api/mission").json() == MISSION


def test_a_view_with_a_key_its_model_lacks_fails_rather_than_lose_it() -> None:
    gateway = MagicMock()
    gateway.status_view_unless_busy.return_value = {**STATUS, "battery_v": 7.4}
    with pytest.raises(ResponseValidationError, match="battery_v"):
        client_of(gateway).get("/api/status")


def test_the_routes_a_replay_shares_read_a_source_and_nothing_else() -> None:
    shared = {(method, route.path) for route in source_reads(ROUTERS) for method in route.methods or ()}
    assert shared == {
        ("GET", "/api/status"),
        ("GET", "/api/mission"),
        ("GET", "/api/map"),
        ("GET", "/api/map/image"),
        ("GET", "/api/perception"),
        ("GET", "/api/firmware/settings"),
        ("GET", "/api/camera"),
        ("GET", "/api/camera/frame.jpg"),
        ("GET", "/api/camera/stream"),
    }
    for route in source_reads(ROUTERS):
        assert gateway_of not in {d.call for d in route.dependant.dependencies}
        assert source_of in {d.call for d in route.dependant.dependencies}
