"""Obstacles on the floor from one camera image (monocular ground-plane obstacle detection, as in
Duckietown's ground projection or Ulrich & Nourbakhsh, "Appearance-based obstacle detection with
monocular color vision", AAAI 2000): whatever does not look like the floor just in front of the
cart is an obstacle; where it meets the floor, the lowest non-floor pixel of each image column,
is projected onto the floor through the ground homography.

The "columns" are scan lines through the vanishing point of vertical lines (Hartley & Zisserman,
section 8.6): with the camera pitched down the vertical edges of a box converge below the image,
and a plain image column crossing such an edge would take a point high on the box for its foot,
placing a hit behind the box. Along a scan line through that point, the lowest non-floor pixel
of an edge is its foot. The scan lines are sampled from the raw image with cv2.remap.

- Three cues say where the floor ends, each where it can decide: the floor's appearance in
  shadow-blind terms (cart2d/perception/floor_model.py), learnt from a patch of floor just in
  front of the cart and refreshed slowly from that patch's pixels no cue flags; the floor's
  geometry, what does not line up with the last frame warped by the floor's homography
  (cart2d/perception/parallax.py, passed in as `off_plane`); and the boundary, the image's edges
  (cv2.Canny), onto which the foot of what the other two found is moved when one lies just below
  it (JPEG blur and the cleaning spread an obstacle's colour a row or two onto the floor). Each
  hit carries how many cues saw it (Detection.support), the weight of its evidence in the
  log-odds grid (cart2d/perception/occupancy.py). Specks are dropped by an opening with a
  vertical line, which keeps a 2 cm leg at 1 m (6 pixels wide) whole.
- Each column gives a ray on the floor from the lens's foot: to the column's hit if there is one
  within the range limits (the hit's pixel edge projected), else to the last floor pixel within
  the maximum range. Rays are evidence of free floor; hits of obstacles (cart2d/perception/occupancy.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import FloatArray, Mount
from cart2d.perception.floor_model import FloorModel, FloorModelConfig, chromaticity

BoolImage = npt.NDArray[np.bool_]

# The cleaning's sizes in pixels (open_px, close_px, solid_samples) are given for a picture this
# tall (QVGA) and scaled with the picture's height: a speck or a thin leg spans fewer rows of a
# smaller picture, and a 5-row opening would erase a whole obstacle near the horizon of a
# 96-row one.
QVGA_HEIGHT = 240


def scaled_px(size_px: int, height_px: int, least: int) -> int:
    """`size_px` (at QVGA_HEIGHT) for a picture `height_px` tall, at least `least`; never larger."""
    return max(least, min(size_px, round(size_px * height_px / QVGA_HEIGHT)))


@dataclass(frozen=True)
class DetectorConfig:
    min_range_m: float = (
        0.18  # along the floor from the lens's foot; the image starts about here (robot.toml)
    )
    max_range_m: float = 1.25  # where the picture ends (robot.toml), and a pixel spans ~2 cm of floor
    patch_depth_m: float = 0.15  # the floor patch learnt from: this deep from the nearest floor seen...
    patch_half_width_m: float = 0.12  # ...and this wide each side of the lens
    floor: FloorModelConfig = field(default_factory=FloorModelConfig)
    min_patch_floor: float = 0.6  # learn only while this much of the patch looks like floor
    blur_px: int = 5  # median filter of the floor mask: 3 or 5
    open_px: int = 5  # an opening by a vertical line removes specks of non-floor (JPEG ringing)...
    close_px: int = 7  # ... closing fills holes inside an obstacle
    guard_px: int = 9  # learning keeps this far from any non-floor pixel
    solid_samples: int = 5  # an obstacle spans at least this many samples up a scan line
    # A line that grazes a vertical edge (which runs along the lines) leaves the obstacle sideways,
    # high up: its "foot" is no foot when the foot of a line d <= foot_lines away is more than
    # d * foot_step_rows lower. Near the picture's sides a calibrated line can lean a little off the
    # true vertical, and grazes an edge over a few lines: 4 lines catch that (a face's own foot,
    # rising less than foot_step_rows per line, passes at any distance).
    foot_step_rows: int = 3
    foot_lines: int = 4
    # The boundary cue: edges (cv2.Canny on the grey picture, these thresholds) up to snap_rows
    # below the lowest obstacle sample of a line take the foot down to them.
    canny_low: int = 40
    canny_high: int = 100
    snap_rows: int = 4


@dataclass
class Detection:
    """One image's result, in base_link (x forward, y left, m)."""

    floor_mask: BoolImage  # H x W, True where the image looks like floor
    lowest_row: npt.NDArray[np.int32]  # per scan line (~column): lowest non-floor sample in range, -1 if none
    lowest_px: FloatArray  # per scan line: that sample's raw pixel (u, v), NaN if none
    hits: FloatArray  # N x 2: where obstacles meet the floor, within the range limits
    # M x 2: ends of the rays of free floor: the hits first, then the floor seen up to max range
    free: FloatArray
    origin: FloatArray  # the lens's foot on the floor, where every ray starts
    min_range_m: float
    is_hit: BoolImage  # per scan line: whether it gave a hit
    # per hit: how many cues (appearance, parallax, boundary) put an obstacle's foot there
    support: npt.NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))


class ObstacleDetector:
    def __init__(
        self, calibration: CameraCalibration, mount: Mount | None = None, config: DetectorConfig | None = None
    ) -> None:
        self.calibration = calibration
        self.mount = mount or Mount.from_robot()
        self.config = config or DetectorConfig()
        lens = calibration.intrinsics
        self.size = (lens.width, lens.height)
        self.origin = np.array([self.mount.x_m, self.mount.y_m])
        u, v = np.meshgrid(np.arange(lens.width, dtype=np.float64), np.arange(lens.height, dtype=np.float64))
        centre_xy, centre_ok = self._ground_raw(u, v)
        self.patch = self._patch_mask(centre_xy, centre_ok)
        if not self.patch.any():
            raise ValueError(
                "the camera sees no floor just in front of the cart: check [camera] and the calibration"
            )
        self._scan_lines()
        k = self.config
        self.floor_model = FloorModel(k.floor)
        height = lens.height
        open_px, close_px = scaled_px(k.open_px, height, 3), scaled_px(k.close_px, height, 3)
        self.open_kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (1, open_px))
        self.close_kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (close_px, close_px))
        self.guard_kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k.guard_px, k.guard_px))
        self.solid_kernel = np.ones((scaled_px(k.solid_samples, height, 2), 1), np.uint8)

    def _ground_raw(self, u: FloatArray, v: FloatArray) -> tuple[FloatArray, BoolImage]:
        xy, ok = self.calibration.pixels_to_ground(np.column_stack([u.ravel(), v.ravel()]))
        return xy.reshape(*u.shape, 2), ok.reshape(u.shape)

    def _patch_mask(self, centre_xy: FloatArray, centre_ok: BoolImage) -> BoolImage:
        """The floor just in front of the cart: from the nearest floor the camera sees, patch_depth_m deep."""
        x = np.where(centre_ok, centre_xy[..., 0], np.inf)
        y = centre_xy[..., 1]
        nearest = float(x[centre_ok].min()) if centre_ok.any() else np.inf
        return np.asarray(
            centre_ok
            & (x <= nearest + self.config.patch_depth_m)
            & (np.abs(y - self.mount.y_m) <= self.config.patch_half_width_m),
            dtype=np.bool_,
        )

    def _vertical_vanishing_point(self) -> FloatArray | None:
        """Where vertical lines meet in the ideal image, from the ground homography: its first two
        columns are K r1 and K r2 (up to scale), the floor's axes, and r1 x r2 is the vertical."""
        lens = self.calibration.intrinsics
        kinv = np.linalg.inv(lens.matrix())
        h = self.calibration.ground.floor_to_pixel
        r1, r2 = kinv @ h[:, 0], kinv @ h[:, 1]
        vertical = lens.matrix() @ np.cross(r1 / np.linalg.norm(r1), r2 / np.linalg.norm(r2))
        if abs(vertical[2]) < 1e-9 * np.linalg.norm(vertical):
            return None  # optical axis horizontal: verticals stay parallel, image columns are right
        point: FloatArray = vertical[:2] / vertical[2]
        return point

    def _scan_lines(self) -> None:
        """Scan line k (one per image column) passes through pixel (k, cy) of the ideal image and the
        vertical vanishing point; sample r of every line is on ideal row r. Precomputed: where each
        sample is in the raw image (remap maps), the floor point of its lower edge, its range."""
        lens, k = self.calibration.intrinsics, self.config
        width, height = self.size
        rows = np.arange(height, dtype=np.float64)[:, None]
        anchors = np.arange(width, dtype=np.float64)[None, :]
        vp = self._vertical_vanishing_point()
        if vp is None or abs(vp[1] - lens.cy) < 1e-6:
            u = np.broadcast_to(anchors, (height, width)).copy()
        else:
            u = vp[0] + (anchors - vp[0]) * (rows - vp[1]) / (lens.cy - vp[1])
        v = np.broadcast_to(rows, (height, width))
        raw = lens.distort(np.column_stack([u.ravel(), v.ravel()])).reshape(height, width, 2)
        self.map_x = raw[..., 0].astype(np.float32)
        self.map_y = raw[..., 1].astype(np.float32)
        inside = (
            (raw[..., 0] >= 0) & (raw[..., 0] <= width - 1) & (raw[..., 1] >= 0) & (raw[..., 1] <= height - 1)
        )
        ground = self.calibration.ground
        centre_xy, centre_ok = ground.pixels_to_ground(np.column_stack([u.ravel(), v.ravel()]))
        edge_xy, edge_ok = ground.pixels_to_ground(np.column_stack([u.ravel(), (v + 0.5).ravel()]))
        centre_xy, edge_xy = centre_xy.reshape(height, width, 2), edge_xy.reshape(height, width, 2)
        centre_distance = np.linalg.norm(centre_xy - self.origin, axis=-1)
        centre_distance[~centre_ok.reshape(height, width)] = np.inf
        self.scan_in_range = inside & (centre_distance <= k.max_range_m)
        self.edge_xy = edge_xy
        self.edge_distance = np.linalg.norm(edge_xy - self.origin, axis=-1)
        self.edge_distance[~edge_ok.reshape(height, width)] = np.inf
        # per scan line, the lowest sample in the picture: an obstacle there hides its own foot
        seen = inside & centre_ok.reshape(height, width)
        self.bottom_row = np.where(seen.any(axis=0), height - 1 - np.argmax(seen[::-1], axis=0), -1).astype(
            np.int32
        )
        # per scan line, the highest sample still within max range: where a clear line's ray ends
        has = self.scan_in_range.any(axis=0)
        self.far_row = np.where(has, np.argmax(self.scan_in_range, axis=0), -1).astype(np.int32)
        cols = np.arange(width)
        self.far_xy = np.where(has[:, None], centre_xy[np.maximum(self.far_row, 0), cols], np.nan)

    def field_of_view(self, every: int = 16) -> FloatArray:
        """The floor the detector looks at, as a polygon in base_link (K x 2): the nearest floor
        each scan line sees, left to right, then where it ends (max range or the picture's edge),
        right to left; one line in `every`, and the outermost ones."""
        usable = np.nonzero((self.far_row >= 0) & (self.bottom_row >= 0))[0]
        if len(usable) == 0:
            return np.zeros((0, 2))
        lines = np.unique(np.concatenate([usable[::every], usable[-1:]]))
        near = self.edge_xy[self.bottom_row[lines], lines]
        far = self.far_xy[lines]
        return np.asarray(np.concatenate([near, far[::-1]]), dtype=np.float64)

    def learn(self, bgr: npt.NDArray[np.uint8]) -> None:
        """Learns the floor from the patch in front of the cart, all of it: the patch must be clear."""
        chroma, brightness = chromaticity(bgr)
        self.floor_model = FloorModel(self.config.floor)
        self.floor_model.learn(chroma, brightness, self.patch)

    def forget_floor(self) -> None:
        """The next picture learns the floor afresh from its patch (another room, another picture)."""
        self.floor_model = FloorModel(self.config.floor)

    def detect(self, bgr: npt.NDArray[np.uint8], off_plane: BoolImage | None = None) -> Detection:
        """One raw image (the calibration's size) -> its Detection. `off_plane`: the parallax cue's
        mask for this image (raw pixels standing above the floor), if there is one. The first image
        also teaches the floor (see learn)."""
        if (bgr.shape[1], bgr.shape[0]) != self.size:
            raise ValueError(f"a {bgr.shape[1]} x {bgr.shape[0]} image; the calibration is for {self.size}")
        chroma, brightness = chromaticity(bgr)
        if not self.floor_model.learnt:
            self.floor_model.learn(
                chroma, brightness, self.patch if off_plane is None else self.patch & ~off_plane
            )
        k = self.config
        looks_floor = self.floor_model.floor_like(chroma, brightness).astype(np.uint8)
        speckled = cv2.medianBlur(1 - looks_floor, k.blur_px)  # an edge stays where it is
        opened = cv2.morphologyEx(speckled, cv2.MORPH_OPEN, self.open_kernel)
        unlike = np.asarray(cv2.morphologyEx(opened, cv2.MORPH_CLOSE, self.close_kernel), dtype=np.uint8)
        not_floor = unlike if off_plane is None else np.maximum(unlike, off_plane.astype(np.uint8))
        self._refresh(chroma, brightness, not_floor)
        edges = cv2.Canny(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), k.canny_low, k.canny_high)
        lines = [
            cv2.remap(image, self.map_x, self.map_y, cv2.INTER_NEAREST, borderValue=0)
            for image in (
                unlike,
                np.zeros_like(unlike) if off_plane is None else off_plane.astype(np.uint8),
                edges,
            )
        ]
        cues = [
            cv2.morphologyEx(line, cv2.MORPH_OPEN, self.solid_kernel).astype(bool) & self.scan_in_range
            for line in lines[:2]
        ]
        return self._rays(not_floor == 0, cues[0] | cues[1], cues, lines[2] > 0)

    def _refresh(
        self,
        chroma: npt.NDArray[np.uint8],
        brightness: npt.NDArray[np.uint8],
        not_floor: npt.NDArray[np.uint8],
    ) -> None:
        """Follows slow changes of the floor (light, a different floor) from the patch's floor pixels
        away from any obstacle; a patch mostly covered is not learnt from at all."""
        k = self.config
        guarded = cv2.dilate(not_floor, self.guard_kernel).astype(bool)
        learn_from = self.patch & ~guarded
        if learn_from.sum() < k.min_patch_floor * self.patch.sum():
            return
        self.floor_model.learn(chroma, brightness, learn_from)

    def _rays(
        self,
        floor: BoolImage,
        obstacle: BoolImage,
        cues: Sequence[BoolImage] = (),
        edges: BoolImage | None = None,
    ) -> Detection:
        """`obstacle`: along the scan lines (row, line), where an obstacle is; `cues`: the same
        per cue (appearance, parallax) for the support count; `edges`: the boundary cue's edges
        along the lines, onto which each line's foot is moved if one is within snap_rows."""
        height, width = obstacle.shape
        k = self.config
        has = np.asarray(obstacle.any(axis=0), dtype=np.bool_)
        lowest = np.where(has, height - 1 - np.argmax(obstacle[::-1], axis=0), -1).astype(np.int32)
        cols = np.arange(width)
        support = np.zeros(width, np.int32)
        for cue in cues:
            near = [
                cue[np.clip(lowest + d, 0, height - 1), cols] for d in range(-k.snap_rows, k.snap_rows + 1)
            ]
            support += np.any(near, axis=0) & has
        if edges is not None:
            lowest, snapped = self._snapped(lowest, has, edges)
            support += snapped
        rows = np.maximum(lowest, 0)
        hit_distance = np.where(has, self.edge_distance[rows, cols], np.inf)
        foot_seen = lowest < self.bottom_row  # floor seen below the obstacle on this line
        # beyond the picture's sides a neighbour counts as lower than any row: a line there cannot
        # be shown not to graze an obstacle's silhouette, so its "foot" is not taken
        padded = np.pad(lowest, k.foot_lines, constant_values=height)
        for d in range(1, k.foot_lines + 1):
            left, right = (
                padded[k.foot_lines - d : k.foot_lines - d + width],
                padded[k.foot_lines + d :][:width],
            )
            foot_seen &= np.maximum(left, right) <= lowest + d * k.foot_step_rows
        is_hit = has & foot_seen & (hit_distance >= k.min_range_m) & (hit_distance <= k.max_range_m)
        hits = self.edge_xy[rows[is_hit], cols[is_hit]]
        # no obstacle in range: the line saw floor up to max range; an obstacle too near, or one
        # whose foot is out of the picture: no ray
        clear = ~has & (self.far_row >= 0)
        free = np.concatenate([hits, self.far_xy[clear]])
        lowest_px = np.full((width, 2), np.nan)
        lowest_px[has] = np.column_stack([self.map_x[rows[has], cols[has]], self.map_y[rows[has], cols[has]]])
        return Detection(
            floor_mask=floor,
            lowest_row=lowest,
            lowest_px=lowest_px,
            hits=hits,
            free=free,
            origin=self.origin.copy(),
            min_range_m=k.min_range_m,
            is_hit=is_hit,
            support=support[is_hit],
        )

    def _snapped(
        self, lowest: npt.NDArray[np.int32], has: BoolImage, edges: BoolImage
    ) -> tuple[npt.NDArray[np.int32], BoolImage]:
        """Each line's lowest obstacle sample moved to the nearest edge within snap_rows (the
        nearer one first; at equal distance the one above: JPEG and the cleaning spread an
        obstacle downwards, never up), and which lines were moved."""
        height, width = edges.shape
        cols = np.arange(width)
        out, snapped = lowest.copy(), np.zeros(width, dtype=np.bool_)
        for distance in range(self.config.snap_rows + 1):
            for d in (-distance, distance) if distance else (0,):
                rows = lowest + d
                inside = has & ~snapped & (rows >= 0) & (rows < height)
                found = inside & edges[np.clip(rows, 0, height - 1), cols]
                out[found] = rows[found]
                snapped |= found
        return out, snapped


def draw_detection(canvas: npt.NDArray[np.uint8], detection: Detection) -> None:
    """Draws on `canvas` (the frame the detection is of, BGR), in place: the floor tinted green,
    each scan line's hit marked red."""
    tint = np.zeros_like(canvas)
    tint[detection.floor_mask] = (0, 160, 0)
    cv2.addWeighted(canvas, 1.0, tint, 0.35, 0.0, dst=canvas)
    for u, v in detection.lowest_px[detection.is_hit]:
        cv2.circle(canvas, (round(u), round(v)), 1, (0, 0, 255), -1)


def draw_overlay(bgr: npt.NDArray[np.uint8], detection: Detection) -> npt.NDArray[np.uint8]:
    """A copy of the frame with the detection drawn (draw_detection)."""
    out = bgr.copy()
    draw_detection(out, detection)
    return out
