"""The gateway sees (cart2d/gateway/seeing.py): the pose at a frame's capture from telemetry as it
arrived, hand-computed; a cleared perceived layer forgets what was seen and sees again at once;
and missions in the simulator whose boxes the map does not show, driven with the simulated camera
and perception (cart2d/tools/missions/camera.py) against the same missions driven blind."""

from __future__ import annotations

import json
import math
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from cart2d.gateway.poses import CapturePoses, PoseHistory
from cart2d.gateway.seeing import Seeing
from cart2d.maps.world import Box
from cart2d.planning import segment_square_distance
from cart2d.recording.channels import TOPIC_CAMERA
from cart2d.recording.session import DEFAULT_CAMERA_FPS
from cart2d.server import create_app
from cart2d.tools.missions.camera import mission_camera
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec
from tests.support.gateway import WIDE, GatewayRig, QuietGateway
from tests.support.missions import BOX, mission
from tests.support.recording import Read
from tests.support.server import BASE_URL, JSON
from tests.support.waiting import wait_for


def test_the_pose_at_a_time_between_two_frames_is_interpolated_the_short_way_round() -> None:
    poses = PoseHistory(keep_s=10.0)
    poses.add(1.0, (0.0, 0.0, math.pi - 0.1))
    poses.add(1.1, (0.1, 0.2, -math.pi + 0.1))  # turned 0.2 rad through ±pi, not 2 pi - 0.2 back
    x, y, theta = poses.at(1.05) or (math.nan, math.nan, math.nan)
    assert (x, y) == pytest.approx((0.05, 0.1))
    assert math.remainder(theta - math.pi, math.tau) == pytest.approx(0.0, abs=1e-9)


def test_before_the_first_telemetry_there_is_no_pose_and_after_the_last_it_is_the_last() -> None:
    listener = CapturePoses(0.06)  # the gateway's listener of these histories
    listener({"type": "truth", "x": 5.0, "y": 5.0, "theta": 0.0})  # not odometry: ignored
    assert listener.newest() is None
    poses = PoseHistory(keep_s=10.0)
    assert poses.at(0.0) is None
    poses.add(2.0, (1.0, 2.0, 0.5))
    assert poses.at(1.9) is None
    assert poses.at(9.0) == (1.0, 2.0, 0.5)


def test_old_poses_are_forgotten() -> None:
    poses = PoseHistory(keep_s=1.0)
    for k in range(30):
        poses.add(k * 0.1, (k * 0.1, 0.0, 0.0))
    assert poses.at(1.0) is None  # 1.9 s back from the newest at 2.9 s
    assert poses.at(2.5) == pytest.approx((2.5, 0.0, 0.0))


def test_a_box_the_map_does_not_show_is_seen_mapped_and_driven_around(tmp_path: Path) -> None:
    report = run_mission(mission(), base_dir=tmp_path, mcap_path=tmp_path / "run.mcap")
    goal = report["goals"][0]
    assert goal["reached"], goal.get("reason")
    assert report["box_contacts"] == 0 and report["collisions"] == 0
    assert any("camera" in r["reason"] for r in report["replans"])  # seen on the way, not before
    # each camera replan with the frame that caused it: captured before the new path was in the
    # firmware, by the camera's latency, the processing, planning and upload (simulated time)
    causes = [r for r in report["perception"]["replan_frames"] if r["outcome"] == "replanned"]
    assert causes and all("camera" in r["reason"] for r in causes)
    assert all(0.0 < r["sim_t"] - r["frame_stamp_s"] < 0.5 for r in causes), causes
    cells = np.array([c[:2] for c in report["perception"]["cells"]])
    # what it believes occupied is on the box (its face, and as deep as the camera assumes)
    reach = 0.2 + 0.05  # the assumed depth at most, and a cell
    near_box = (np.abs(cells[:, 0] - BOX["x"]) <= BOX["sx"] / 2 + reach) & (
        np.abs(cells[:, 1] - BOX["y"]) <= BOX["sy"] / 2 + reach
    )
    assert near_box.mean() >= 0.8, cells
    # the camera's frames, with what perception drew on them, are in the recording, at the
    # recording's bounded camera rate over the drive (simulated time)
    frames = Read(tmp_path / "run.mcap").on(TOPIC_CAMERA)
    span_s = (frames[-1].log_time - frames[0].log_time) / 1e9
    assert span_s >= goal["time_s"] and len(frames) >= DEFAULT_CAMERA_FPS * span_s / 2
    assert all(f.data for f in frames)


def test_blind_the_same_mission_drives_into_the_box(tmp_path: Path) -> None:
    report = run_mission(mission(perception=False), base_dir=tmp_path)
    assert not report["goals"][0]["reached"]
    assert report["box_contacts"] >= 1
    assert "perception" not in report


def test_the_readmes_example_world_is_crossed_without_touching_a_box(tmp_path: Path) -> None:
    world = json.loads(Path(__file__).parents[2].joinpath("docs", "examples", "boxes.json").read_text())
    spec = MissionSpec.model_validate(
        {"start": [0.0, 0.0, 0.0], "goals": [[1.6, 0.3]], "world": world, "timeout_s": 60.0}
    )
    report = run_mission(spec, base_dir=tmp_path)
    assert report["goals"][0]["reached"], report["goals"][0].get("reason")
    assert report["box_contacts"] == 0 and report["collisions"] == 0


def test_a_cart_standing_still_a_second_has_one_frame_in_three_taken_in() -> None:
    seeing = Seeing(QuietGateway(), latency_s=0.0)  # type: ignore[arg-type]
    here = (0.5, 0.5, 0.0)
    taken = [not seeing._idle(here, k / 15) for k in range(60)]  # 4 s at 15 fps
    assert all(taken[:15])  # the first second at rest: every frame
    assert sum(taken[15:]) == 15  # then one in three
    assert not seeing._idle((0.6, 0.5, 0.0), 4.0)  # moved: every frame again
    assert not seeing._idle((0.6, 0.5, 0.0), 4.1)


def test_after_clear_perceived_a_box_seen_is_on_the_map_and_blocks_the_route(tmp_path: Path) -> None:
    # Once, a clear that left no cell believed after one frame (a cell needs two hits) was taken
    # for a new clear at every frame: the cart stayed blind until the gateway restarted.
    rig = GatewayRig(tmp_path, WIDE, speed="1")  # the camera in real time, as `cart2d sim` runs it
    client = TestClient(
        create_app(rig.gateway, simulation=rig.simulation.add_routes), base_url=BASE_URL, headers=JSON
    )
    try:
        rig.sim.control("place", x=0.4, y=0.8, theta=0.0)
        rig.link.call("SET_POSE", 0.4, 0.8, 0.0)
        rig.sim.add_boxes([Box(1.2, 0.8, 0.2, 0.2, id="first")])

        def cells() -> list[list[float]]:
            answer: list[list[float]] = client.get("/api/perception").json()["cells"]
            return answer

        with mission_camera(rig.gateway, rig.sim, None):
            seeing = rig.gateway.seeing
            assert seeing is not None
            wait_for(lambda: len(cells()) > 0, 60.0)  # the first box, seen
            assert client.post("/api/perception/clear").json()["cells"] == []
            rig.sim.remove_boxes(["first"])
            box = (0.9, 0.8)  # another, nearer, dropped after the clear
            rig.sim.add_boxes([Box(*box, 0.2, 0.2, id="second")])
            seen = seeing.frames
            wait_for(lambda: seeing.frames >= seen + 15, 60.0)  # a second of frames at 15 fps
            after = np.array([c[:2] for c in cells()])
            assert len(after) > 0, "nothing is perceived after the clear"
            near = np.abs(after - box).max(axis=1) <= 0.1 + 0.2 + 0.05  # the box, its assumed depth, a cell
            assert near.mean() >= 0.8, after
            plan = rig.gateway.planner.plan((0.4, 0.8), (1.6, 0.8))
            legs = zip([plan.start, *plan.waypoints], plan.waypoints, strict=False)
            assert min(segment_square_distance(a, b, box, 0.1) for a, b in legs) > 0.0  # round it
            assert plan.length_m > 1.2 + 0.05
    finally:
        rig.close()


def test_a_change_of_framesize_at_rest_leaves_perception_seeing_once_it_is_back(tmp_path: Path) -> None:
    # The simulated camera's own /control?var=framesize&val=8 then =5 while the cart stands: once,
    # the drawing of the last QVGA frame on a VGA one raised IndexError and the feed's thread ended
    # for good, while /api/camera said connected at 15 fps; the cart then drove into a box.
    rig = GatewayRig(tmp_path, WIDE, speed="1")
    client = TestClient(
        create_app(rig.gateway, simulation=rig.simulation.add_routes), base_url=BASE_URL, headers=JSON
    )
    try:
        rig.sim.control("place", x=0.4, y=0.8, theta=0.0)
        rig.link.call("SET_POSE", 0.4, 0.8, 0.0)
        rig.sim.add_boxes([Box(1.1, 0.8, 0.2, 0.2)])
        with mission_camera(rig.gateway, rig.sim, None):
            seeing, feed = rig.gateway.seeing, rig.gateway.camera
            assert seeing is not None and feed is not None and feed.base_url is not None
            wait_for(lambda: seeing.idle_skipped > 0, 60.0)  # at rest: the last drawing is reused

            def framesize(index: int) -> None:
                with urllib.request.urlopen(f"{feed.base_url}/control?var=framesize&val={index}", timeout=10):
                    pass

            framesize(8)  # VGA: perception's calibration is for QVGA
            wait_for(lambda: feed.status()["width"] == 640 and feed.status()["state"] == "blind", 60.0)
            state = client.get("/api/camera").json()
            assert state["worker"] == "running" and state["processor_errors"] > 0
            assert "a 640 x 480 image; the calibration is for (320, 240)" in state["problem"]
            framesize(5)
            wait_for(lambda: feed.status()["width"] == 320, 60.0)
            seen = seeing.frames
            wait_for(lambda: seeing.frames >= seen + 5, 60.0)
            state = client.get("/api/camera").json()
            assert state["worker"] == "running" and state["worker_errors"] == 0
            assert client.get("/api/perception").json()["cells"]  # the box, still on the map
    finally:
        rig.close()
