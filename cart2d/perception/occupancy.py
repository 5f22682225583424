"""The perceived obstacles as an occupancy grid with log-odds (Moravec & Elfes, "High resolution
maps from wide angle sonar", ICRA 1985; Thrun, Burgard & Fox, Probabilistic Robotics, ch. 9):
every cell holds l = log(p / (1 - p)), starting at 0 (p = 0.5, unknown). A detection's hits add
`hit_log_odds` to their cells, the cells its rays cross on their way (free floor seen) add
`free_log_odds`, and l is clamped so that a cell can change its mind after a few frames.

A hit marks its cell and the cells behind it (the camera sees an obstacle's face, not its
depth): behind the face, along its normal, where the hit's neighbours (the hits of nearby scan
lines, on the same face) tell the face's direction, as deep as its run of hits is long (an
obstacle is taken to be about as deep as it is wide) up to `hit_depth_m`; a hit whose run is too
short to tell (a thin pole, the end of a face at the picture's side) is only its cell. What is
assumed behind a face rises to two hits' worth at most and never where the floor was seen more
than hit: floor seen from elsewhere refines a face-only belief (ASSUMED_HITS). Along the
ray (an earlier rule) the depth behind the end of a face seen at a slant spilt sideways onto the
floor beside the obstacle and closed passages next to it; one depth for every obstacle either
left a deep box's far corner out or closed the passages between small ones. A ray is sampled
every half cell from min range to its end: the cells it crosses, each counted once per frame
however many rays cross it; a ray that ends on a hit stops half a cell short of it, and a cell
hit in a frame is never also cleared in that frame. A frame whose heading is uncertain (taken
while the cart turned: its capture time's error turns the whole view) clears no floor beyond a hit
within that angle of a ray's bearing: at 2.6 rad/s a 20 ms error swings a ray 5 cm at 1 m, and
such rays, seen beside a box, cleared its far side. Cells a frame has hit or crossed are
`observed` (the rest no frame has shown: cart2d/gateway/look.py looks there before driving).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from cart2d.perception.camera_model import FloatArray
from cart2d.perception.detection import Detection

Pose = tuple[float, float, float]  # x, y (m) and heading theta (rad) of base_link in the map

# A face's direction at a hit, from the hits of nearby scan lines: at most FACE_WINDOW of them
# each side (320 lines span ~0.4 m of floor at 0.35 m, ~1.1 m at 1 m: 32 lines 4 to 11 cm), within
# FACE_RADIUS_M of it (another obstacle's hits are farther), spread over MIN_FACE_SPAN_M at least
# (the hits' range steps are about 1 to 2 cm at 1 m, so a shorter run gives no direction to trust).
FACE_WINDOW = 32
FACE_RADIUS_M = 0.08
MIN_FACE_SPAN_M = 0.04
# A run of hits: hits in scan-line order each within RUN_GAP_M of the one before (along a face the
# next line's hit is millimetres to a range step away; another obstacle's starts further off).
RUN_GAP_M = 0.04
# A hit that two cues saw adds this much more of hit_log_odds than one only one cue saw (and
# again for a third): believed after fewer frames, cleared by more.
SUPPORT_WEIGHT = 0.5
# The cells behind a face (assumed, not seen) rise to at most two hits' worth: believed after two
# frames like a face, but cleared by about six rays of floor seen through them from elsewhere;
# and where the floor was seen more than hit (log-odds below 0), a face seen again adds no
# assumption: seen floor beats an assumed body (exploration saved each box larger than it is, with
# false cells round it, as the depth assumed frame after frame outweighed the floor seen there).
ASSUMED_HITS = 2.0


def run_lengths(hits: FloatArray) -> FloatArray:
    """Per hit (N x 2, in scan-line order), the length of its run of hits, end to end."""
    if len(hits) == 0:
        return np.zeros(0)
    breaks = np.hypot(*np.diff(hits, axis=0).T) > RUN_GAP_M
    run = np.concatenate([[0], np.cumsum(breaks)])
    first = np.searchsorted(run, run, side="left")
    last = np.searchsorted(run, run, side="right") - 1
    return np.asarray(np.hypot(*(hits[last] - hits[first]).T), dtype=np.float64)


def _reach(origin: FloatArray, ends: FloatArray, hits: FloatArray, heading_sigma: float) -> FloatArray:
    """Per ray (to `ends`), how far it may clear floor: up to the nearest hit within
    `heading_sigma` of its bearing (unbounded with none, or a certain heading). Bearings are taken
    from the first ray's (a picture spans far less than a half turn), the hits sorted by theirs,
    and each ray's window of hits found by bisection: a few hundred rays and hits in well under
    a millisecond."""
    reach = np.full(len(ends), np.inf)
    if heading_sigma <= 0.0 or len(hits) == 0 or len(ends) == 0:
        return reach
    rays, faces = ends - origin, hits - origin
    ref = math.atan2(rays[0, 1], rays[0, 0])

    def bearing(v: FloatArray) -> FloatArray:
        return np.asarray(np.remainder(np.arctan2(v[:, 1], v[:, 0]) - ref + math.pi, math.tau) - math.pi)

    face_bearings = bearing(faces)
    order = np.argsort(face_bearings)
    sorted_bearings = face_bearings[order]
    ranges = np.append(np.hypot(faces[order, 0], faces[order, 1]), np.inf)  # inf: past the last
    b = bearing(rays)
    lo = np.searchsorted(sorted_bearings, b - heading_sigma, side="left")
    hi = np.searchsorted(sorted_bearings, b + heading_sigma, side="right")
    # the minimum of ranges[lo:hi] per ray: reduceat over the pairs (lo, hi), its even results
    nearest = np.minimum.reduceat(ranges, np.column_stack([lo, hi]).reshape(-1))[::2]
    return np.asarray(np.where(hi > lo, nearest, reach), dtype=np.float64)


class LogOddsGrid:
    def __init__(
        self,
        origin: tuple[float, float],
        resolution_m: float,
        width: int,
        height: int,
        hit_log_odds: float = 0.85,  # p = 0.7 per hit
        free_log_odds: float = -0.4,  # p = 0.4 per ray crossing
        min_log_odds: float = -2.0,
        max_log_odds: float = 3.5,  # p = 0.97: cleared by about 9 frames of free rays
        hit_depth_m: float = 0.0,  # how deep behind its face an obstacle is taken to be, at most
    ) -> None:
        if resolution_m <= 0.0 or width < 1 or height < 1:
            raise ValueError("the grid needs a positive resolution and at least one cell")
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution_m = float(resolution_m)
        self.width, self.height = int(width), int(height)
        self.hit_log_odds, self.free_log_odds = hit_log_odds, free_log_odds
        self.min_log_odds, self.max_log_odds = min_log_odds, max_log_odds
        self.hit_depth_m = float(hit_depth_m)
        self.log_odds = np.zeros((self.height, self.width), dtype=np.float32)
        self._observed = np.zeros((self.height, self.width), dtype=np.bool_)  # hit or crossed, ever

    def clear(self) -> None:
        self.log_odds[:] = 0.0
        self._observed[:] = False

    def observed(self, points: FloatArray) -> npt.NDArray[np.bool_]:
        """Whether each point (N x 2, map m) lies in a cell some frame has hit or seen floor in
        (off the grid: no)."""
        ij = np.floor((np.reshape(points, (-1, 2)) - np.array(self.origin)) / self.resolution_m).astype(
            np.int64
        )
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.width) & (ij[:, 1] >= 0) & (ij[:, 1] < self.height)
        out = np.zeros(len(ij), dtype=np.bool_)
        out[inside] = self._observed[ij[inside, 1], ij[inside, 0]]
        return out

    def probability(self) -> npt.NDArray[np.float32]:
        """p(occupied) per cell, rows along y from the origin."""
        return np.asarray(1.0 / (1.0 + np.exp(-self.log_odds)), dtype=np.float32)

    def _cells(self, points: FloatArray) -> npt.NDArray[np.int64]:
        """Flat indices of the cells holding `points` (N x 2, map m), those outside dropped."""
        ij = np.floor((points - np.array(self.origin)) / self.resolution_m).astype(np.int64)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.width) & (ij[:, 1] >= 0) & (ij[:, 1] < self.height)
        return np.asarray(ij[inside, 1] * self.width + ij[inside, 0], dtype=np.int64)

    def integrate(self, pose: Pose, detection: Detection, heading_sigma: float = 0.0) -> None:
        """Adds one detection made with the cart at `pose`, its heading uncertain by
        `heading_sigma` (rad)."""
        x, y, theta = pose
        c, s = math.cos(theta), math.sin(theta)
        rotation = np.array([[c, -s], [s, c]])

        def to_map(points: FloatArray) -> FloatArray:
            return np.asarray(np.reshape(points, (-1, 2)) @ rotation.T + [x, y], dtype=np.float64)

        origin = to_map(detection.origin)[0]
        hits, ends = to_map(detection.hits), to_map(detection.free)
        ends_on_hit = np.zeros(len(ends), dtype=bool)
        ends_on_hit[: len(hits)] = True  # Detection.free lists the hits first
        behind, hit_of = self._behind_indexed(origin, hits)
        hit_cells, weights = self._hit_weights(behind, hit_of, detection)
        free_cells = np.setdiff1d(
            self._free_cells(
                origin, ends, ends_on_hit, detection.min_range_m, _reach(origin, ends, hits, heading_sigma)
            ),
            hit_cells,
        )
        flat = self.log_odds.reshape(-1)
        low, high = self.min_log_odds, self.max_log_odds
        changed = np.clip(flat[hit_cells] + self.hit_log_odds * weights, low, high)
        assumed = ~np.isin(hit_cells, self._cells(hits))  # behind a face, not on it
        changed[assumed] = self._assumed(flat[hit_cells[assumed]], changed[assumed])
        flat[free_cells] = np.clip(flat[free_cells] + self.free_log_odds, low, high)
        flat[hit_cells] = changed
        self._observed.reshape(-1)[np.concatenate([free_cells, hit_cells])] = True

    def _assumed(self, now: npt.NDArray[np.float32], raised: FloatArray) -> npt.NDArray[np.float32]:
        """The log-odds of cells behind a face (`now`) once a frame assumes them occupied
        (`raised`, as if hit): up to ASSUMED_HITS hits' worth (what a face seen there raised
        higher stays), and unchanged where the floor was seen more than hit."""
        ceiling = ASSUMED_HITS * self.hit_log_odds
        grown = np.maximum(now, np.minimum(raised, ceiling))
        return np.asarray(np.where(now < 0.0, now, grown), dtype=np.float32)

    def _hit_weights(
        self, behind: FloatArray, hit_of: npt.NDArray[np.int64], detection: Detection
    ) -> tuple[npt.NDArray[np.int64], FloatArray]:
        """The cells the hits mark (each once) and the weight of their evidence: a hit that more
        cues saw (Detection.support: appearance, parallax, boundary) counts SUPPORT_WEIGHT more per
        cue beyond the first; a cell several hits mark takes the strongest."""
        support = np.ones(len(detection.hits), np.int32)
        if len(detection.support) == len(detection.hits):
            support = np.maximum(detection.support, 1)
        ij = np.floor((behind - np.array(self.origin)) / self.resolution_m).astype(np.int64)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.width) & (ij[:, 1] >= 0) & (ij[:, 1] < self.height)
        cells = ij[inside, 1] * self.width + ij[inside, 0]
        levels = support[hit_of[inside]]
        order = np.lexsort((-levels, cells))  # by cell, the strongest first
        unique, first = np.unique(cells[order], return_index=True)
        weights = 1.0 + SUPPORT_WEIGHT * (levels[order][first] - 1)
        return np.asarray(unique, dtype=np.int64), np.asarray(weights, dtype=np.float64)

    def _behind(self, origin: FloatArray, hits: FloatArray) -> FloatArray:
        """The points _behind_indexed gives, without their hits' indices."""
        return self._behind_indexed(origin, hits)[0]

    def _behind_indexed(
        self, origin: FloatArray, hits: FloatArray
    ) -> tuple[FloatArray, npt.NDArray[np.int64]]:
        """The hits and, behind each, the points into the obstacle as deep as its run of hits is
        long, up to hit_depth_m: a camera sees an obstacle's face, never how deep it is, and a cart
        that plans past a face's ends must not cut through the unseen rest. Free rays from other
        views clear what is not there. With each point, the index of its hit."""
        if self.hit_depth_m <= 0.0 or len(hits) == 0:
            return hits, np.arange(len(hits), dtype=np.int64)
        directions = self._into_obstacle(origin, hits)
        depths = np.minimum(run_lengths(hits), self.hit_depth_m)
        t = np.arange(0.0, self.hit_depth_m + 1e-9, self.resolution_m / 2)
        points = hits[:, None, :] + directions[:, None, :] * t[None, :, None]
        inside = t[None, :] <= depths[:, None] + 1e-9
        index = np.broadcast_to(np.arange(len(hits))[:, None], inside.shape)
        return np.asarray(points[inside], dtype=np.float64), np.asarray(index[inside], dtype=np.int64)

    @staticmethod
    def _into_obstacle(origin: FloatArray, hits: FloatArray) -> FloatArray:
        """Per hit, the unit vector into its obstacle: the normal of the face through it, away from
        the camera, where hits of nearby scan lines (FACE_WINDOW each side in the hits' order,
        within FACE_RADIUS_M) spread along a face at least MIN_FACE_SPAN_M (their principal
        direction, from the 2 x 2 scatter); else zero (no depth is assumed)."""
        rays = hits - origin
        rays = rays / np.maximum(np.linalg.norm(rays, axis=1), 1e-12)[:, None]
        n = len(hits)
        index = np.arange(n)[:, None] + np.arange(-FACE_WINDOW, FACE_WINDOW + 1)[None, :]
        offsets = hits[np.clip(index, 0, n - 1)] - hits[:, None, :]
        near = (index >= 0) & (index < n) & (np.hypot(offsets[..., 0], offsets[..., 1]) <= FACE_RADIUS_M)
        count = near.sum(axis=1)
        mean = (offsets * near[..., None]).sum(axis=1) / count[:, None]
        centred = (offsets - mean[:, None, :]) * near[..., None]
        sxx = (centred[..., 0] ** 2).sum(axis=1)
        syy = (centred[..., 1] ** 2).sum(axis=1)
        sxy = (centred[..., 0] * centred[..., 1]).sum(axis=1)
        along = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # the principal direction's angle
        spread = 0.5 * (sxx + syy + np.hypot(sxx - syy, 2.0 * sxy)) / count  # its variance
        normals = np.column_stack([-np.sin(along), np.cos(along)])
        normals *= np.where((normals * rays).sum(axis=1) < 0.0, -1.0, 1.0)[:, None]
        face = spread >= MIN_FACE_SPAN_M**2 / 12.0  # the variance of points spread evenly over a span
        return np.asarray(np.where(face[:, None], normals, 0.0), dtype=np.float64)

    def _free_cells(
        self,
        origin: FloatArray,
        ends: FloatArray,
        ends_on_hit: npt.NDArray[np.bool_],
        min_range_m: float,
        reach: FloatArray,
    ) -> npt.NDArray[np.int64]:
        if len(ends) == 0:
            return np.zeros(0, dtype=np.int64)
        step = self.resolution_m / 2
        offsets = ends - origin
        lengths = np.linalg.norm(offsets, axis=1)
        stop = np.minimum(lengths - np.where(ends_on_hit, step, 0.0), reach - step)
        t = min_range_m + step * np.arange(max(1, math.ceil((float(stop.max()) - min_range_m) / step) + 1))
        along = t[None, :] <= stop[:, None]
        directions = offsets / np.maximum(lengths, 1e-12)[:, None]
        samples = origin + directions[:, None, :] * t[None, :, None]
        return np.unique(self._cells(samples[along]))

    def cells(self, threshold: float = 0.5) -> list[tuple[float, float, float]]:
        """(x, y, p) of the cells' centres (map m) whose p(occupied) is above `threshold`; rounded
        to 0.1 mm and 0.001 (binary fractions printed whole were three times the size of every
        message of cells the gateway sends its viewers, twice a second)."""
        p = self.probability()
        rows, cols = np.nonzero(p > threshold)
        xs = np.round(self.origin[0] + (cols + 0.5) * self.resolution_m, 4)
        ys = np.round(self.origin[1] + (rows + 0.5) * self.resolution_m, 4)
        qs = np.round(p[rows, cols].astype(np.float64), 3)
        return [(float(a), float(b), float(q)) for a, b, q in zip(xs, ys, qs, strict=True)]
