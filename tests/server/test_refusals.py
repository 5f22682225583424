"""What the gateway refuses for now (cart2d.gateway.Refused: exploration without a camera,
nothing seen to save) is a 409 with its sentence, from one handler (server/app.py), and changes
nothing; a bad name is a 400 before anything is tried."""

from __future__ import annotations

from fastapi.testclient import TestClient

from cart2d.gateway import Gateway
from cart2d.server.app import create_app


def test_exploring_without_a_camera_is_refused_with_the_reason(gateway: Gateway) -> None:
    client = TestClient(create_app(gateway), base_url="http://127.0.0.1")
    answer = client.post("/api/explore", json={})
    assert answer.status_code == 409, answer.text
    assert "camera" in answer.json()["detail"]
    assert client.get("/api/explore").json()["state"] != "exploring"
    assert gateway.mission.state == "idle"


def test_a_bad_name_to_explore_is_refused_before_anything_starts(gateway: Gateway) -> None:
    client = TestClient(create_app(gateway), base_url="http://127.0.0.1")
    answer = client.post("/api/explore", json={"save": "a b"})
    assert answer.status_code == 422 and "save" in answer.text
    assert gateway.mission.state == "idle"
