"""Synthetic camera images drawn with OpenCV: a floor, checkerboards and boxes seen through a
lens with known intrinsics and distortion. They are the ground truth the calibration and the
obstacle detector are tested and benchmarked against before (and besides) the simulator's camera.

The scene is drawn as the ideal pinhole camera sees it, where straight edges stay straight, so
every face is one cv2.fillConvexPoly: supersampled (anti-aliased when shrunk with INTER_AREA) on a
canvas with a margin. The lens distortion is then applied with cv2.remap: every raw pixel takes
the colour of the ideal pixel its ray passes through (cv2.undistortPointsIter).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import Board, GroundBoard
from cart2d.perception.camera_model import FloatArray, Intrinsics, Mount

Colour = tuple[int, int, int]  # BGR
NEAR_M = 0.01  # faces are clipped to this depth in front of the lens
SHIFT_BITS = 4  # fillConvexPoly's fractional bits: 1/16 of a canvas pixel
FLOOR_BGR: Colour = (170, 175, 180)
WALL_BGR: Colour = (205, 215, 225)


@dataclass(frozen=True)
class Box:
    """An axis-aligned box standing on the floor (centre and size in metres, like a mission's world)."""

    x: float
    y: float
    sx: float
    sy: float
    height: float
    bgr: Colour = (40, 60, 170)

    def faces(self) -> list[tuple[FloatArray, FloatArray, float]]:
        """(corners 4 x 3, outward normal, shade) of the top and the four sides."""
        x0, x1 = self.x - self.sx / 2, self.x + self.sx / 2
        y0, y1 = self.y - self.sy / 2, self.y + self.sy / 2
        h = self.height
        a = np.array
        return [
            (a([[x0, y0, h], [x1, y0, h], [x1, y1, h], [x0, y1, h]]), a([0.0, 0.0, 1.0]), 1.15),
            (a([[x0, y0, 0], [x0, y1, 0], [x0, y1, h], [x0, y0, h]]), a([-1.0, 0.0, 0.0]), 0.95),
            (a([[x1, y0, 0], [x1, y1, 0], [x1, y1, h], [x1, y0, h]]), a([1.0, 0.0, 0.0]), 0.8),
            (a([[x0, y0, 0], [x1, y0, 0], [x1, y0, h], [x0, y0, h]]), a([0.0, -1.0, 0.0]), 0.7),
            (a([[x0, y1, 0], [x1, y1, 0], [x1, y1, h], [x0, y1, h]]), a([0.0, 1.0, 0.0]), 0.85),
        ]


@dataclass(frozen=True)
class PlacedBoard:
    """A checkerboard with its pose: world point = rotation @ board point + translation."""

    board: Board
    rotation: FloatArray
    translation: FloatArray

    def corners_world(self) -> FloatArray:
        return np.asarray(self.board.object_points(), dtype=np.float64) @ self.rotation.T + self.translation


def floor_board(board: Board, centre_x_m: float, centre_y_m: float) -> PlacedBoard:
    """`board` lying on the floor as the calibration's GroundBoard says (the cart at the origin)."""
    rotation, translation = GroundBoard(board, centre_x_m, centre_y_m).pose_in_base()
    return PlacedBoard(board, rotation, translation)


def _clip_to_front(points_cam: FloatArray) -> FloatArray:
    """A convex polygon (N x 3, camera frame) clipped to z >= NEAR_M (Sutherland-Hodgman, one plane)."""
    out: list[FloatArray] = []
    n = len(points_cam)
    for k in range(n):
        p, q = points_cam[k], points_cam[(k + 1) % n]
        if p[2] >= NEAR_M:
            out.append(p)
        if (p[2] >= NEAR_M) != (q[2] >= NEAR_M):
            s = (NEAR_M - p[2]) / (q[2] - p[2])
            out.append(p + s * (q - p))
    return np.array(out).reshape(-1, 3)


class SyntheticCamera:
    """Renders BGR images of `true_lens` (intrinsics and distortion) mounted as `mount`."""

    def __init__(
        self,
        true_lens: Intrinsics,
        mount: Mount,
        noise_sigma: float = 2.0,
        seed: int = 0,
        floor_texture: float = 0.04,
        supersample: int = 4,
        margin_px: int = 48,
    ) -> None:
        self.lens, self.mount = true_lens, mount
        self.noise_sigma, self.floor_texture = noise_sigma, floor_texture
        self.rng = np.random.default_rng(seed)
        self.s, self.margin = supersample, margin_px
        self.canvas_size = (
            (true_lens.width + 2 * margin_px) * supersample,
            (true_lens.height + 2 * margin_px) * supersample,
        )
        grid = np.stack(np.meshgrid(np.arange(true_lens.width), np.arange(true_lens.height)), axis=-1)
        ideal = true_lens.undistort(grid.reshape(-1, 2).astype(np.float64)) + margin_px
        self.map_x = ideal[:, 0].reshape(true_lens.height, true_lens.width).astype(np.float32)
        self.map_y = ideal[:, 1].reshape(true_lens.height, true_lens.width).astype(np.float32)

    def _canvas_pixels(self, points_cam: FloatArray) -> npt.NDArray[np.int32]:
        """Camera-frame points (in front) -> fixed-point canvas pixels for fillConvexPoly."""
        lens, s = self.lens, self.s
        u = lens.fx * points_cam[:, 0] / points_cam[:, 2] + lens.cx + self.margin
        v = lens.fy * points_cam[:, 1] / points_cam[:, 2] + lens.cy + self.margin
        # ideal pixel p covers canvas pixels s p .. s p + s - 1, whose centres average s p + (s - 1) / 2
        canvas = np.column_stack([u, v]) * s + (s - 1) / 2
        return np.round(canvas * (1 << SHIFT_BITS)).astype(np.int32)

    def _fill(
        self,
        canvas: npt.NDArray[np.uint8],
        world: FloatArray,
        pose: tuple[FloatArray, FloatArray],
        bgr: Colour,
    ) -> None:
        r, t = pose
        front = _clip_to_front(world @ r.T + t)
        if len(front) >= 3:
            cv2.fillConvexPoly(canvas, self._canvas_pixels(front), bgr, cv2.LINE_8, SHIFT_BITS)

    def render(
        self,
        cart_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        boards: Sequence[PlacedBoard] = (),
        boxes: Sequence[Box] = (),
        floor_bgr: Colour = FLOOR_BGR,
    ) -> npt.NDArray[np.uint8]:
        """What the camera sees with the cart at `cart_pose` (x, y, theta in the world; boards and
        boxes are in world coordinates; a board's pose may be anywhere, e.g. held in the air)."""
        pose = self._world_to_camera(cart_pose)
        w, h = self.canvas_size
        canvas = np.empty((h, w, 3), np.uint8)
        canvas[:] = WALL_BGR
        cx, cy = cart_pose[0], cart_pose[1]
        far = 50.0
        floor = np.array(
            [
                [cx - far, cy - far, 0],
                [cx + far, cy - far, 0],
                [cx + far, cy + far, 0],
                [cx - far, cy + far, 0],
            ]
        )
        self._fill(canvas, floor, pose, floor_bgr)
        if self.floor_texture > 0.0:
            self._texture(canvas)
        centre = -pose[0].T @ pose[1]
        on_floor = [b for b in boards if np.allclose(b.corners_world()[:, 2], 0.0)]
        for placed in on_floor:
            self._draw_board(canvas, placed, pose)
        faces = []
        for box in boxes:
            for corners, normal, shade in box.faces():
                if float(normal @ (centre - corners[0])) > 0.0:  # faces the camera
                    colour = tuple(int(min(255, c * shade)) for c in box.bgr)
                    faces.append((float(np.linalg.norm(corners.mean(axis=0) - centre)), corners, colour))
        for _, corners, colour in sorted(faces, key=lambda f: -f[0]):  # the far ones first
            self._fill(canvas, corners, pose, colour)  # type: ignore[arg-type]
        for placed in boards:
            if not any(placed is b for b in on_floor):
                self._draw_board(canvas, placed, pose)
        ideal = cv2.resize(canvas, (w // self.s, h // self.s), interpolation=cv2.INTER_AREA)
        raw = np.asarray(
            cv2.remap(ideal, self.map_x, self.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE),
            dtype=np.uint8,
        )
        if self.noise_sigma > 0.0:
            noise = self.rng.normal(0.0, self.noise_sigma, raw.shape)
            raw = np.clip(raw + noise, 0, 255).astype(np.uint8)
        return raw

    def _texture(self, canvas: npt.NDArray[np.uint8]) -> None:
        """Mild blotches of brightness (a floor is never one flat grey): smooth noise, drawn small
        and enlarged with cv2.resize."""
        h, w = canvas.shape[:2]
        blotches = self.rng.normal(0.0, 1.0, (max(2, h // 64), max(2, w // 64))).astype(np.float32)
        gain = 1.0 + self.floor_texture * cv2.resize(blotches, (w, h), interpolation=cv2.INTER_CUBIC)
        canvas[:] = np.clip(canvas * gain[..., None], 0, 255).astype(np.uint8)

    def _world_to_camera(self, cart_pose: tuple[float, float, float]) -> tuple[FloatArray, FloatArray]:
        x, y, theta = cart_pose
        c, s = math.cos(theta), math.sin(theta)
        base_to_world = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        r_cb, t_cb = self.mount.extrinsics()
        # p_cam = R_cb (R_wb^T (p_world - T)) + t_cb
        r = r_cb @ base_to_world.T
        return r, t_cb - r @ np.array([x, y, 0.0])

    def _draw_board(
        self, canvas: npt.NDArray[np.uint8], placed: PlacedBoard, pose: tuple[FloatArray, FloatArray]
    ) -> None:
        b, sq = placed.board, placed.board.square_m

        def world(x0: float, y0: float, x1: float, y1: float) -> FloatArray:
            local = np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]])
            return np.asarray(local @ placed.rotation.T + placed.translation, dtype=np.float64)

        # a white margin of one square round the (cols + 1) x (rows + 1) squares
        self._fill(
            canvas, world(-2 * sq, -2 * sq, (b.cols + 1) * sq, (b.rows + 1) * sq), pose, (250, 250, 250)
        )
        for i in range(-1, b.cols):
            for j in range(-1, b.rows):
                if (i + j) % 2 == 0:
                    self._fill(canvas, world(i * sq, j * sq, (i + 1) * sq, (j + 1) * sq), pose, (20, 20, 20))


def true_pixels(lens: Intrinsics, mount: Mount, floor_xy: npt.ArrayLike) -> FloatArray:
    """Where floor points (N x 2, base_link) appear in the raw image of `lens` mounted as `mount`."""
    pts = np.asarray(floor_xy, dtype=np.float64).reshape(-1, 2)
    r, t = mount.extrinsics()
    rvec, _ = cv2.Rodrigues(r)
    uv, _ = cv2.projectPoints(
        np.column_stack([pts, np.zeros(len(pts))]), rvec, t, lens.matrix(), lens.dist_array()
    )
    return np.asarray(uv, dtype=np.float64).reshape(-1, 2)
