"""The route modules reach the robot only through the Gateway front (issue 23): a fake gateway
records what each route asked of it."""

from __future__ import annotations

from unittest.mock import MagicMock

from fastapi.testclient import TestClient

from cart2d.server import create_app

JSON = {"Content-Type": "application/json", "X-Cart2d-Token": "any"}


def test_firmware_load_asks_the_gateway_not_its_link() -> None:
    gateway = MagicMock()
    client = TestClient(create_app(gateway), base_url="http://127.0.0.1:8310")
    answer = client.post("/api/firmware/load", headers=JSON)
    assert answer.status_code == 200, answer.text
    assert answer.json() == {"result": "loaded"}
    gateway.load_settings.assert_called_once_with()
    gateway.link.call.assert_not_called()
