"""The fleet manager's live stream (/ws, cart2d/fleet/stream.py): the page's view at connection
and again when it changes, each message a views.FleetUpdate; a page of another origin refused
at the handshake, as the gateway's /ws is (fake vehicles: no broker, no simulator)."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.testclient import WebSocketDenialResponse

from cart2d.fleet import vda5050
from cart2d.fleet.api import fleet_app
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.fleet.views import FleetUpdate

LATTICE = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(4) for j in range(4)))
JSON = {"Content-Type": "application/json"}
WS = "ws://127.0.0.1/ws"  # the Host the manager answers to on loopback


def _manager() -> FleetManager:
    manager = FleetManager(LATTICE, publish=lambda topic, message: None)
    manager.heard(vda5050.topic("c1", "connection"), {"connectionState": "ONLINE"})
    position: dict[str, Any] = {
        "x": 0.25,
        "y": 0.25,
        "theta": 0.0,
        "mapId": "arena",
        "positionInitialized": True,
    }
    manager.heard(vda5050.topic("c1", "state"), {"agvPosition": position, "orderId": ""})
    return manager


def test_the_view_at_connection_and_again_when_it_changes() -> None:
    manager = _manager()
    client = TestClient(fleet_app(manager, "127.0.0.1"), base_url="http://127.0.0.1")
    with client.websocket_connect(WS) as ws:
        first = FleetUpdate.model_validate(ws.receive_json())
        assert first.type == "fleet" and [c.name for c in first.view.carts] == ["c1"]
        assert first.view.goals == []
        assert client.post("/api/fleet/goals", json={"x": 0.25, "y": 1.25}, headers=JSON).status_code == 201
        changed = FleetUpdate.model_validate(ws.receive_json())  # the goal, pushed without a poll
        assert [(g.at, g.status) for g in changed.view.goals] == [((0.25, 1.25), "waiting")]
        manager.step()  # the manager's round: the goal assigned and sent
        assigned = FleetUpdate.model_validate(ws.receive_json())
        assert [(g.cart, g.status) for g in assigned.view.goals] == [("c1", "driving")]
        polled = FleetUpdate.model_validate({"type": "fleet", "view": client.get("/api/fleet").json()})
        assert assigned.view == polled.view  # the stream and GET /api/fleet say the same


def test_a_page_of_another_origin_is_refused_the_stream() -> None:
    client = TestClient(fleet_app(_manager(), "127.0.0.1"), base_url="http://127.0.0.1")
    elsewhere = {"origin": "http://elsewhere.example"}
    # answered at the handshake, never accepted
    with pytest.raises(WebSocketDenialResponse) as refused, client.websocket_connect(WS, headers=elsewhere):
        pass
    assert refused.value.status_code == 403 and "another origin" in refused.value.json()["detail"]
