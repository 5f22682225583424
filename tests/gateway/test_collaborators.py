"""What the gateway may be given besides its link (cart2d/gateway/collaborators.py): a source of
ground truth, a simulated world, a status part. Fakes: no simulator; a real cart has none."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from cart2d.gateway import Gateway
from cart2d.maps.world import World
from cart2d.store import Store
from tests.support.fake_firmware import FakeFirmware


class FakeTruth:
    def __init__(self) -> None:
        self.listeners: list[Callable[[dict[str, Any]], None]] = []
        self.t: float | None = None

    def time_s(self) -> float | None:
        return self.t

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> None:
        self.listeners.append(listener)

    def send(self, t: float) -> None:
        self.t = t
        for listener in self.listeners:
            listener(truth_at(t))


def truth_at(t: float) -> dict[str, Any]:
    """A whole truth message (messages.TruthMessage) of a cart standing at (0, 0) at time t."""
    message: dict[str, Any] = {"type": "truth", "t": t, "mcu": "running", "rtf": 1.0}
    message["cpu"] = {"mean": 0.02, "max": 0.08, "ticks": 10}
    for name in ("x", "y", "theta", "v", "omega", "wheel_l", "wheel_r", "slip_l", "slip_r", "caster"):
        message[name] = 0.0
    for name in ("duty_l", "duty_r", "current_l", "current_r", "enc_l", "enc_r"):
        message[name] = 0.0
    for name in ("switch_l", "switch_r", "in_collision", "in_wall_contact", "in_box_contact"):
        message[name] = False
    for name in ("collisions", "wall_contacts", "box_contacts", "boxes"):
        message[name] = 0
    message["first_collision_t"] = message["first_wall_contact_t"] = None
    return message


class FakeWorld:
    def __init__(self) -> None:
        self.walls: list[World] = []

    def follow_walls(self, walls: Callable[[], World]) -> None:
        self.walls.append(walls())

    def boxes_view(self) -> dict[str, Any] | None:
        return {"version": 1, "boxes": []}


def gateway_with(tmp_path: Path, **collaborators: Any) -> Gateway:
    store = Store(tmp_path)
    return Gateway(FakeFirmware(), store, store.load(), **collaborators)


def test_a_real_cart_has_the_monotonic_clock_and_is_not_simulated(tmp_path: Path) -> None:
    gateway = gateway_with(tmp_path)
    assert gateway.cart_time() is not None and not gateway.simulated
    view = gateway.status_view()
    assert view["link"]["simulated"] is False and "simulator" not in view


def test_the_ground_truth_is_the_carts_clock_and_reaches_the_viewers(tmp_path: Path) -> None:
    truth = FakeTruth()
    gateway = gateway_with(tmp_path, truth=truth)
    seen: list[dict[str, Any]] = []
    gateway.subscribe(seen.append)
    assert gateway.cart_time() is None  # before its first message
    truth.send(3.5)
    assert gateway.cart_time() == 3.5
    assert seen == [truth_at(3.5)]


def test_the_simulated_worlds_walls_follow_the_map(tmp_path: Path) -> None:
    world = FakeWorld()
    gateway = gateway_with(tmp_path, world=world)
    assert gateway.simulated and gateway.status_view()["link"]["simulated"] is True
    assert len(world.walls) == 1  # at once
    larger = gateway.settings.map.model_copy(update={"cols": 14, "rows": 12})
    gateway.update_settings(gateway.settings.model_copy(update={"map": larger}))
    assert len(world.walls) == 2 and world.walls[1] != world.walls[0]
    gateway.set_obstacle(1.0, 0.8, True)  # an obstacle is not a wall: the world is left alone
    assert len(world.walls) == 2


def test_a_status_part_is_in_the_status(tmp_path: Path) -> None:
    gateway = gateway_with(tmp_path)
    state = {"state": "running"}
    gateway.add_status_part("simulator", lambda: dict(state))
    state["state"] = "restarting"
    assert gateway.status_view()["simulator"] == {"state": "restarting"}


def test_a_soft_reset_presses_the_reset_button_given_else_sends_reboot(tmp_path: Path) -> None:
    cart = FakeFirmware()
    store = Store(tmp_path)
    pressed: list[int] = []

    def press() -> None:
        pressed.append(1)
        cart.restart(keep_pose=True)

    gateway = Gateway(cart, store, store.load(), reset_button=press)
    assert gateway.soft_reset() is not None
    assert pressed == [1] and "REBOOT" not in cart.requests
    real = gateway_with(tmp_path)
    assert real.soft_reset() is not None
    assert "REBOOT" in real.link.requests  # type: ignore[attr-defined]
