"""The views of `cart2d camera calibrate` and the calibration from them: the camera's lens and
its ground homography from checkerboard views (cart2d/perception/calibration.py does the maths).

A real camera (`--camera URL`, the ESP32-CAM's base URL) is read one JPEG at a time from
URL/capture while the user holds the board where the prompt says and presses Enter. `--synthetic`
calibrates OpenCV-rendered views of a lens with known distortion (cart2d/perception/synthetic.py),
a dry run of the whole procedure whose truth is known. The simulator's camera, once it can place
the board itself (Simulator.place_target), goes through `synthetic_views`' one job: a view of each
pose of `view_plan` and of the board on the floor.
"""

from __future__ import annotations

import math
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from cart2d.perception.calibration import (
    Board,
    CameraCalibration,
    GroundBoard,
    find_corners,
    fit_ground,
)
from cart2d.perception.camera_model import FloatArray, Intrinsics, Mount
from cart2d.tools.camera_calibration.lens import Image, lens_from_views

Pose = tuple[float, float, float]  # the cart's x, y (m) and heading (rad) in the world
Placement = tuple[FloatArray, FloatArray]  # (R, t): world point = R @ board point + t
# The synthetic lens: the stock lens a few per cent off its data sheet, with the barrel distortion
# the simulated OV2640 has (the contract's [sim.camera] k1, k2).
SYNTHETIC_K1, SYNTHETIC_K2 = -0.12, 0.03
CAPTURE_TIMEOUT_S = 5.0
EDGE_PX = 4  # the held board's margin kept inside the picture
# the simulator's views cost little, and more of them pin k2 down (a held board cannot reach the
# picture's bottom corners without going below the floor)
SIM_VIEWS = 20


@dataclass(frozen=True)
class HeldPose:
    """A view of the board held in front of the camera: its middle on the ray of pixel (u, v) of
    the nominal lens, `distance_m` away, tilted about the camera's x and y axes; `hint` says it in
    words for a person holding it."""

    u: float
    v: float
    distance_m: float
    tilt_x_deg: float
    tilt_y_deg: float
    hint: str

    def in_camera(self, board: Board, lens: Intrinsics) -> tuple[FloatArray, FloatArray]:
        """(R, t): camera-frame point = R @ board point + t. Untilted, the board faces the lens
        (its z axis towards it), its columns to the picture's left and its rows downwards."""
        rx, ry = math.radians(self.tilt_x_deg), math.radians(self.tilt_y_deg)
        rot_x = np.array([[1, 0, 0], [0, math.cos(rx), -math.sin(rx)], [0, math.sin(rx), math.cos(rx)]])
        rot_y = np.array([[math.cos(ry), 0, math.sin(ry)], [0, 1, 0], [-math.sin(ry), 0, math.cos(ry)]])
        facing = np.diag([-1.0, 1.0, -1.0])
        r = rot_y @ rot_x @ facing
        ray = np.array([(self.u - lens.cx) / lens.fx, (self.v - lens.cy) / lens.fy, 1.0])
        middle = self.distance_m * ray / np.linalg.norm(ray)
        board_middle = np.array([(board.cols - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_m
        return r, middle - r @ board_middle


# where the board's middle goes, as a fraction of the room it has to each side: the middle and
# the edges of the picture, where the distortion is largest
SPOTS = [
    (0.0, 0.0, "in the middle"),
    (-1.0, -1.0, "top left"),
    (1.0, -1.0, "top right"),
    (-1.0, 1.0, "bottom left"),
    (1.0, 1.0, "bottom right"),
    (0.0, -1.0, "top middle"),
    (0.0, 1.0, "bottom middle"),
    (-1.0, 0.0, "left middle"),
    (1.0, 0.0, "right middle"),
]
# rotations about the camera's x (right) and y (down) axes: a positive one about x takes the
# board's lower edge away from the lens, a positive one about y brings its right side nearer
TILTS = [
    (0, 0, "facing the camera"),
    (35, 0, "its lower edge away"),
    (-35, 0, "its top edge away"),
    (0, 35, "its left side away"),
    (0, -35, "its right side away"),
    (25, 25, "its lower left corner away"),
    (-25, 25, "its top left corner away"),
    (-25, -25, "its top right corner away"),
    (25, -25, "its lower right corner away"),
]
PLANNED_TILTS = 6  # the first six of TILTS take turns; the others are there for held_above_floor
FLOOR_CLEARANCE_M = 0.01  # the held board's lowest edge above the floor
SEEN_MARGIN_SQUARES = 1.3  # of the board around its inner corners kept in the picture


def _held_pose(
    k: int,
    spot: tuple[float, float, str],
    tilt: tuple[int, int, str],
    fill: float,
    shrink: float,
    lens: Intrinsics,
    board: Board,
) -> HeldPose:
    fu, fv, where = spot
    tx, ty, how = tilt
    # the printed board is (cols + 1) x (rows + 1) squares and a margin of about a square each side
    board_w_m, board_h_m = (board.cols + 3) * board.square_m, (board.rows + 3) * board.square_m
    distance = lens.fx * board_w_m / (fill * lens.width)
    half_w, half_h = lens.fx * board_w_m / distance / 2, lens.fy * board_h_m / distance / 2
    room_u = max(0.0, lens.width / 2 - half_w - EDGE_PX)
    room_v = max(0.0, lens.height / 2 - half_h - EDGE_PX)
    return HeldPose(
        lens.cx + shrink * fu * room_u,
        lens.cy + shrink * fv * room_v,
        distance,
        tx,
        ty,
        f"{where}, {how}, about {distance:.2f} m away",
    )


def held_above_floor(pose: HeldPose, board: Board, lens: Intrinsics, mount: Mount) -> bool:
    """Whether the whole printed board (its white margin included) is in the picture of the
    nominal lens and above the floor: a board cannot be held below the floor the camera looks
    down at (at 25 degrees of pitch the floor fills the picture from about 0.35 m on)."""
    r, t = pose.in_camera(board, lens)

    def corners(margin: float) -> FloatArray:
        s = board.square_m
        x0, x1, y0, y1 = (
            -margin * s,
            (board.cols - 1 + margin) * s,
            -margin * s,
            (board.rows - 1 + margin) * s,
        )
        return np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x0, y1, 0.0], [x1, y1, 0.0]]) @ r.T + t

    # in the picture: the squares and a little of the white around them (what findChessboardCorners
    # needs); above the floor: all of the card
    seen, card = corners(SEEN_MARGIN_SQUARES), corners(2.0)
    if (seen[:, 2] <= 0.05).any():
        return False
    u = lens.fx * seen[:, 0] / seen[:, 2] + lens.cx
    v = lens.fy * seen[:, 1] / seen[:, 2] + lens.cy
    if (u < 1).any() or (u > lens.width - 2).any() or (v < 1).any() or (v > lens.height - 2).any():
        return False
    r_cb, t_cb = mount.extrinsics()
    base = (card - t_cb) @ r_cb  # r_cb.T @ (p - t) row by row
    return bool((base[:, 2] >= FLOOR_CLEARANCE_M).all())


def view_plan(n: int, lens: Intrinsics, board: Board, mount: Mount | None = None) -> list[HeldPose]:
    """`n` views that fill the image and tilt the board both ways (what Zhang's method needs to
    separate the focal length from the distance, and the distortion from both), each far enough
    for the whole board (with its white margin) to stay in the picture. With `mount`, every view
    also keeps the board above the floor (held_above_floor): a view that would not is brought
    nearer, nearer the middle of the picture or tilted otherwise, the first of those that fits."""
    poses = []
    for k in range(n):
        spot = SPOTS[k % len(SPOTS)]
        tilt = TILTS[k % PLANNED_TILTS]
        # far enough for the board to take 40 to 60 % of the picture's width: room to reach its corners
        fill = 0.6 - 0.1 * ((k // len(SPOTS)) % 3)
        pose = _held_pose(k, spot, tilt, fill, 1.0, lens, board)
        if mount is not None:
            candidates = (
                _held_pose(k, spot, other, f, shrink, lens, board)
                for other in [tilt, *(t for t in TILTS if t != tilt)]
                for shrink in (1.5, 1.25, 1.0, 0.8, 0.6)
                for f in np.arange(fill, 0.951, 0.05)
            )
            found = next((p for p in candidates if held_above_floor(p, board, lens, mount)), None)
            if found is None:
                continue  # no way to hold the board there: the spot is left out
            pose = found
        poses.append(pose)
    return poses


def held_in_base(
    pose: HeldPose, board: Board, lens: Intrinsics, mount: Mount
) -> tuple[FloatArray, FloatArray]:
    """A held pose in base_link: base point = R @ board point + t."""
    r_cam, t_cam = pose.in_camera(board, lens)
    r_cb, t_cb = mount.extrinsics()
    return r_cb.T @ r_cam, r_cb.T @ (t_cam - t_cb)


def in_world(placement_in_base: Placement, cart: Pose) -> Placement:
    r, t = placement_in_base
    c, s = math.cos(cart[2]), math.sin(cart[2])
    base_to_world = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return base_to_world @ r, base_to_world @ t + np.array([cart[0], cart[1], 0.0])


def board_placements(
    board: Board,
    ground: GroundBoard,
    n: int,
    mount: Mount,
    cart: Pose = (0.0, 0.0, 0.0),
    above_floor: bool = False,
) -> tuple[list[Placement], Placement]:
    """Where a calibration without a person puts the board, in the world of a cart at `cart`:
    the held views of `view_plan` (for the nominal lens; with `above_floor`, only views that keep
    the board above the floor, as a world with a floor needs) and the board on the floor. The
    simulator takes them as they are: Simulator.place_target(Board.from_rotation(R, t, ...))."""
    nominal = Intrinsics.nominal(mount)
    plan = view_plan(n, nominal, board, mount if above_floor else None)
    held = [in_world(held_in_base(pose, board, nominal, mount), cart) for pose in plan]
    return held, in_world(ground.pose_in_base(), cart)


def synthetic_views(
    board: Board, ground: GroundBoard, n: int, mount: Mount, seed: int = 0, cart: Pose = (0.0, 0.0, 0.0)
) -> tuple[Intrinsics, Iterator[Image], Image]:
    """The lens that `--synthetic` pretends to have, its views of the board at `board_placements`
    and its view of the board on the floor. The simulator's camera is used the same way: the
    board placed (Simulator.place_target) at each placement, a frame taken (Simulator.wait_frame)."""
    from cart2d.perception.synthetic import PlacedBoard, SyntheticCamera

    nominal = Intrinsics.nominal(mount)
    truth = Intrinsics(
        nominal.width,
        nominal.height,
        nominal.fx * 1.03,
        nominal.fy * 1.03,
        nominal.cx + 3.0,
        nominal.cy - 2.0,
        (SYNTHETIC_K1, SYNTHETIC_K2, 0.0, 0.0, 0.0),
    )
    camera = SyntheticCamera(truth, mount, seed=seed)
    held, on_floor = board_placements(board, ground, n, mount, cart)

    def views() -> Iterator[Image]:
        for r, t in held:
            yield camera.render(cart, boards=[PlacedBoard(board, r, t)])

    return truth, views(), camera.render(cart, boards=[PlacedBoard(ground.board, *on_floor)])


def capture(url: str) -> Image:
    """One JPEG from the ESP32-CAM's URL/capture, decoded."""
    with urllib.request.urlopen(url.rstrip("/") + "/capture", timeout=CAPTURE_TIMEOUT_S) as reply:
        data = reply.read()
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"{url}/capture did not send a JPEG")
    return np.asarray(image, dtype=np.uint8)


def sized(image: Image, mount: Mount) -> Image:
    """`image` if it has the size perception runs at ([camera] width_px x height_px); else ValueError."""
    if (image.shape[1], image.shape[0]) != (mount.width_px, mount.height_px):
        raise ValueError(
            f"the camera sends {image.shape[1]} x {image.shape[0]} pictures; set its framesize to "
            f"{mount.width_px} x {mount.height_px} ([camera] in config/robot.toml), e.g. in its web page"
        )
    return image


def camera_views(
    url: str, board: Board, ground: GroundBoard, n: int, mount: Mount, ask: Callable[[str], str] = input
) -> tuple[Iterator[Image], Callable[[], Image]]:
    """Views of a real camera: the user holds the board as each prompt says and presses Enter."""
    nominal = Intrinsics.nominal(mount)

    def views() -> Iterator[Image]:
        for k, pose in enumerate(view_plan(n, nominal, board)):
            ask(
                f"view {k + 1}/{n}: hold the {board.cols + 1} x {board.rows + 1} square board {pose.hint}, "
                "all of it in the picture, still; then press Enter "
            )
            yield sized(capture(url), mount)

    def floor_view() -> Image:
        ask(
            f"lay the board flat on the floor, its long side across, its middle {ground.centre_x_m:.3f} m "
            f"ahead of the wheel axis and {ground.centre_y_m:.3f} m left of the centre line, square to "
            "the cart; then press Enter "
        )
        return sized(capture(url), mount)

    return views(), floor_view


def calibrate(
    views: Iterator[Image],
    floor_view: Image | Callable[[], Image],
    board: Board,
    ground: GroundBoard,
    mount: Mount,
    say: Callable[[str], None] = print,
) -> CameraCalibration:
    """The lens from every view the board is found in (lens.lens_from_views: its checks and
    report), then the ground homography. ValueError when there are too few views, the lens fit is
    refused or the floor board is not seen."""
    checked = lens_from_views(((f"view {k + 1}", image) for k, image in enumerate(views)), board, say)
    lens = checked.lens
    image = floor_view() if callable(floor_view) else floor_view
    found = find_corners(image, ground.board)
    if found is None:
        raise ValueError("the board on the floor was not found in the picture")
    fit = fit_ground(found, lens.intrinsics, ground, mount)
    say(
        f"ground: the board's corners land {1000 * fit.rms_m:.1f} mm RMS ({1000 * fit.max_m:.1f} mm "
        f"at worst) from where they lie; {fit.outliers} corner(s) left out"
    )
    return CameraCalibration.of(lens, fit)
