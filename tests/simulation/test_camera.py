"""The simulated camera against the real simulator binary, through the ESP32-CAM URLs it is served
at (cart2d/simulation/camera.py): what it shows against robot.toml's camera facts (projected here
with OpenCV, independently of the simulator's C++), its timestamps in simulated time, the stock
sketch's one stream client, determinism at any speed, and a checkerboard OpenCV can find."""

from __future__ import annotations

import http.client
import itertools
import math
import re
import threading
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from cart2d.maps.world import Box, World, arena_world
from cart2d.params import robot
from cart2d.simulation.camera import PART_BOUNDARY, SimCameraServer
from cart2d.simulation.controls import Board
from cart2d.simulation.simulator import Simulator
from tests.support.sim import start_sim

PORT = 18280  # tests only; the stream on PORT + 1


def camera_matrix() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """K, distortion, rvec, tvec of the mounted camera for a cart at the origin heading +x, from
    robot.toml ([camera] facts, [sim.camera] lens): the OpenCV model the simulator claims to be."""
    cam, lens = robot()["camera"], robot()["sim"]["camera"]
    w, h = int(cam["width_px"]), int(cam["height_px"])
    f = (w / 2) / math.tan(math.radians(float(cam["hfov_deg"])) / 2)
    k = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]])
    dist = np.array([float(lens["k1"]), float(lens["k2"]), 0, 0, 0])
    p = math.radians(float(cam["pitch_deg"]))
    z_c = np.array([math.cos(p), 0, -math.sin(p)])  # optical axis, base_link
    x_c = np.array([0.0, -1.0, 0.0])  # image right = base_link -y
    rot = np.vstack([x_c, np.cross(z_c, x_c), z_c])
    centre = np.array([float(cam["mount_x_m"]), float(cam["mount_y_m"]), float(cam["height_m"])])
    rvec, _ = cv2.Rodrigues(rot)
    return k, dist, rvec, -rot @ centre


def project(points: list[tuple[float, float, float]]) -> np.ndarray:
    k, dist, rvec, tvec = camera_matrix()
    uv, _ = cv2.projectPoints(np.array(points, dtype=np.float64), rvec, tvec, k, dist)
    return uv.reshape(-1, 2)


def decode(jpeg: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def at(image: np.ndarray, uv: np.ndarray, du: float = 0.0, dv: float = 0.0) -> np.ndarray:
    """BGR at a pixel, averaged over 3 x 3 (the noise and JPEG's ringing)."""
    u, v = round(float(uv[0] + du)), round(float(uv[1] + dv))
    assert 1 <= u < image.shape[1] - 1 and 1 <= v < image.shape[0] - 1, (u, v)
    patch: np.ndarray = image[v - 1 : v + 2, u - 1 : u + 2].reshape(-1, 3).mean(axis=0)
    return patch


def is_red(bgr: np.ndarray) -> bool:
    return bool(bgr[2] > 120 and bgr[1] < 70 and bgr[0] < 70)


def is_grey(bgr: np.ndarray) -> bool:
    return bool(np.ptp(bgr) < 15 and 140 < bgr.mean() < 200)


RED_BOX = Box(0.55, 0.0, 0.2, 0.3, height=0.1, colour="#c03020")


def world_with(*boxes: Box) -> World:
    return World(boxes=boxes, boundary=arena_world(10, 10, 0.2).boundary)


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[Simulator, SimCameraServer]]:
    sim = start_sim(tmp_path, world=world_with(RED_BOX), start=(0.0, 0.0, 0.0))
    server = SimCameraServer(lambda: sim.control_address, PORT).start()
    yield sim, server
    server.stop()
    sim.stop()


def get(port: int, path: str, timeout_s: float = 10.0) -> http.client.HTTPResponse:
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout_s)
    connection.request("GET", path)
    return connection.getresponse()


def stream_parts(response: http.client.HTTPResponse, count: int) -> list[tuple[dict[str, str], bytes]]:
    """The next `count` parts of an MJPEG stream: their headers and JPEG bytes. The part headers
    are split on the declared boundary; HTTP itself is http.client's."""
    parts: list[tuple[dict[str, str], bytes]] = []
    buf = b""
    marker = f"--{PART_BOUNDARY}\r\n".encode()
    while len(parts) < count:
        start = buf.find(marker)
        end = buf.find(b"\r\n\r\n", start) if start >= 0 else -1
        if end >= 0:
            lines = buf[start + len(marker) : end].decode().split("\r\n")
            headers = dict(line.split(": ", 1) for line in lines)
            size = int(headers["Content-Length"])
            if len(buf) >= end + 4 + size:
                parts.append((headers, buf[end + 4 : end + 4 + size]))
                buf = buf[end + 4 + size :]
                continue
        chunk = response.read1(65536)
        assert chunk, "the stream ended"
        buf += chunk
    return parts


def test_a_box_shows_at_the_pixels_robot_toml_predicts(served: tuple[Simulator, SimCameraServer]) -> None:
    answer = get(PORT, "/capture")
    assert answer.status == 200
    assert answer.getheader("Content-Type") == "image/jpeg"
    image = decode(answer.read())
    cam = robot()["camera"]
    assert image.shape == (int(cam["height_px"]), int(cam["width_px"]), 3)
    front = 0.55 - 0.1
    face, bottom, top, left, right, back = project(
        [
            (front, 0, 0.05),
            (front, 0, 0.0),
            (front, 0, 0.1),
            (front, 0.15, 0.05),
            (front, -0.15, 0.05),
            (0.65, 0, 0.1),
        ]
    )
    assert is_red(at(image, face))
    # 3 px inside and outside each edge of the front face; above it, the top face (lit brighter:
    # the lens is higher than the box), then the floor beyond its far edge.
    assert is_red(at(image, bottom, dv=-3)) and is_grey(at(image, bottom, dv=3))
    assert is_red(at(image, top, dv=3)) and is_red(at(image, top, dv=-3))
    assert at(image, top, dv=-3)[2] > at(image, top, dv=3)[2] + 20
    assert is_red(at(image, back, dv=3)) and is_grey(at(image, back, dv=-3))
    assert is_red(at(image, left, du=3)) and is_grey(at(image, left, du=-3))
    assert is_red(at(image, right, du=-3)) and is_grey(at(image, right, du=3))
    # The floor beside it, near and far.
    for point in project([(0.8, 0.3, 0.0), (0.4, -0.1, 0.0), (1.15, 0.3, 0.0)]):
        assert is_grey(at(image, point))


def test_status_and_control_as_the_stock_sketch(served: tuple[Simulator, SimCameraServer]) -> None:
    import json

    status = json.loads(get(PORT, "/status").read())
    assert status["framesize"] == 5 and status["quality"] == 10  # QVGA; libjpeg 80
    assert get(PORT, "/control?var=framesize&val=8").status == 200  # VGA
    assert json.loads(get(PORT, "/status").read())["framesize"] == 8
    assert decode(get(PORT, "/capture").read()).shape == (480, 640, 3)
    assert get(PORT, "/control?var=nonsense&val=1").status == 500
    assert get(PORT, "/control?var=framesize&val=99").status == 500


def test_stream_stamps_are_simulated_capture_times(served: tuple[Simulator, SimCameraServer]) -> None:
    sim, _ = served
    answer = get(PORT + 1, "/stream")
    assert answer.getheader("Content-Type") == f"multipart/x-mixed-replace;boundary={PART_BOUNDARY}"
    parts = stream_parts(answer, 12)
    answer.close()
    fps = float(robot()["sim"]["camera"]["fps"])
    stamps = [float(headers["X-Timestamp"]) for headers, _ in parts]
    assert all(re.fullmatch(r"\d+\.\d{6}", headers["X-Timestamp"]) for headers, _ in parts)
    assert all(b > a for a, b in itertools.pairwise(stamps))
    for t in stamps:  # t_k = k / fps, to the microsecond of the header
        assert abs(t * fps - round(t * fps)) * 1e6 / fps < 1.0
    # Delivered only once the latency has passed in simulated time.
    latency_s = float(robot()["sim"]["camera"]["latency_ms"]) / 1000
    assert sim.truth()["t"] >= stamps[-1] + latency_s
    for _, jpeg in parts:
        assert decode(jpeg).shape[:2] == (240, 320)


def test_one_stream_client_at_a_time(served: tuple[Simulator, SimCameraServer]) -> None:
    first = get(PORT + 1, "/stream")
    stream_parts(first, 2)
    got: list[tuple[dict[str, str], bytes]] = []

    def watch() -> None:
        second = get(PORT + 1, "/stream", timeout_s=20.0)
        got.extend(stream_parts(second, 2))
        second.close()

    waiting = threading.Thread(target=watch, daemon=True)
    waiting.start()
    stream_parts(first, 15)  # a second of frames for the first client...
    assert not got  # ...and none for the second meanwhile
    first.close()
    waiting.join(timeout=20.0)
    assert len(got) == 2  # its turn once the first has left


def frame_at_half_a_second(tmp_path: Path, speed: str) -> tuple[int, bytes]:
    sim = start_sim(
        tmp_path / speed, world=world_with(RED_BOX), start=(0.0, 0.0, 0.3), paused=True, speed=speed
    )
    try:
        sim.camera(True)
        sim.place_target(Board(x=0.45, y=-0.075))
        sim.run_for(0.5)
        frame = sim.wait_frame(timeout_s=5.0)
        return frame.seq, frame.jpeg
    finally:
        sim.stop()


def test_a_frame_is_the_same_at_any_speed(tmp_path: Path) -> None:
    (tmp_path / "1").mkdir()
    (tmp_path / "max").mkdir()
    slow = frame_at_half_a_second(tmp_path, "1")
    fast = frame_at_half_a_second(tmp_path, "max")
    # The last frame out by 0.5 s: k / 15 + 0.06 <= 0.5.
    assert slow[0] == fast[0] == 6
    assert slow[1] == fast[1]


def test_the_checkerboard_is_found_where_the_model_puts_its_corners(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, world=world_with(), start=(0.0, 0.0, 0.0), paused=True)
    try:
        board = Board(x=0.3, y=-0.075)  # 9 x 6 corners of 3 cm, lying on the floor ahead
        sim.place_target(board)
        sim.camera(True, noise_sigma=2.0)
        sim.run_for(0.2)
        image = decode(sim.wait_frame(timeout_s=5.0).jpeg)
    finally:
        sim.stop()
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    found, corners = cv2.findChessboardCorners(grey, (board.cols, board.rows))
    assert found
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.01)
    corners = cv2.cornerSubPix(grey, corners, (3, 3), (-1, -1), criteria).reshape(-1, 2)
    expected = project([board.corner(i, j) for j in range(board.rows) for i in range(board.cols)])
    # OpenCV may list the corners from either end: match each expected corner to the nearest.
    # Edges are anti-aliased, so corners land within a fraction of a pixel (one ray a pixel:
    # 0.32 px RMS, 0.57 px at worst on this foreshortened view).
    errors = np.linalg.norm(expected[:, None, :] - corners[None, :, :], axis=2).min(axis=1)
    assert float(np.sqrt(np.mean(errors**2))) < 0.3
    assert float(errors.max()) < 0.55


def test_cart2d_sim_serves_the_camera_and_keeps_its_url(tmp_path: Path) -> None:
    """`cart2d sim --camera-port P` serves the simulated ESP32-CAM beside the panel."""
    from tests.support.cli import running_cart2d
    from tests.support.sockets import free_port, free_port_pair
    from tests.support.waiting import wait_serving

    port = free_port()
    camera_port = free_port_pair(avoid=port)
    run = ["sim", "--port", str(port), "--camera-port", str(camera_port), "--speed", "max"]
    with running_cart2d(tmp_path, *run, keep_stderr=True) as gateway:
        wait_serving(port)
        answer = get(camera_port, "/capture")
        assert answer.status == 200
        assert decode(answer.read()).shape == (240, 320, 3)
        out, err = gateway.stop(), gateway.err
    assert f"simulated ESP32-CAM on 127.0.0.1:{camera_port}" in out, err


def test_a_missions_perception_key() -> None:
    from cart2d.simulation.world_file import parse
    from cart2d.tools.missions.spec import MissionSpec, perception_on

    spec, problems = parse(b'{"goals": [[0.4, 0]], "perception": false}', MissionSpec, "m.json")
    assert spec is not None and not problems
    assert spec.perception is False and not perception_on(spec.perception, has_world=True)
    spec, _ = parse(b'{"goals": [[0.4, 0]]}', MissionSpec, "m.json")
    assert spec is not None and spec.perception is None
    assert perception_on(spec.perception, has_world=True)  # on by default with a world...
    assert not perception_on(spec.perception, has_world=False)  # ...off without one
    spec, problems = parse(b'{"goals": [[0.4, 0]], "perception": "maybe"}', MissionSpec, "m.json")
    assert spec is None and problems and problems[0].startswith("perception:")


def test_the_camera_comes_back_after_a_simulator_restart(served: tuple[Simulator, SimCameraServer]) -> None:
    sim, _ = served
    before = get(PORT, "/capture")
    assert before.status == 200
    before.read()
    sim.restart()  # a new process, a new side-channel address
    after = get(PORT, "/capture")
    assert after.status == 200
    assert decode(after.read()).shape == (240, 320, 3)


def test_a_board_from_a_rotation_matrix_has_the_same_corners() -> None:
    """Board.from_rotation (world = R @ board + t, as cart2d/perception poses its boards) gives the
    roll, pitch, yaw the simulator takes: the same corners."""
    rng = np.random.default_rng(3)
    rotations = [np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])]  # face down on the floor
    rotations += [cv2.Rodrigues(rng.normal(size=3))[0] for _ in range(20)]
    rotations.append(cv2.Rodrigues(np.array([0.0, math.pi / 2, 0.0]))[0])  # pitch 90°: gimbal lock
    for rotation in rotations:
        t = rng.normal(size=3)
        board = Board.from_rotation(rotation.tolist(), t.tolist())
        for i, j in ((0, 0), (8, 0), (0, 5), (3, 4)):
            expected = rotation @ np.array([i * 0.03, j * 0.03, 0.0]) + t
            assert np.allclose(board.corner(i, j), expected, atol=1e-9)


def detected_corners(image: np.ndarray, cols: int, rows: int) -> np.ndarray:
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    found, corners = cv2.findChessboardCorners(grey, (cols, rows))
    assert found
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.01)
    refined: np.ndarray = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), criteria).reshape(-1, 2)
    return refined


def test_a_board_held_up_facing_the_lens(tmp_path: Path) -> None:
    """A 7 x 5 board of 2 cm squares square to the optical axis 0.35 m from the lens, posed by a
    rotation matrix: OpenCV finds its corners where that pose, projected, puts them."""
    cam = robot()["camera"]
    p = math.radians(float(cam["pitch_deg"]))
    axis = np.array([math.cos(p), 0.0, -math.sin(p)])
    # board x = image right (world -y), board y = image down, normal along the optical axis
    rotation = np.column_stack([[0.0, -1.0, 0.0], [-math.sin(p), 0.0, -math.cos(p)], axis])
    cols, rows, square = 7, 5, 0.02
    centre = (
        np.array([float(cam["mount_x_m"]), float(cam["mount_y_m"]), float(cam["height_m"])]) + 0.35 * axis
    )
    first = centre - rotation @ np.array([(cols - 1) * square / 2, (rows - 1) * square / 2, 0.0])
    board = Board.from_rotation(rotation.tolist(), first.tolist(), cols, rows, square)
    sim = start_sim(tmp_path, world=world_with(), start=(0.0, 0.0, 0.0), paused=True)
    try:
        sim.place_target(board)
        sim.camera(True)
        sim.run_for(0.2)
        image = decode(sim.wait_frame(timeout_s=5.0).jpeg)
    finally:
        sim.stop()
    corners = detected_corners(image, cols, rows)
    points = [
        rotation @ np.array([i * square, j * square, 0.0]) + first for j in range(rows) for i in range(cols)
    ]
    expected = project([tuple(point) for point in points])
    errors = np.linalg.norm(expected[:, None, :] - corners[None, :, :], axis=2).min(axis=1)
    assert float(errors.max()) < 0.3


def test_a_missions_world_boxes_block_the_cart_and_count() -> None:
    """A box of the mission's world, not on the map, driven blind (perception off): the planner
    drives straight at it, the cart stops against it (physical), the contact is in the report,
    the goal beyond is not reached."""
    from cart2d.tools.missions.run import run_mission
    from cart2d.tools.missions.spec import MissionSpec

    spec = MissionSpec.model_validate(
        {
            "start": [0.0, 0.0, 0.0],
            "goals": [[1.2, 0.0]],
            "world": {"boxes": [{"x": 0.6, "y": 0.0, "sx": 0.2, "sy": 0.4, "colour": "#c03020"}]},
            "timeout_s": 15.0,
            "perception": False,
        }
    )
    report = run_mission(spec)
    assert report["box_contacts"] >= 1
    assert report["goals"][0]["reached"] is False


def test_a_mission_starting_on_a_box_is_refused() -> None:
    from cart2d.simulation.world_file import WorldSpec, world_problems

    world = WorldSpec.model_validate(
        {"boxes": [{"x": 1.0, "y": 0.0, "sx": 0.2, "sy": 0.2}, {"x": 0.2, "y": 0, "sx": 0.1, "sy": 0.1}]}
    )
    (problem,) = world_problems((0.0, 0.0, 0.0), world)
    assert problem.startswith("world.boxes[1] at (0.2, 0)")
    assert world_problems((0.0, 0.0, 0.0), None) == []
