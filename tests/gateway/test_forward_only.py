"""While the gateway sees, the cart drives forwards only (issue 14, cart2d/gateway/forward_only.py
and the firmware setting reverse_allowed): a route that starts behind the cart is driven by
turning round first, so the camera sees where the cart goes; blind, the seed's reversing is
unchanged. Reverse motion is measured on the simulator's ground truth (the recording's /ws
"truth" messages), in simulated time."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

from cart2d.gateway.forward_only import REVERSE_ALLOWED, ReverseGuard
from cart2d.link import firmware
from cart2d.tools.missions.camera import mission_camera
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec
from tests.support.recording import Read
from tests.support.server import Rig
from tests.support.waiting import wait_for

# not show it, so the first plan runs straight through it, starting behind the cart.
BOX_XY, BOX_SIZE = (0.9, 0.9), (0.2, 0.4)
BOX = {
    "x": BOX_XY[0],
    "y": BOX_XY[1],
    "sx": BOX_SIZE[0],
    "sy": BOX_SIZE[1],
    "height": 0.3,
    "colour": "#3050c0",
}


def facing_away(**extra: Any) -> MissionSpec:
    body = {
        "grid": {"cols": 10, "rows": 10, "step": 0.2},
        "start": [0.3, 0.9, math.pi],  # facing west, the goal east
        "goals": [[1.6, 0.9]],
        "world": {"boxes": [BOX]},
        "timeout_s": 60.0,
        **extra,
    }
    return MissionSpec.model_validate_json(json.dumps(body))


def longest_reverse_m(recording: Path) -> float:
    """The longest distance the cart drove backwards at a stretch (along its heading, truth)."""
    truth = Read(recording).ws("truth")
    longest = run = 0.0
    for a, b in itertools.pairwise(truth):
        theta = a["theta"] + 0.5 * math.remainder(b["theta"] - a["theta"], math.tau)
        along = (b["x"] - a["x"]) * math.cos(theta) + (b["y"] - a["y"]) * math.sin(theta)
        if along < 0.0:
            run += -along
            longest = max(longest, run)
        elif along > 1e-4:  # driving forwards ends a stretch; turning on the spot does not
            run = 0.0
    return longest


def test_seeing_the_cart_turns_round_for_a_route_behind_it_and_sees_the_box(tmp_path: Path) -> None:
    report = run_mission(facing_away(), base_dir=tmp_path, mcap_path=tmp_path / "run.mcap")
    goal = report["goals"][0]
    assert goal["reached"], goal.get("reason")
    assert report["box_contacts"] == 0 and report["collisions"] == 0
    assert longest_reverse_m(tmp_path / "run.mcap") < 0.05
    # It saw the box once it faced it: while it turned to look before driving off, or on the way
    # (which of the two depends on how soon the frames are processed, in wall-clock time).
    perceived = report["perception"]
    seen = [(x, y) for x, y, p in perceived["cells"] if p > 0.8 and on_the_box(x, y)]
    assert len(seen) >= BOX_SIZE[1] / perceived["resolution_m"]  # at least the face it drove at


def on_the_box(x: float, y: float, margin_m: float = 0.025) -> bool:
    """Within a perceived cell's size of BOX."""
    return all(abs(v - c) <= size / 2 + margin_m for v, c, size in zip((x, y), BOX_XY, BOX_SIZE, strict=True))


def test_blind_the_cart_still_backs_to_a_route_behind_it_as_the_seed_did(tmp_path: Path) -> None:
    report = run_mission(facing_away(perception=False), base_dir=tmp_path, mcap_path=tmp_path / "run.mcap")
    assert report["box_contacts"] >= 1  # backing into the box it never saw
    assert longest_reverse_m(tmp_path / "run.mcap") > 0.2  # 0.33 m, then it stalls against the box


class FakeLink:
    """PARAM_GET / PARAM_SET of the firmware's reverse_allowed, and the writes seen."""

    def __init__(self, value: float) -> None:
        self.value = value
        self.writes: list[float] = []

    def call(self, command: str, ident: int, *args: float, **_: Any) -> tuple[float, ...]:
        assert ident == REVERSE_ALLOWED
        if command == "PARAM_SET":
            self.value = args[0]
            self.writes.append(args[0])
        return (ident, self.value, 0.0, 1.0)


def test_the_users_value_comes_back_when_the_gateway_no_longer_sees() -> None:
    link, guard = FakeLink(1.0), ReverseGuard()
    guard.apply(link, seeing=True)  # type: ignore[arg-type]
    guard.apply(link, seeing=True)  # type: ignore[arg-type]
    assert link.value == 0.0 and link.writes == [0.0]
    guard.apply(link, seeing=False)  # type: ignore[arg-type]
    assert link.value == 1.0 and link.writes == [0.0, 1.0]
    guard.apply(link, seeing=False)  # type: ignore[arg-type]
    assert link.writes == [0.0, 1.0]


def test_a_restart_that_loads_reversing_again_is_overridden_again() -> None:
    link, guard = FakeLink(1.0), ReverseGuard()
    guard.apply(link, seeing=True)  # type: ignore[arg-type]
    link.value = 1.0  # the MCU restarted: its saved settings are loaded
    guard.apply(link, seeing=True)  # type: ignore[arg-type]
    assert link.value == 0.0 and link.writes == [0.0, 0.0]
    guard.apply(link, seeing=False)  # type: ignore[arg-type]
    assert link.value == 1.0


def test_a_user_who_forbids_reversing_keeps_it_forbidden() -> None:
    link, guard = FakeLink(0.0), ReverseGuard()
    guard.apply(link, seeing=True)  # type: ignore[arg-type]
    guard.apply(link, seeing=False)  # type: ignore[arg-type]
    assert link.value == 0.0 and link.writes == []


def test_while_seeing_a_restart_of_the_mcu_does_not_let_its_saved_reversing_back(rig: Rig) -> None:
    def reverse_allowed() -> float:
        return firmware.read_setting(rig.link, REVERSE_ALLOWED)

    assert reverse_allowed() == 1.0  # the default: the seed's behaviour
    with mission_camera(rig.gateway, rig.sim, None):
        assert reverse_allowed() == 0.0  # from the moment it sees
        noticed = rig.gateway.resets_noticed
        rig.sim.control("reset")  # the reset button: the firmware loads its settings (1) again
        wait_for(lambda: rig.gateway.resets_noticed > noticed, 10)
        assert reverse_allowed() == 0.0
    assert reverse_allowed() == 1.0  # the camera gone, the user's value is back
