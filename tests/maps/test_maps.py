"""Occupancy maps (cart2d/maps/): ROS map_server files in and out, plain images, coarsening to the
planning grid, and planning on a floor plan (walls, unknown space, the map's edge)."""

from __future__ import annotations

import io
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cart2d.gateway.live_map import planner_for, world_for
from cart2d.maps import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    MapError,
    OccupancyMap,
    Thresholds,
    load_ros_map,
    map_from_image,
    map_from_ros,
    save_ros_map,
)
from cart2d.maps.ros import image_bytes
from cart2d.planning import GoalBlocked, Unreachable, polyline_length
from cart2d.store import FloorPlan, MapSettings, parse_settings


def random_map(seed: int, shape: tuple[int, int] = (37, 53)) -> OccupancyMap:
    rng = np.random.default_rng(seed)
    cells = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN], dtype=np.int8), size=shape, p=[0.6, 0.25, 0.15])
    return OccupancyMap((-1.25, 3.5), 0.05, cells)


@pytest.mark.parametrize("suffix", [".pgm", ".png"])
def test_a_ros_map_round_trips_through_its_yaml_and_image(tmp_path: Path, suffix: str) -> None:
    original = random_map(1)
    image = save_ros_map(original, tmp_path / "floor.yaml", suffix)
    assert image == tmp_path / f"floor{suffix}"
    text = (tmp_path / "floor.yaml").read_text()
    assert f"image: floor{suffix}" in text and "mode: trinary" in text
    loaded = load_ros_map(tmp_path / "floor.yaml")
    assert loaded.same_cells(original)
    # export again: the same bytes
    save_ros_map(loaded, tmp_path / "again.yaml", suffix)
    assert (tmp_path / f"again{suffix}").read_bytes() == image.read_bytes()


def test_the_image_is_read_as_map_server_reads_it() -> None:
    # top row of the image = highest y; p = (255 - x) / 255 against the thresholds (strictly)
    pixels = np.array([[0, 254, 128], [255, 100, 166]], dtype=np.uint8)  # 100: p = 0.608; 166: 0.349
    data = io.BytesIO()
    Image.fromarray(pixels, mode="L").save(data, format="PNG")
    yaml_text = "image: m.png\nresolution: 0.1\norigin: [1.0, 2.0, 0.0]\nnegate: 0\n"
    yaml_text += "occupied_thresh: 0.6\nfree_thresh: 0.3\n"
    m = map_from_ros(yaml_text, data.getvalue())
    assert m.origin_m == (1.0, 2.0) and m.resolution_m == 0.1 and (m.width, m.height) == (3, 2)
    assert m.cells.tolist() == [[FREE, OCCUPIED, UNKNOWN], [OCCUPIED, FREE, UNKNOWN]]
    negated = map_from_ros(yaml_text.replace("negate: 0", "negate: 1"), data.getvalue())
    assert negated.cells.tolist() == [[OCCUPIED, UNKNOWN, OCCUPIED], [FREE, OCCUPIED, UNKNOWN]]
    # colour channels are averaged: (255, 0, 0) is x = 85, p = 0.667 > 0.6
    rgb = io.BytesIO()
    Image.fromarray(np.array([[[255, 0, 0], [255, 255, 255]]] * 2, dtype=np.uint8), mode="RGB").save(
        rgb, "PNG"
    )
    assert map_from_ros(yaml_text, rgb.getvalue()).cells[0].tolist() == [OCCUPIED, FREE]


def test_a_plain_image_with_a_resolution() -> None:
    pixels = np.full((4, 6), 255, dtype=np.uint8)
    pixels[0, :] = 0  # the top row: a wall along the highest y
    data = io.BytesIO()
    Image.fromarray(pixels, mode="L").save(data, format="PNG")
    m = map_from_image(data.getvalue(), 0.5, (-1.0, -1.0))
    assert m.extent_m == (-1.0, -1.0, 2.0, 1.0)
    assert (m.cells[3] == OCCUPIED).all() and (m.cells[:3] == FREE).all()
    assert (map_from_image(data.getvalue(), 0.5, thresholds=Thresholds(negate=True)).cells[3] == FREE).all()


@pytest.mark.parametrize(
    ("yaml_text", "words"),
    [
        ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0.5]\n", "yaw"),
        ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\nmode: scale\n", "trinary"),
        ("image: m.png\norigin: [0, 0, 0]\n", "resolution"),
        ("image: m.png\nresolution: -1\norigin: [0, 0, 0]\n", "resolution"),
        ("resolution: 0.1\norigin: [0, 0, 0]\n", "image"),
        (
            "image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.9\noccupied_thresh: 0.2\n",
            "thresh",
        ),
        ("image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 2\n", "negate"),
        ("- a list\n", "mapping"),
        ("image: [unclosed\n", "cannot be read"),
    ],
)
def test_bad_yaml_is_refused_with_the_reason(yaml_text: str, words: str) -> None:
    with pytest.raises(MapError, match=words):
        map_from_ros(yaml_text, image_bytes(random_map(2), ".png"))


def test_bad_images_are_refused() -> None:
    yaml_text = "image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\n"
    with pytest.raises(MapError, match="not a PNG nor a PGM"):
        map_from_ros(yaml_text, b"not an image")
    big = io.BytesIO()
    Image.new("L", (2001, 3)).save(big, format="PNG")
    with pytest.raises(MapError, match="2000"):
        map_from_ros(yaml_text, big.getvalue())


def test_coarsening_never_loses_an_obstacle_nor_frees_unknown_space() -> None:
    fine = random_map(3)
    for k in (2, 3, 4, 7):
        coarse = fine.coarsened(k)
        assert coarse.resolution_m == pytest.approx(0.05 * k) and coarse.origin_m == fine.origin_m
        assert coarse.height == math.ceil(fine.height / k) and coarse.width == math.ceil(fine.width / k)
        for j in range(fine.height):
            for i in range(fine.width):
                block = coarse.cells[j // k, i // k]
                if fine.cells[j, i] == OCCUPIED:
                    assert block == OCCUPIED
                elif fine.cells[j, i] == UNKNOWN:
                    assert block != FREE
        # a block is free only when all its cells are (those past the edge count as unknown)
        padded = np.full((coarse.height * k, coarse.width * k), UNKNOWN, dtype=np.int8)
        padded[: fine.height, : fine.width] = fine.cells
        for j, i in zip(*np.nonzero(coarse.cells == FREE), strict=True):
            assert (padded[j * k : (j + 1) * k, i * k : (i + 1) * k] == FREE).all()


def test_the_planning_step_is_chosen_and_bounded() -> None:
    m = OccupancyMap((0.0, 0.0), 0.05, np.zeros((2000, 2000), dtype=np.int8))
    assert m.planning_factor(None, 0.2) == 2  # half the planning radius: 0.1 m blocks
    assert m.planning_factor(0.05, 0.2) == 2  # at most 1024 x 1024 nodes even when asked finer
    assert m.planning_factor(0.5, 0.2) == 10
    assert OccupancyMap((0.0, 0.0), 0.2, np.zeros((10, 10), np.int8)).planning_factor(None, 0.2) == 1


def corridor_map(unknown_stripe: bool) -> OccupancyMap:
    """A 4 x 2 m room at 0.05 m with walls all round (the image's outline) and a wall across
    x = 2 m with a 0.6 m gap at the top; optionally a stripe of unknown across the gap."""
    cells = np.zeros((40, 80), dtype=np.int8)
    cells[0, :] = cells[-1, :] = OCCUPIED
    cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[:28, 39:41] = OCCUPIED
    if unknown_stripe:
        cells[28:39, 39:41] = UNKNOWN
    return OccupancyMap((-0.5, -0.5), 0.05, cells)


def test_planning_on_an_imported_map_goes_through_the_gap(tmp_path: Path) -> None:
    save_ros_map(corridor_map(False), tmp_path / "room.yaml")
    m = MapSettings.model_validate({"floor_plan": FloorPlan.of(load_ros_map(tmp_path / "room.yaml"), "room")})
    assert (m.cols, m.rows, m.step_m) == (40, 20, 0.1)
    assert m.origin_m == pytest.approx((-0.45, -0.45))  # node (0, 0): the centre of block (0, 0)
    planner = planner_for(m)
    plan = planner.plan((0.3, 0.3), (3.0, 0.3))
    graph = planner.graph
    route = [plan.start, *plan.waypoints]
    assert all(graph.segment_free(a, b) for a, b in itertools.pairwise(route))
    # over the wall's top (gap from y = 0.9 m to 1.45 m): higher than 0.9 + the 0.2 m radius
    assert max(y for _, y in plan.waypoints) > 1.1 - 1e-6
    assert polyline_length(route) > 2.7 + 0.3  # up and over, not through
    # the footprint stays on the map: a goal a radius from its edge is refused
    with pytest.raises(GoalBlocked):
        planner.plan((0.3, 0.3), (-0.4, 0.3))


def test_unknown_space_is_blocked_unless_allowed() -> None:
    floor = FloorPlan.of(corridor_map(True), "room")
    blocked = planner_for(MapSettings.model_validate({"floor_plan": floor}))
    with pytest.raises(Unreachable):
        blocked.plan((0.3, 0.3), (3.0, 0.3))
    allowed = planner_for(MapSettings.model_validate({"floor_plan": floor, "unknown_is_free": True}))
    assert allowed.plan((0.3, 0.3), (3.0, 0.3)).length_m > 2.7


def test_the_settings_file_carries_the_floor_plan() -> None:
    m = MapSettings.model_validate(
        {"floor_plan": FloorPlan.of(random_map(4), "r.yaml"), "obstacles": [(3, 4)]}
    )
    text = m.model_dump_json()
    again = parse_settings(('{"map": ' + text + "}").encode()).map
    assert again.floor_plan is not None and again.floor_plan.occupancy().same_cells(random_map(4))
    assert again.obstacles == [(3, 4)] and (again.cols, again.rows) == (m.cols, m.rows)
    broken = text.replace(again.floor_plan.cells[:12], "AAAAAAAAAAAA")
    with pytest.raises(ValueError, match="cells"):
        parse_settings(('{"map": ' + broken + "}").encode())


def test_the_simulated_world_follows_the_map() -> None:
    # a node grid: walls a margin outside its nodes, wherever its origin
    world = world_for(MapSettings(cols=20, rows=10, step_m=0.2, origin_m=(1.0, -1.0)))
    assert world.boundary == pytest.approx((0.75, -1.25, 1.0 + 3.8 + 0.25, -1.0 + 1.8 + 0.25))
    # a floor plan: its occupied cells, and walls at its edge
    plan = corridor_map(False)
    world = world_for(MapSettings.model_validate({"floor_plan": FloorPlan.of(plan)}))
    assert world.walls is not None and world.boundary is True
    assert world.walls.origin == plan.origin_m and world.walls.resolution == 0.05
    assert sum(world.walls.occupied) == int((plan.cells == OCCUPIED).sum())
