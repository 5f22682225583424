"""The panel's files on a cart's gateway (cart2d/server/panel.py): web/ builds the fleet page
beside the panel, and a cart's gateway does not serve it (it has no /api/fleet: the page would
only say its manager is lost); `cart2d fleet` serves it (tests/fleet/test_fleet_views.py)."""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.testclient import TestClient

from cart2d.server.panel import PanelFiles


def test_a_carts_gateway_serves_the_panel_but_not_the_fleet_page(tmp_path: Path) -> None:
    (tmp_path / "index.html").write_text("<!doctype html><title>panel</title>")
    (tmp_path / "fleet.html").write_text("<!doctype html><title>fleet</title>")
    app = FastAPI()
    app.mount("/", PanelFiles(directory=tmp_path, api_routes=app.router.routes), name="panel")
    client = TestClient(app, base_url="http://127.0.0.1")
    assert "panel" in client.get("/").text
    assert client.get("/fleet.html").status_code == 404
    assert client.get("/fleet").status_code == 404
