"""The map built from what the camera saw: which cell is what, saved as a ROS map_server map and
loaded back the same; POST /api/map/save refusing what it cannot do with a sentence."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from cart2d.gateway import Gateway
from cart2d.gateway.map_saving import checked_name, save_seen_map
from cart2d.maps.building import built_map
from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN
from cart2d.maps.ros import load_ros_map
from cart2d.server import create_app


class SeenGrid:
    """What the camera saw, as seeing.py's grid offers it: a wall along y = 0.5 m seen, floor
    in front of it seen free, the rest never looked at."""

    origin = (-0.5, -0.25)
    resolution_m = 0.05
    width, height = 40, 30

    def __init__(self) -> None:
        self.p = np.full((self.height, self.width), 0.5, dtype=np.float32)
        self.seen = np.zeros((self.height, self.width), dtype=np.bool_)
        self.seen[5:15, 5:30] = True
        self.p[5:14, 5:30] = 0.1  # floor
        self.p[14, 5:30] = 0.95  # the wall's face

    def probability(self) -> np.ndarray:
        return self.p

    def observed(self, points: np.ndarray) -> np.ndarray:
        ij = np.floor((points - np.array(self.origin)) / self.resolution_m).astype(int)
        return np.asarray(self.seen[ij[:, 1], ij[:, 0]])


class Seeing:
    grid = SeenGrid()


def test_cells_are_occupied_where_believed_free_where_floor_was_seen_unknown_elsewhere() -> None:
    grid = SeenGrid()
    built = built_map(grid.probability(), grid.seen, grid.origin, grid.resolution_m)
    assert (built.cells[14, 5:30] == OCCUPIED).all()
    assert (built.cells[5:14, 5:30] == FREE).all()
    assert (built.cells[20:, :] == UNKNOWN).all() and (built.cells[:, 35:] == UNKNOWN).all()


def test_a_saved_map_loads_back_equal(tmp_path: Path) -> None:
    saved = save_seen_map(Seeing(), tmp_path, "room")  # type: ignore[arg-type]
    assert saved["yaml"] == str(tmp_path / "maps" / "room.yaml")
    assert saved["counts"] == {"free": 9 * 25, "occupied": 25, "unknown": 40 * 30 - 10 * 25}
    loaded = load_ros_map(Path(saved["yaml"]))
    grid = Seeing.grid
    assert loaded.same_cells(built_map(grid.probability(), grid.seen, grid.origin, grid.resolution_m))


@pytest.mark.parametrize("name", ["", "../up", "a.yaml", "a b", "x" * 65, "-a"])
def test_a_bad_name_is_refused(name: str) -> None:
    with pytest.raises(ValueError, match="a map's name is"):
        checked_name(name)


def test_the_api_says_why_it_cannot_save(gateway: Gateway, tmp_path: Path) -> None:
    client = TestClient(create_app(gateway), base_url="http://127.0.0.1")
    answer = client.post("/api/map/save", json={"name": "room"})
    assert answer.status_code == 409 and "seen nothing yet" in answer.json()["detail"]
    answer = client.post("/api/map/save", json={"name": "../room"})
    assert answer.status_code == 422 and "name" in str(answer.json()["detail"])
    assert not (gateway.store.directory / "maps").exists()
