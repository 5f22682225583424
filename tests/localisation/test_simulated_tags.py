"""Markers rendered by the simulator (OpenCV's bitmaps textured on a wall and on the floor) are
found, and the pose they give is the simulator's truth."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cart2d.localisation.markers import Marker, MarkerMap
from cart2d.localisation.tags import TagDetector, TagLocaliser
from cart2d.perception.camera_model import Mount
from cart2d.simulation.markers import place_markers
from cart2d.simulation.simulator import Simulator
from cart2d.tools.camera_calibration.simulated import SimCamera, sim_options, simulated_lens
from tests.support.sim import require_builds

MOUNT = Mount.from_robot()
MARKERS = MarkerMap(
    (
        Marker(5, 0.1, 0.5, 0.12, 0.06, 180.0),  # upright, 0.5 m ahead, facing the cart
        Marker(9, 0.12, 0.7, -0.15, 0.0, 160.0, "floor"),
    )
)


def test_the_simulator_renders_markers_the_detector_finds_at_their_pose(tmp_path: Path) -> None:
    require_builds()
    localiser = TagLocaliser(MARKERS, simulated_lens(MOUNT), MOUNT)
    with Simulator(sim_options(tmp_path / "eeprom.bin")) as sim:
        camera = SimCamera.on(sim)
        assert TagDetector().detect(camera.picture()) == []
        place_markers(sim, MARKERS)
        picture = camera.picture()
        truth = camera.cart()
    fixes = localiser.fixes(TagDetector().detect(picture))
    assert sorted(f.tag_id for f in fixes) == [5, 9]
    for fix in fixes:
        error = np.array(fix.pose) - np.array(truth)
        assert math.hypot(error[0], error[1]) < 0.01, fix
        assert abs(math.remainder(error[2], math.tau)) < math.radians(1.5), fix
