"""`cart2d camera calibrate --sim`: the calibration against the simulated camera, which places the
checkerboard itself (Simulator.place_target) where a person would hold it and takes the frame
captured after it was placed (the camera's latency: a frame in flight still shows the board where
it was). The views and the maths are the real camera's (views.calibrate).

Conventions shared with the simulator (sim/README.md, "The camera"), checked by
tests/perception/test_simulated_camera.py: a placement (R, t) puts inner corner (i, j) of a cols x rows
INNER-corner board at R @ (i * square_m, j * square_m, 0) + t in the world, which is what
Board.from_rotation takes; the cart's base_link is the world moved by the cart's true pose.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from cart2d.maps.world import World
from cart2d.params import robot
from cart2d.perception.calibration import Board, CameraCalibration, GroundBoard
from cart2d.perception.camera_model import FloatArray, Intrinsics, Mount
from cart2d.perception.synthetic import true_pixels
from cart2d.simulation.controls import Board as SimBoard
from cart2d.simulation.controls import CameraControls
from cart2d.simulation.side_channel import SideChannel, SimulatorError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.tools.camera_calibration.lens import Image
from cart2d.tools.camera_calibration.views import Placement, Pose, board_placements, calibrate

# A board held in the air must stay above the floor, which a camera 0.25 m up looking 25 degrees
# down sees from about 0.35 m on: the held board is smaller than the floor board (9 x 6 corners
# of 15 mm fit at 0.27-0.35 m in every part of the picture; 30 mm ones only near its top edge,
# too alike for Zhang's method).
HELD_SQUARE_M = 0.015
# The simulator of its own: a room with nothing in it, its walls 2 m away, beyond what the
# detector looks at (a running `cart2d sim` keeps its own world: its arena does too).
ROOM = (-2.0, -2.0, 4.0, 2.0)
FRAME_TIMEOUT_S = 10.0
MAX_DRIFT_M, MAX_DRIFT_DEG = 0.002, 0.2  # the cart standing still: a running simulator's cart may not


def simulated_lens(mount: Mount | None = None) -> Intrinsics:
    """The lens the simulator renders with (sim/README.md, "The camera"): the nominal pinhole of
    [camera] (fx = fy from hfov, the principal point in the middle) and [sim.camera]'s k1, k2."""
    nominal = Intrinsics.nominal(mount)
    lens = robot()["sim"]["camera"]
    dist = (float(lens["k1"]), float(lens["k2"]), 0.0, 0.0, 0.0)
    return Intrinsics(nominal.width, nominal.height, nominal.fx, nominal.fy, nominal.cx, nominal.cy, dist)


def decode(jpeg: bytes) -> Image:
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError("the simulated camera sent a frame that is not a JPEG")
    return np.asarray(image, dtype=np.uint8)


class RunningSim(CameraControls):
    """A simulator that runs already (`cart2d sim`), reached at the side channel it prints: its
    time goes on by itself, the cart stands where the user left it, the world is the user's."""

    def __init__(self, address: str) -> None:
        self.side: SideChannel | None = SideChannel(address)

    def control(self, kind: str, **members: Any) -> dict[str, Any]:
        if self.side is None:
            raise SimulatorError("the side channel is closed")
        return self.side.request({"type": kind, **members})

    def close(self) -> None:
        if self.side is not None:
            with contextlib.suppress(SimulatorError, OSError):
                self.control("target", board=None)
                self.control("camera", on=False)
            self.side.close()
            self.side = None


@dataclass
class SimCamera:
    """A simulator's camera, on, taking pictures on demand. `advance` runs a paused simulator
    for so many simulated seconds (Simulator.run_for); None: the simulator runs by itself."""

    sim: CameraControls
    fps: float
    latency_s: float
    advance: Callable[[float], object] | None = None
    last_seq: int = -1

    @classmethod
    def on(cls, sim: Simulator | RunningSim) -> SimCamera:
        settings = sim.camera(True)
        advance = sim.run_for if isinstance(sim, Simulator) else None
        return cls(sim, float(settings["fps"]), float(settings["latency_ms"]) / 1000.0, advance)

    def now(self) -> dict[str, Any]:
        truth: dict[str, Any] = self.sim.control("truth")["truth"]
        return truth

    def cart(self) -> Pose:
        truth = self.now()
        return float(truth["x"]), float(truth["y"]), float(truth["theta"])

    def picture(self) -> Image:
        """A frame captured after this call: everything changed before it is in the picture."""
        since = float(self.now()["t"])
        # one frame period to the next capture, the latency for it to arrive, and a frame to spare
        if self.advance is not None:
            self.advance(2.0 / self.fps + self.latency_s)
        while True:
            frame = self.sim.wait_frame(self.last_seq, FRAME_TIMEOUT_S)
            self.last_seq = frame.seq
            if frame.t >= since:
                return decode(frame.jpeg)
            if self.advance is not None:
                self.advance(1.0 / self.fps)  # captured before: the next one is still to come

    def with_board(self, board: Board, placement: Placement) -> Image:
        r, t = placement
        self.sim.place_target(
            SimBoard.from_rotation(r.tolist(), t.tolist(), board.cols, board.rows, board.square_m)
        )
        return self.picture()


def sim_views(
    camera: SimCamera, board: Board, ground: GroundBoard, n: int, mount: Mount
) -> tuple[Iterator[Image], Callable[[], Image]]:
    """The simulated camera's views of the held board (board_placements, above the floor) and of
    the board on the floor, for the cart where it stands (ValueError if it moves meanwhile: the
    boards were placed for where it stood)."""
    start = camera.cart()
    held, on_floor = board_placements(board, ground, n, mount, start, above_floor=True)

    def still(placement: Placement) -> Placement:
        x, y, theta = camera.cart()
        turned = abs(math.remainder(theta - start[2], math.tau))
        if math.hypot(x - start[0], y - start[1]) > MAX_DRIFT_M or turned > math.radians(MAX_DRIFT_DEG):
            raise ValueError("the cart moved during the calibration: stop it and calibrate again")
        return placement

    def views() -> Iterator[Image]:
        for placement in held:
            yield camera.with_board(board, still(placement))

    def floor_view() -> Image:
        return camera.with_board(ground.board, still(on_floor))

    return views(), floor_view


def sim_options(eeprom: Path | None = None, seed: int = 1) -> SimOptions:
    """A paused simulator in a room with nothing but far walls, the cart at the origin."""
    return SimOptions(
        speed="max",
        seed=seed,
        paused=True,
        quiet=True,
        eeprom=eeprom,
        world=World(boundary=ROOM),
        start=(0.0, 0.0, 0.0),
    )


def calibrate_in_simulator(
    board: Board,
    ground: GroundBoard,
    n: int,
    mount: Mount,
    options: SimOptions | None = None,
    say: Callable[[str], None] = print,
) -> CameraCalibration:
    """Starts a simulator, turns its camera on, places the board at each view and on the floor,
    calibrates; the simulator is stopped whatever happens."""
    with Simulator(options or sim_options()) as sim:
        camera = SimCamera.on(sim)
        views, floor_view = sim_views(camera, board, ground, n, mount)
        return calibrate(views, floor_view, board, ground, mount, say)


def calibrate_running_simulator(
    address: str, board: Board, ground: GroundBoard, n: int, mount: Mount, say: Callable[[str], None] = print
) -> CameraCalibration:
    """The same against a simulator that runs already (`cart2d sim`'s side channel, HOST:PORT):
    the board is placed in front of its cart where it stands, then taken away."""
    sim = RunningSim(address)
    try:
        camera = SimCamera.on(sim)
        views, floor_view = sim_views(camera, board, ground, n, mount)
        return calibrate(views, floor_view, board, ground, mount, say)
    finally:
        sim.close()


def describe_truth(mount: Mount) -> str:
    truth = simulated_lens(mount)
    return (
        f"the simulated lens is fx {truth.fx:.1f} fy {truth.fy:.1f} cx {truth.cx:.1f} cy {truth.cy:.1f} px, "
        f"k1 {truth.dist[0]:.3f} k2 {truth.dist[1]:.3f} (config/robot.toml [camera], [sim.camera])"
    )


def ground_errors(calibration: CameraCalibration, mount: Mount, range_m: float) -> FloatArray:
    """How far (m) the calibrated model puts floor points `range_m` ahead of the lens's foot from
    where they are, across the width of the picture: each point's raw pixel from the simulator's
    true lens and mount (sim/README.md, "The camera"; tests/simulation/test_camera.py checks the rendered
    pictures against the same model to a fraction of a pixel), projected back to the floor."""
    x = mount.x_m + range_m
    across = np.linspace(-1.0, 1.0, 81) * x  # wider than the picture: those outside are dropped
    floor = np.column_stack([np.full_like(across, x), mount.y_m + across])
    raw = true_pixels(simulated_lens(mount), mount, floor)
    inside = (raw[:, 0] >= 0) & (raw[:, 0] <= mount.width_px - 1) & (raw[:, 1] >= 0)
    inside &= raw[:, 1] <= mount.height_px - 1
    if not inside.any():
        return np.zeros(0)
    seen, valid = calibration.pixels_to_ground(raw[inside])
    errors = np.linalg.norm(seen - floor[inside], axis=1)
    return np.where(valid, errors, np.inf)
