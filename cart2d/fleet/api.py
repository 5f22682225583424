"""The fleet manager's HTTP API and its page (`cart2d fleet`, `cart2d fleet sim`): every cart on
one live map, goals dropped on it or posted, STOP ALL. The server's guards (Host, origin,
content type, body size: cart2d/server/guards.py) stand in front of it as of the gateway."""

from __future__ import annotations

from collections.abc import Callable
from importlib import resources
from typing import Any

from fastapi import FastAPI, HTTPException
from fastapi.responses import HTMLResponse
from pydantic import BaseModel, ConfigDict, Field

from cart2d.fleet.manager import FleetManager
from cart2d.server import guards

Truth = Callable[[], dict[str, Any]]


class GoalRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    x: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    y: float = Field(ge=-1000, le=1000, allow_inf_nan=False)
    cart: str | None = Field(
        None, max_length=64, description="the cart to send (default: the nearest idle one)"
    )


def fleet_app(manager: FleetManager, bind_host: str, truth: Truth | None = None) -> FastAPI:
    """`truth`: the simulated carts' ground truth (the shared arena's view), if simulated."""
    app = FastAPI(title="cart2d fleet", docs_url=None, redoc_url=None)
    guards.install(app, bind_host)
    page = resources.files("cart2d.fleet").joinpath("fleet.html").read_text()

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def fleet_page() -> str:
        return page

    @app.get("/api/fleet")
    def fleet_view() -> dict[str, Any]:
        """Every cart (connection, pose, state, nodes held, route), the goals, the deadlocks."""
        view = manager.view()
        if truth is not None:
            view["truth"] = truth()
        return view

    @app.post("/api/fleet/goals", status_code=201)
    def add_goal(goal: GoalRequest) -> dict[str, Any]:
        """A goal for the named cart or the nearest idle one, at the lattice node nearest (x, y)."""
        try:
            added = manager.add_goal(goal.x, goal.y, goal.cart)
        except ValueError as exc:
            raise HTTPException(400, str(exc)) from exc
        return {"id": added.goal_id, "at": manager.lattice.position(added.cell), "cart": added.cart}

    @app.post("/api/fleet/stop")
    def stop_all() -> dict[str, str]:
        """STOP ALL: every gateway's own stop where it runs here, then cancelOrder to each cart."""
        manager.stop_all()
        return {"stopped": "all"}

    @app.delete("/api/fleet/carts/{name}")
    def remove_cart(name: str) -> dict[str, str]:
        """Forgets a cart: the nodes an OFFLINE cart held are free again."""
        if name not in manager.carts:
            raise HTTPException(404, f"there is no cart {name!r}")
        manager.remove(name)
        return {"removed": name}

    return app
