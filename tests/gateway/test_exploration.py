"""Exploration's loop against a fake world (no simulator): a room of two halves joined by a door,
and a walled-off pocket whose floor shows through a window but has no way in. The camera
reveals the cells within 0.6 m of where the cart stands; it finishes with every reachable floor
cell seen, the pocket set aside with its reason, and the map saved; a STOP ends it at once."""

from __future__ import annotations

from cart2d.gateway.exploration import Explorer, Progress
from cart2d.maps.frontiers import Point
from cart2d.maps.occupancy import FREE
from tests.support.exploration_world import FakeWorld


def test_it_explores_every_reachable_floor_and_sets_the_pocket_aside() -> None:
    world = FakeWorld()
    told: list[Progress] = []
    saved: list[str] = []

    def save() -> str:
        saved.append("room")
        return "saved room.yaml"

    progress = Explorer(world.seen, world.path_length, world.go_to, lambda: False, save, told.append).run()
    assert progress.sentence.startswith("exploration finished: no reachable frontier left")
    assert progress.sentence.endswith("saved room.yaml") and saved == ["room"]
    reachable = world.truth == FREE
    reachable[20:30, 22:30] = False  # the pocket
    assert (world.seen_cells[reachable] == FREE).all()
    assert progress.set_aside and all(world.in_pocket(p) for p in progress.set_aside)
    assert all(r.startswith("no path to the frontier") for r in progress.set_aside.values())
    assert told[-1].goals == progress.goals > 3


def test_a_stop_ends_it_with_the_map_saved() -> None:
    world = FakeWorld()
    progress = Explorer(world.seen, world.path_length, world.go_to, lambda: True, lambda: "saved").run()
    assert progress.sentence == "exploration stopped by the user; saved" and progress.goals == 0


def test_a_goal_the_cart_fails_to_reach_is_not_sent_again() -> None:
    world = FakeWorld()
    sent: list[Point] = []

    def refuse(p: Point) -> str:
        sent.append(p)
        return "the path was blocked"

    progress = Explorer(world.seen, world.path_length, refuse, lambda: False, lambda: "saved").run()
    assert len(sent) == len(set(sent)) and progress.set_aside
    assert "no reachable frontier left" in progress.sentence


def test_a_way_left_out_for_now_is_taken_as_the_last_resort() -> None:
    """Every way through the door is 'not now' (math.inf: it passes a box's unseen side): the
    first choice finds nothing, and the last resort's lengths are chosen then, not the end."""
    world = FakeWorld()

    def not_now_beyond_the_door(p: Point) -> float | None:
        return float("inf") if p[0] > 1.5 else world.path_length(p)

    progress = Explorer(
        world.seen,
        not_now_beyond_the_door,
        world.go_to,
        lambda: False,
        lambda: "saved",
        last_resort=world.path_length,
    ).run()
    beyond = world.truth == FREE
    beyond[:, :16] = False
    beyond[20:30, 22:30] = False  # the pocket
    assert (world.seen_cells[beyond] == FREE).all(), progress.sentence
    without = FakeWorld()
    Explorer(without.seen, not_now_beyond_the_door, without.go_to, lambda: False, lambda: "saved").run()
    assert not (without.seen_cells[beyond] == FREE).all()  # what the last resort adds
