"""The simulator's camera and checkerboard target over the side channel (sim/README.md, "The
camera"): `Simulator.camera(on)`, `Simulator.place_target(board)`, `Simulator.wait_frame()`; and
the hold that keeps the simulator in step with a consumer of its frames, `Simulator.hold(t)`.

Frames are JSON lines {"type":"frame","seq":k,"t":t_k,"jpeg":base64}: frame k is captured at
simulated time t_k = k / fps from the cart's true pose and arrives once the camera's latency has
passed in simulated time, to every side-channel client that turned the camera on."""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cart2d.simulation.side_channel import SideChannel


class CameraTimeout(RuntimeError):
    pass


@dataclass(frozen=True)
class Board:
    """A printed checkerboard of cols x rows INNER corners, squares of square_m, with a white
    margin one square wide. Its pose is that of its first inner corner in the world (m) and the
    rotation Rz(yaw)·Ry(pitch)·Rx(roll) (rad) from the board's axes (x along the columns, y along
    the rows, z its face's normal) to the world's: all zero, it lies face up on the floor plane
    z. Standing up facing a cart that looks along +x: roll = -pi/2, yaw = pi/2 (columns to the
    left, rows downwards from the first corner)."""

    x: float
    y: float
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    cols: int = 9
    rows: int = 6
    square_m: float = 0.03

    @classmethod
    def from_rotation(
        cls,
        rotation: Sequence[Sequence[float]],
        translation: Sequence[float],
        cols: int = 9,
        rows: int = 6,
        square_m: float = 0.03,
    ) -> Board:
        """The board whose inner corner (i, j) is at rotation @ (i·square, j·square, 0) + translation
        in the world (a proper rotation matrix, 3 x 3): its roll, pitch, yaw (ZYX angles)."""
        r = rotation
        yaw = math.atan2(r[1][0], r[0][0])
        pitch = math.atan2(-r[2][0], math.hypot(r[0][0], r[1][0]))
        roll = math.atan2(r[2][1], r[2][2])
        if math.hypot(r[0][0], r[1][0]) < 1e-9:  # gimbal lock: pitch ±90°, yaw taken as 0
            yaw, roll = 0.0, math.atan2(-r[1][2], r[1][1])
        x, y, z = (float(v) for v in translation)
        return cls(x, y, z, roll, pitch, yaw, cols, rows, square_m)

    def message(self) -> dict[str, Any]:
        return {
            "cols": self.cols,
            "rows": self.rows,
            "square_m": self.square_m,
            "x": self.x,
            "y": self.y,
            "z": self.z,
            "roll": self.roll,
            "pitch": self.pitch,
            "yaw": self.yaw,
        }

    def corner(self, i: float, j: float) -> tuple[float, float, float]:
        """Inner corner (i, j) in the world (i along the columns)."""
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        ex = (cy * cp, sy * cp, -sp)
        ey = (cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr)
        a, b = i * self.square_m, j * self.square_m
        return (
            self.x + a * ex[0] + b * ey[0],
            self.y + a * ex[1] + b * ey[1],
            self.z + a * ex[2] + b * ey[2],
        )


@dataclass(frozen=True)
class SimFrame:
    seq: int  # k
    t: float  # simulated capture time, k / fps
    jpeg: bytes


def frame_of(message: dict[str, Any]) -> SimFrame:
    return SimFrame(int(message["seq"]), float(message["t"]), base64.b64decode(message["jpeg"]))


def wait_frame(side: SideChannel, after_seq: int, timeout_s: float) -> SimFrame:
    """The newest frame on this side channel whose seq is above after_seq, waiting for it."""
    with side._cond:
        arrived = side._cond.wait_for(
            lambda: side.closed or (side.frame is not None and int(side.frame["seq"]) > after_seq), timeout_s
        )
        if not arrived or side.frame is None or int(side.frame["seq"]) <= after_seq:
            raise CameraTimeout(f"no camera frame after {after_seq} within {timeout_s:g} s")
        return frame_of(side.frame)


class CameraControls:
    """The camera's part of Simulator (mixed in: simulator.py stays small)."""

    side: SideChannel | None
    # The simulated ESP32-CAM's base URL once `cart2d sim` serves it (camera.py), for the gateway.
    camera_url: str | None = None

    def control(self, kind: str, **members: Any) -> dict[str, Any]:
        raise NotImplementedError

    def camera(self, on: bool, **settings: float) -> dict[str, Any]:
        """Frames on or off for this side channel; settings override robot.toml's [sim.camera]
        (fps, latency_ms, noise_sigma, exposure, k1, k2, width, height, jpeg_quality) for every
        client. Returns the settings in force."""
        ack = self.control("camera", on=on, **settings)
        out: dict[str, Any] = ack["camera"]
        return out

    def hold(self, until_s: float | None) -> dict[str, Any]:
        """Simulated time runs up to until_s (s) and waits there until a later hold moves it;
        None ends holding (sim/README.md, "Lockstep": cart2d/simulation/lockstep.py holds it to
        what perception has taken in). Returns the ack: "t", the simulated time now, and "hold"."""
        return self.control("hold", until=until_s)

    def place_target(self, board: Board | dict[str, Any] | None) -> None:
        """Places the checkerboard (None removes it)."""
        message = board.message() if isinstance(board, Board) else board
        self.control("target", board=message)

    def wait_frame(self, after_seq: int = -1, timeout_s: float = 10.0) -> SimFrame:
        """The next frame newer than after_seq (camera(True) first; the simulator must run)."""
        if self.side is None:
            raise CameraTimeout("the simulator is not running")
        return wait_frame(self.side, after_seq, timeout_s)
