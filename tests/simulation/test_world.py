"""The simulator's physical world against the real firmware: boxes and map walls stop the cart
and close its switches (the firmware's bumper stop fires), a map's corridor lets it through, an
arena of any size and origin, timed physical obstacles, and `place` refused into a box. Judged
by ground truth."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cart2d.link import Link
from cart2d.link.firmware import read_status
from cart2d.maps.world import Box, WallGrid, World, arena_world, run_lengths
from cart2d.simulation.side_channel import SimulatorError
from tests.support.sim import events, high_rate_truth, start_sim, wait_idle

BUMPER_X = 0.17  # robot.toml [body] bumper_x_m


# -- the messages, without a simulator ---------------------------------------------------------


def test_run_lengths_start_with_free_cells() -> None:
    assert run_lengths([False, True, True, False, False, False, True]) == [1, 2, 3, 1]
    assert run_lengths([True, False]) == [0, 1, 1]
    assert run_lengths([False, False]) == [2]


def test_a_world_message_from_rows_of_cells() -> None:
    grid = WallGrid.from_rows([[False, True], [True, True]], origin=(-1.0, 2.0), resolution=0.5)
    world = World(boxes=(Box(1.0, 2.0, 0.2, 0.4, id="a"),), walls=grid)
    assert world.message() == {
        "boxes": [{"x": 1.0, "y": 2.0, "sx": 0.2, "sy": 0.4, "height": 0.3, "colour": "#b8742f", "id": "a"}],
        "walls": {"origin": [-1.0, 2.0], "resolution": 0.5, "width": 2, "height": 2, "rle": [1, 3]},
    }
    assert World(boundary=False).message()["boundary"] is False
    with pytest.raises(ValueError):
        WallGrid.from_rows([[True], [True, False]], (0.0, 0.0), 0.1)


def test_the_arena_of_a_grid_lies_the_margin_outside_its_nodes() -> None:
    assert arena_world(20, 10, 0.2, margin=0.25).boundary == pytest.approx((-0.25, -0.25, 4.05, 2.05))


# -- against the firmware ----------------------------------------------------------------------


def test_the_bumper_stops_the_cart_at_a_box(tmp_path: Path) -> None:
    # A box across the path: the switches close on its face and the firmware's bumper stop fires
    # within a control tick or two, as against a wall; the box counts as a box contact.
    world = World(boxes=(Box(1.5, 0.9, 0.2, 0.6, id="crate"),), boundary=(-0.25, -0.25, 2.05, 2.05))
    sim = start_sim(tmp_path, world=world, start=(0.6, 0.9, 0.0), speed="1")  # every sample
    try:
        with Link(sim.pty, timeout_s=0.3) as link:
            link.call("SET_POSE", 0.6, 0.9, 0.0)
            samples = high_rate_truth(sim)
            link.call("GOTO", 1.9, 0.9)
            wait_idle(link)
            status = read_status(link)
            truth = sim.truth()
        contact = next(s for s in samples if s["switch_l"] or s["switch_r"])
        off = next(s for s in samples if s["t"] >= contact["t"] and s["duty_l"] == 0.0 and s["duty_r"] == 0.0)
        assert contact["v"] > 0.2
        assert off["t"] - contact["t"] <= 0.017
        assert status.has("BUMPER") and status.mode == "IDLE"
        assert max(s["x"] for s in samples) + BUMPER_X <= 1.4 + 1e-6  # never into the box
        assert truth["x"] + BUMPER_X == pytest.approx(1.4, abs=0.003)  # it rests on the face
        assert truth["switch_l"] and truth["switch_r"]
        assert (truth["box_contacts"], truth["wall_contacts"], truth["collisions"]) == (1, 0, 0)
        assert truth["boxes"] == 1
        (event,) = events(sim, "box_contact")
        assert event["id"] == "crate" and event["x"] == 1.5
    finally:
        sim.stop()


def test_the_reset_routine_squares_up_against_a_box(tmp_path: Path) -> None:
    # The routine creeps forwards until a switch closes, holds that side and pushes the other
    # until both are pressed: against a box's face as against a wall.
    world = World(boxes=(Box(1.7, 0.9, 0.2, 1.0, id="crate"),), boundary=(-0.25, -0.25, 2.45, 2.05))
    sim = start_sim(tmp_path, world=world, start=(1.0, 0.9, 0.2))
    try:
        with Link(sim.pty) as link:
            link.call("RESET_ROUTINE")
            wait_idle(link)
            status = read_status(link)
        truth = sim.truth()
        assert not status.has("ROUTINE_FAILED")
        assert truth["switch_l"] and truth["switch_r"]
        assert abs(math.remainder(truth["theta"], 2 * math.pi)) < 0.01  # square to the face at x = 1.6
        assert truth["x"] + BUMPER_X == pytest.approx(1.6, abs=0.005)
        assert truth["box_contacts"] >= 1 and truth["wall_contacts"] == 0
    finally:
        sim.stop()


def corridor_world() -> World:
    """A 3 m x 2 m map at 5 cm from (-0.5, -0.5): a wall x in [1.0, 1.3) across it, but for a
    0.5 m corridor at y in [0.5, 1.0). The cart is 0.34 m wide (its bumper's ends 0.39 m)."""
    rows = [[30 <= i < 36 and not 20 <= j < 30 for i in range(60)] for j in range(40)]
    return World(walls=WallGrid.from_rows(rows, origin=(-0.5, -0.5), resolution=0.05))


def test_a_maps_corridor_lets_the_cart_through_and_its_walls_stop_it(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, world=corridor_world(), start=(0.3, 0.75, 0.0))
    try:
        state = sim.world_state()
        assert len(state["walls"]) == 2 + 4  # the blocks beside the corridor, the map's boundary
        with Link(sim.pty, timeout_s=0.3) as link:
            link.call("SET_POSE", 0.3, 0.75, 0.0)
            link.call("GOTO", 2.0, 0.75)  # straight through the corridor
            wait_idle(link)
            through = sim.truth()
            assert read_status(link).has("ARRIVED")
            assert math.hypot(through["x"] - 2.0, through["y"] - 0.75) < 0.01
            assert through["wall_contacts"] == 0

            sim.control("place", x=0.3, y=0.2, theta=0.0)  # back west, below the corridor
            link.call("SET_POSE", 0.3, 0.2, 0.0)
            link.call("GOTO", 2.0, 0.2)  # straight into the wall
            wait_idle(link)
            status = read_status(link)
            stopped = sim.truth()
        assert status.has("BUMPER")
        assert stopped["wall_contacts"] == 1 and stopped["box_contacts"] == 0
        assert stopped["x"] + BUMPER_X == pytest.approx(1.0, abs=0.003)  # on the wall's west face
        assert stopped["switch_l"] and stopped["switch_r"]
    finally:
        sim.stop()


def test_an_arena_of_any_size_and_origin(tmp_path: Path) -> None:
    # A settings file with cols: 20 draws a 4 m map: its walls must be 4 m apart, not 2 m.
    wide = start_sim(tmp_path, world=arena_world(20, 10, 0.2), start=(0.4, 0.9, 0.0))
    try:
        with Link(wide.pty, timeout_s=0.3) as link:
            link.call("SET_POSE", 0.4, 0.9, 0.0)
            link.call("GOTO", 3.6, 0.9)
            wait_idle(link)
            assert read_status(link).has("ARRIVED")
        truth = wide.truth()
        assert math.hypot(truth["x"] - 3.6, truth["y"] - 0.9) < 0.01
        assert truth["wall_contacts"] == 0
    finally:
        wide.stop()
    # An origin far from (0, 0): the start pose is checked against this world, not the default.
    moved = start_sim(tmp_path, world=World(boundary=(-3.0, -2.0, 1.0, 2.0)), start=(-2.5, -1.5, 0.0))
    try:
        assert moved.truth()["x"] == -2.5
        with Link(moved.pty, timeout_s=0.3) as link:
            link.call("SET_POSE", -2.5, -1.5, 0.0)
            link.call("GOTO", 0.5, 1.5)
            wait_idle(link)
        truth = moved.truth()
        assert math.hypot(truth["x"] - 0.5, truth["y"] - 1.5) < 0.01
        assert truth["wall_contacts"] == 0
    finally:
        moved.stop()


def test_a_start_inside_a_box_is_refused(tmp_path: Path) -> None:
    world = World(boxes=(Box(1.0, 1.0, 0.4, 0.4, id="pillar"),), boundary=(-0.25, -0.25, 2.05, 2.05))
    with pytest.raises(SimulatorError, match='overlap box "pillar"'):
        start_sim(tmp_path, world=world, start=(1.0, 0.7, 0.0))


def test_place_is_refused_where_the_footprint_overlaps_a_box(tmp_path: Path) -> None:
    world = World(boxes=(Box(1.0, 1.0, 0.4, 0.4, id="pillar"),), boundary=(-0.25, -0.25, 2.05, 2.05))
    sim = start_sim(tmp_path, world=world, start=(0.3, 0.3, 0.0))
    try:
        with pytest.raises(SimulatorError, match='overlap box "pillar"'):
            sim.control("place", x=1.0, y=0.65, theta=0.0)  # the disc 2 cm into its south face
        with pytest.raises(SimulatorError, match="overlap box"):
            sim.control("place", x=0.64, y=1.0, theta=0.0)  # the bumper 1 cm into its west face
        with pytest.raises(SimulatorError, match="overlap a wall"):
            sim.control("place", x=1.9, y=1.0, theta=0.0)
        assert (sim.truth()["x"], sim.truth()["y"]) == (0.3, 0.3)  # refused: nothing moved
        sim.control("place", x=0.62, y=1.0, theta=0.0)  # 1 cm clear of the box
        assert sim.truth()["x"] == 0.62
    finally:
        sim.stop()


def test_an_event_obstacle_becomes_physical_at_its_time(tmp_path: Path) -> None:
    # A mission's event obstacle (issue 13): scheduled in simulated time, it is virtual and
    # physical from that moment; the cart driving at it stops on it, and the touch counts both
    # as a collision (the obstacle) and as a box contact (its box).
    sim = start_sim(tmp_path, start=(0.4, 0.9, 0.0))
    try:
        with Link(sim.pty, timeout_s=0.3) as link:
            link.call("SET_POSE", 0.4, 0.9, 0.0)
            sim.control("speed", factor=1)  # real time while we look at the schedule
            at_s = round(sim.truth()["t"] + 1.0, 3)
            ack = sim.change_obstacles(add=[(1.4, 0.9)], step=0.2, physical=True, at_s=at_s)
            assert ack["scheduled"] and ack["at"] == at_s
            state = sim.world_state()
            assert state["boxes"] == [] and state["obstacles"] == []
            assert [c["what"] for c in state["scheduled"]] == ["obstacles"]
            sim.control("speed", factor="max")
            link.call("GOTO", 1.9, 0.9)
            wait_idle(link)
            status = read_status(link)
        truth = sim.truth()
        (changed,) = events(sim, "world_changed")
        assert at_s <= changed["t"] <= at_s + 0.001
        assert changed["boxes"] == 1 and changed["obstacles"] == 1
        assert status.has("BUMPER")
        assert truth["x"] + BUMPER_X == pytest.approx(1.3, abs=0.003)
        assert (truth["collisions"], truth["box_contacts"]) == (1, 1)
        (box,) = sim.world_state()["boxes"]
        assert box["obstacle"] and box["id"] == "obstacle@1.4,0.9"
        sim.change_obstacles(remove=[(1.4, 0.9)])  # removing the obstacle removes its box
        assert sim.world_state()["boxes"] == []
    finally:
        sim.stop()
