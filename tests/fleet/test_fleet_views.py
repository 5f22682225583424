"""The fleet manager's JSON (cart2d/fleet/views.py): each cart's state in one word, its order,
and the page served from the built panel (fake vehicles: no broker, no simulator)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from cart2d.fleet import vda5050
from cart2d.fleet.api import fleet_app
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.fleet.views import CartView

JSON = {"Content-Type": "application/json"}  # a change says what it carries (guards.py)
LATTICE = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(4) for j in range(4)))


def _manager(*carts: tuple[str, float, float]) -> FleetManager:
    manager = FleetManager(LATTICE, publish=lambda topic, message: None)
    for name, x, y in carts:
        _say(manager, name, "connection", connectionState="ONLINE")
        _say(manager, name, "state", agvPosition=_at(x, y), orderId="")
    return manager


def _at(x: float, y: float) -> dict[str, Any]:
    return {"x": x, "y": y, "theta": 0.5, "mapId": "arena", "positionInitialized": True}


def _say(manager: FleetManager, name: str, kind: str, **message: Any) -> None:
    manager.heard(vda5050.topic(name, kind), message)


def _cart(manager: FleetManager, name: str) -> CartView:
    return next(c for c in manager.view().carts if c.name == name)


def test_each_cart_has_one_state_word_and_its_order() -> None:
    manager = _manager(("c1", 0.25, 0.25), ("c2", 1.75, 1.75), ("c3", 1.75, 0.25), ("c4", 0.25, 1.75))
    assert {c.name: c.state for c in manager.view().carts} == dict.fromkeys(("c1", "c2", "c3", "c4"), "idle")
    goal = manager.add_goal(0.25, 1.25, cart="c1")
    manager.step()
    c1 = _cart(manager, "c1")
    assert (c1.state, c1.order_id, c1.goal) == ("driving", f"c1-{goal.goal_id}", goal.goal_id)
    assert c1.position == (0.25, 0.25, 0.5) and (0.25, 0.25) in c1.held and c1.route[-1] == (0.25, 1.25)
    _say(manager, "c2", "connection", connectionState="CONNECTIONBROKEN")
    _say(manager, "c3", "state", agvPosition=_at(1.75, 0.25), paused=True)
    refused = vda5050.error("orderError", "an order is being driven", "WARNING", orderId="x")
    _say(manager, "c4", "state", agvPosition=_at(0.25, 1.75), errors=[refused])
    states = {c.name: c.state for c in manager.view().carts}
    assert states == {"c1": "driving", "c2": "offline", "c3": "paused", "c4": "error"}
    c4 = _cart(manager, "c4")
    assert [(e.type, e.level, e.description) for e in c4.errors] == [
        ("orderError", "WARNING", "an order is being driven")
    ]
    manager.stop_all()
    assert (_cart(manager, "c1").state, _cart(manager, "c1").order_id) == ("idle", None)


def test_the_page_is_the_built_panels_fleet_html_with_its_assets(tmp_path: Path) -> None:
    (tmp_path / "assets").mkdir()
    (tmp_path / "fleet.html").write_text('<script type="module" src="./assets/fleet-1.js"></script>')
    (tmp_path / "assets" / "fleet-1.js").write_text("export {};")
    client = TestClient(fleet_app(_manager(), "127.0.0.1", panel=tmp_path), base_url="http://127.0.0.1")
    assert "./assets/fleet-1.js" in client.get("/").text
    assert client.get("/assets/fleet-1.js").text == "export {};"
    unbuilt = TestClient(
        fleet_app(_manager(), "127.0.0.1", panel=tmp_path / "none"), base_url="http://127.0.0.1"
    )
    page = unbuilt.get("/")
    assert page.status_code == 200 and "make panel" in page.text


def test_the_view_carries_the_simulators_truth() -> None:
    def truth() -> dict[str, Any]:
        cart = {k: 0.0 for k in ("t", "x", "y", "theta", "v", "rtf")}
        cart.update(collisions=0, wall_contacts=0, box_contacts=0)
        return {"carts": {"c1": cart}, "cart_contacts": 1, "touching": [["c1", "c2"]]}

    client = TestClient(
        fleet_app(_manager(("c1", 0.25, 0.25)), "127.0.0.1", truth), base_url="http://127.0.0.1"
    )
    view = client.get("/api/fleet").json()
    assert view["truth"]["cart_contacts"] == 1 and view["truth"]["touching"] == [["c1", "c2"]]
    assert view["carts"][0]["state"] == "idle" and view["lattice"]["spacing_m"] == 0.5


def test_one_carts_cancel_and_pause_and_the_refusals_in_a_sentence() -> None:
    sent: list[tuple[str, dict[str, Any]]] = []
    manager = _manager(("c1", 0.25, 0.25), ("c2", 1.75, 1.75))
    manager._publish = lambda topic, message: sent.append((topic, message))
    client = TestClient(fleet_app(manager, "127.0.0.1"), base_url="http://127.0.0.1")

    def actions(cart: str) -> list[str]:
        return [
            a["actionType"]
            for topic, m in sent
            if topic.endswith(f"/{cart}/instantActions")
            for a in m["actions"]
        ]

    refused = client.post("/api/fleet/carts/c1/cancel", headers=JSON)
    assert (
        refused.status_code == 409
        and refused.json()["detail"] == "there is nothing to cancel: c1 drives no order"
    )
    unknown = client.post("/api/fleet/carts/c9/pause", json={"paused": True})
    assert unknown.status_code == 404 and unknown.json()["detail"] == "there is no cart 'c9' (carts: c1, c2)"
    assert client.post("/api/fleet/carts/c1/pause", json={"paused": "yes"}).status_code == 422
    assert actions("c1") == [] and actions("c9") == []

    goal = manager.add_goal(0.25, 1.25, cart="c1")
    manager.step()
    paused = client.post("/api/fleet/carts/c1/pause", json={"paused": True})
    assert paused.json() == {"cart": "c1", "sent": "startPause"}
    assert client.post("/api/fleet/carts/c1/pause", json={"paused": False}).json()["sent"] == "stopPause"
    assert client.post("/api/fleet/carts/c1/cancel", headers=JSON).json() == {
        "cart": "c1",
        "sent": "cancelOrder",
    }
    assert actions("c1") == ["startPause", "stopPause", "cancelOrder"] and actions("c2") == []
    assert goal.status == "cancelled" and _cart(manager, "c1").order_id is None
    assert (0.25, 0.25) in _cart(manager, "c1").held  # where it stands stays its own

    _say(manager, "c2", "connection", connectionState="CONNECTIONBROKEN")
    offline = client.post("/api/fleet/carts/c2/pause", json={"paused": True})
    assert offline.status_code == 409 and "cart c2 is CONNECTIONBROKEN" in offline.json()["detail"]
    assert actions("c2") == []
