"""The graph of a grid for a disc of a given radius: which nodes the disc may stand on and which
8-connected edges it may slide along, built with whole-array operations (footprint stencils
stamped over the occupancy), and the exact checks of single points and segments against the
obstacles."""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import threading
from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt

from cart2d.planning.geometry import (
    FloatArray,
    _point_segment_d2_v,
    _segment_box_d2,
    _segment_box_d2_v,
)
from cart2d.planning.grid import DIRECTIONS, EPS, SQRT2, Grid, Node, OffMap, PlanError, Point

# The footprint may span at most this many grid steps (the seed's map: 0.85).
MAX_FOOTPRINT_STEPS = 50
# Up to this many segments are checked one by one rather than as arrays.
_FEW_SEGMENTS = 32


@functools.cache
def _stencil(radius: float, move: Node) -> tuple[Node, ...]:
    """Cell offsets (relative to a node) whose squares a disc of `radius` (grid units) touches
    while sliding from the node by `move` (a point when move is (0, 0))."""
    reach = radius + EPS
    m = math.ceil(reach + 1.5)
    ax, ay = 0.0, 0.0
    bx, by = float(move[0]), float(move[1])
    out = []
    for dj in range(-m, m + 1):
        for di in range(-m, m + 1):
            d2 = _segment_box_d2(ax, ay, bx, by, di - 0.5, di + 0.5, dj - 0.5, dj + 0.5)
            if d2 <= reach * reach:
                out.append((di, dj))
    return tuple(out)


def _runs(stencil: Iterable[Node]) -> tuple[tuple[int, int, int], ...]:
    """The stencil as horizontal runs (dj, first di, length), in any order."""
    runs: list[tuple[int, int, int]] = []
    for di, dj in sorted(stencil, key=lambda c: (c[1], c[0])):
        if runs and runs[-1][0] == dj and runs[-1][1] + runs[-1][2] == di:
            runs[-1] = (dj, runs[-1][1], runs[-1][2] + 1)
        else:
            runs.append((dj, di, 1))
    return tuple(runs)


@functools.cache
def _footprint(radius: float) -> tuple[tuple[tuple[tuple[int, int, int], ...], ...], int]:
    """The runs of the node stencil and of the edge stencils along DIRECTIONS[0..3] for a disc
    of `radius` (grid units), and the largest offset in them."""
    stencils = [_stencil(radius, (0, 0))] + [_stencil(radius, DIRECTIONS[d]) for d in range(4)]
    pad = max(max(abs(di), abs(dj)) for stencil in stencils for di, dj in stencil)
    return tuple(_runs(stencil) for stencil in stencils), pad


class _Dilation:
    """`hits(runs)[j, i]`: whether an occupied cell lies at (i, j) + some offset of a stencil.

    The occupancy is padded by `pad` free cells on every side, so every offset is a slice. A
    stencil is a union of horizontal runs; the OR over a run of width w is read from `_wide(w)`
    (the OR of w neighbouring cells along a row, built by doubling), so a stencil costs one array
    operation per row of it, however wide the rows are."""

    def __init__(self, occupied: np.ndarray, pad: int) -> None:
        rows, cols = occupied.shape
        self.rows, self.cols, self.pad = rows, cols, pad
        self.padded = np.zeros((rows + 2 * pad, cols + 2 * pad), dtype=np.bool_)
        self.padded[pad : pad + rows, pad : pad + cols] = occupied
        self._wide_cache: dict[int, np.ndarray] = {1: self.padded}

    def _wide(self, w: int) -> np.ndarray:
        """[y, x] = OR of padded[y, x : x + w]."""
        cached = self._wide_cache.get(w)
        if cached is not None:
            return cached
        p = 1 << (w.bit_length() - 1)  # the largest power of two <= w
        out: np.ndarray
        if p == w:
            half = self._wide(w // 2)
            out = half[:, : half.shape[1] - w // 2] | half[:, w // 2 :]
        else:
            base = self._wide(p)
            width = base.shape[1] - (w - p)
            out = base[:, :width] | base[:, w - p : w - p + width]
        self._wide_cache[w] = out
        return out

    def hits(self, runs: Iterable[tuple[int, int, int]]) -> np.ndarray:
        rows, cols, pad = self.rows, self.cols, self.pad
        out = np.zeros((rows, cols), dtype=np.bool_)
        for dj, di, w in runs:
            wide = self._wide(w)
            out |= wide[pad + dj : pad + dj + rows, pad + di : pad + di + cols]
        return out


def _expand(first: npt.NDArray[np.int64], count: npt.NDArray[np.int64]) -> tuple[np.ndarray, np.ndarray]:
    """For ranges [first[k], first[k] + count[k]): (k, value) for every value of every range."""
    owner = np.repeat(np.arange(len(first)), count)
    start = np.cumsum(count) - count
    return owner, first[owner] + (np.arange(owner.size) - start[owner])


def _obstacle_nodes(grid: Grid, obstacles: Iterable[Node]) -> tuple[frozenset[Node], np.ndarray]:
    """The obstacle nodes as a set and as an (m, 2) array of (i, j); ValueError or OffMap for a
    node that is not a pair of integers on the grid."""
    items = obstacles if isinstance(obstacles, list | tuple | set | frozenset) else list(obstacles)
    cols, rows = grid.cols, grid.rows
    # the usual case, checked at C speed: pairs (tuples) of ints
    if (
        set(map(type, items)) <= {tuple}
        and set(map(len, items)) <= {2}
        and set(map(type, itertools.chain.from_iterable(items))) <= {int}
    ):
        with contextlib.suppress(OverflowError):  # a huge int: off the grid, said below
            ij = np.fromiter(itertools.chain.from_iterable(items), np.int64, 2 * len(items)).reshape(-1, 2)
            off = (ij[:, 0] < 0) | (ij[:, 0] >= cols) | (ij[:, 1] < 0) | (ij[:, 1] >= rows)
            if not off.any():
                return frozenset(items), ij
    nodes = frozenset((i, j) for i, j in items)
    for i, j in nodes:
        if not (type(i) is int and type(j) is int):
            raise ValueError(f"obstacle nodes are pairs of integer indices, got ({i!r}, {j!r})")
        if not grid.has_node(i, j):
            raise OffMap(f"obstacle node ({i}, {j}) is not on the {cols} x {rows} grid")
    return nodes, np.array(sorted(nodes), dtype=np.int64).reshape(-1, 2)


class GridGraph:
    """The free nodes and free edges of a grid for a disc of a given radius (immutable).

    `occupied`, `free` (booleans) and `edges` (an 8-bit mask over DIRECTIONS) are numpy arrays
    indexed by node index k = i + j·cols. Built with whole-array operations: a node (an edge) is
    blocked when an obstacle lies at one of the offsets of a precomputed stencil, the cells whose
    squares the disc touches at the node (along the edge); each stencil is stamped as shifted
    copies of the occupancy grid, so the work grows with the grid and the stencils' rows, not
    with the number of obstacles.
    """

    def __init__(
        self,
        grid: Grid,
        obstacles: Iterable[Node],
        footprint_radius_m: float,
        blocked: npt.NDArray[np.bool_] | None = None,
        outside_blocked: bool = False,
    ) -> None:
        """`obstacles`: the user's obstacle nodes; `blocked`: more cells to keep off, (rows, cols)
        (a floor plan's walls and unknown space); `outside_blocked`: the cart's footprint must stay
        on the grid's cells (a floor plan, whose walls may lie at its edge), else only its centre
        (the seed's arena, whose walls lie a margin outside the nodes)."""
        r = footprint_radius_m
        if isinstance(r, bool) or not isinstance(r, int | float) or not math.isfinite(r) or r < 0:
            raise ValueError(f"footprint_radius_m must be a finite number >= 0, got {r!r}")
        if r > MAX_FOOTPRINT_STEPS * grid.step_m:
            # The clearance stencils grow with (radius / step)^2: refuse instead of exhausting memory.
            raise PlanError(
                f"the grid step {grid.step_m:g} m is too fine for the cart, which keeps {r:g} m "
                f"from obstacles: use a step of at least {r / MAX_FOOTPRINT_STEPS:g} m"
            )
        self.grid = grid
        self.footprint_radius_m = float(r)
        nodes, ij = _obstacle_nodes(grid, obstacles)
        cols, rows = grid.cols, grid.rows
        self.obstacles = nodes
        self.outside_blocked = bool(outside_blocked)
        self._r = self.footprint_radius_m / grid.step_m  # radius in grid units

        if blocked is None:
            occupied = np.zeros((rows, cols), dtype=np.bool_)
        else:
            if blocked.shape != (rows, cols):
                raise ValueError(f"blocked cells must be {rows} x {cols}, got {blocked.shape}")
            occupied = np.array(blocked, dtype=np.bool_)
        occupied[ij[:, 1], ij[:, 0]] = True
        self._any_occupied = bool(occupied.any())
        free = np.ones((rows, cols), dtype=np.bool_)
        edges = np.zeros((rows, cols), dtype=np.uint8)
        if self._any_occupied:
            (node_runs, *edge_runs), pad = _footprint(self._r)
            dilation = _Dilation(occupied, pad)
            free = ~dilation.hits(node_runs)
            passable = [~dilation.hits(runs) for runs in edge_runs]
        else:
            passable = [free] * 4
        if self.outside_blocked:
            # the disc on a node stays on the cells: the edges' nodes decide for the edges too
            # (the grid's rectangle is convex)
            i = np.arange(cols)
            j = np.arange(rows)
            free = free & self._inward(j)[:, None] & self._inward(i, cols)[None, :]
        for d in range(4):
            # the edge from (i, j) along DIRECTIONS[d] (bit d), and back (bit d + 4): both ends on
            # the grid and the swept disc clear (its stencil holds both ends' node stencils, so
            # both ends are free anyway)
            mi, mj = DIRECTIONS[d]
            src = (slice(0, rows - mj), slice(max(0, -mi), cols - max(0, mi)))
            dst = (slice(mj, rows), slice(max(0, mi), cols + min(0, mi)))
            ok = passable[d][src] & free[src] & free[dst]
            edges[src] |= ok.view(np.uint8) << d
            edges[dst] |= ok.view(np.uint8) << (d + 4)
        self.occupied: np.ndarray = occupied.reshape(-1)
        self.free: np.ndarray = free.reshape(-1)
        self.edges: np.ndarray = edges.reshape(-1)
        for array in (self.occupied, self.free, self.edges):
            array.flags.writeable = False
        self._occ = self.occupied.tobytes()  # for the per-cell loops of the segment checks
        self._free = self.free.tobytes()
        self._search: Any = None  # its search structure (search.py), built at the first search
        self._search_lock = threading.Lock()

    def _inward(self, u: np.ndarray, count: int | None = None) -> npt.NDArray[np.bool_]:
        """Whether coordinates u (grid units) keep the disc inside [-0.5, count - 0.5]."""
        n = self.grid.rows if count is None else count
        reach = self._r + EPS
        inward: npt.NDArray[np.bool_] = (u + 0.5 > reach) & (n - 0.5 - u > reach)
        return inward

    def _inside(self, u: float, v: float, margin: float = 0.0) -> bool:
        """Whether the disc (+ margin) at (u, v) stays on the grid's cells (always without
        outside_blocked)."""
        if not self.outside_blocked:
            return True
        reach = self._r + margin + EPS
        cols, rows = self.grid.cols, self.grid.rows
        return u + 0.5 > reach and cols - 0.5 - u > reach and v + 0.5 > reach and rows - 0.5 - v > reach

    # node queries

    def node_free(self, i: int, j: int) -> bool:
        return bool(self._free[self.grid.index(i, j)])

    def edge_free(self, a: Node, b: Node) -> bool:
        """Whether the graph has the edge between the neighbouring nodes a and b."""
        move = (b[0] - a[0], b[1] - a[1])
        if move not in DIRECTIONS:
            return False
        return bool(int(self.edges[self.grid.index(*a)]) >> DIRECTIONS.index(move) & 1)

    # geometry queries (metres)

    def point_free(self, x: float, y: float) -> bool:
        """Whether the cart's centre may be at (x, y): inside the map and clear of obstacles."""
        if not (math.isfinite(x) and math.isfinite(y) and self.grid.inside(x, y)):
            return False
        return self._point_clear(*self.grid.to_grid(x, y))

    def segment_free(self, a: Point, b: Point) -> bool:
        """Whether the cart may drive straight from a to b: both inside the map (then the whole
        segment is: the map is convex) and the swept disc clear of obstacles."""
        if not (self.point_free(*a) and self.point_free(*b)):
            return False
        return self._segment_clear(self.grid.to_grid(*a), self.grid.to_grid(*b))

    # the same in grid units, obstacles only (no map bounds)

    def _point_clear(self, u: float, v: float) -> bool:
        return self._segment_clear((u, v), (u, v))

    def _segment_clear(self, a: Point, b: Point, margin: float = 0.0) -> bool:
        """Whether the capsule of radius r (+ margin) around ab misses every obstacle square
        (grid units).

        Only the cells near the segment are visited: column by column, the rows that the
        segment, widened by r, can reach inside that column's slab. With outside_blocked the
        capsule must also stay on the grid's cells: it does when both ends do (convexity)."""
        if not (self._inside(*a, margin) and self._inside(*b, margin)):
            return False
        if not self._any_occupied:
            return True
        occ = self._occ
        cols, rows = self.grid.cols, self.grid.rows
        reach = self._r + margin + EPS
        reach2 = reach * reach
        pad = reach + 0.5 + 1e-7  # half a cell plus the radius, with room for rounding
        ax, ay = a
        bx, by = b
        dx, dy = bx - ax, by - ay
        i_lo = max(0, math.ceil(min(ax, bx) - pad))
        i_hi = min(cols - 1, math.floor(max(ax, bx) + pad))
        for i in range(i_lo, i_hi + 1):
            if dx == 0.0:
                y_lo, y_hi = min(ay, by), max(ay, by)
            else:
                t0 = (i - pad - ax) / dx
                t1 = (i + pad - ax) / dx
                if t0 > t1:
                    t0, t1 = t1, t0
                t0, t1 = max(t0, 0.0), min(t1, 1.0)
                if t0 > t1:
                    continue
                y0, y1 = ay + t0 * dy, ay + t1 * dy
                y_lo, y_hi = min(y0, y1), max(y0, y1)
            j_lo = max(0, math.ceil(y_lo - pad))
            j_hi = min(rows - 1, math.floor(y_hi + pad))
            for j in range(j_lo, j_hi + 1):
                if (
                    occ[i + j * cols]
                    and _segment_box_d2(ax, ay, bx, by, i - 0.5, i + 0.5, j - 0.5, j + 0.5) <= reach2
                ):
                    return False
        return True

    def _point_blockers(self, u: float, v: float) -> list[int]:
        """The indices of the occupied cells the disc at (u, v) touches (grid units), as
        _point_clear decides: what a refusal names."""
        occ = self._occ
        cols, rows = self.grid.cols, self.grid.rows
        reach = self._r + EPS
        pad = reach + 0.5 + 1e-7
        reach2 = reach * reach
        found = []
        for j in range(max(0, math.ceil(v - pad)), min(rows - 1, math.floor(v + pad)) + 1):
            for i in range(max(0, math.ceil(u - pad)), min(cols - 1, math.floor(u + pad)) + 1):
                k = i + j * cols
                if occ[k] and _segment_box_d2(u, v, u, v, i - 0.5, i + 0.5, j - 0.5, j + 0.5) <= reach2:
                    found.append(k)
        return found

    def _segments_clear(self, a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
        """_segment_clear for many segments at once (arrays of shape (m, 2)): the same cells, the
        same decisions."""
        m = len(a)
        if m == 0:
            return np.ones(0, dtype=np.bool_)
        if m <= _FEW_SEGMENTS:  # faster one by one
            return np.array([self._segment_clear(p, q) for p, q in zip(a.tolist(), b.tolist(), strict=True)])
        inside = np.ones(m, dtype=np.bool_)
        if self.outside_blocked:
            cols, rows = self.grid.cols, self.grid.rows
            for ends in (a, b):
                inside &= self._inward(ends[:, 0], cols) & self._inward(ends[:, 1], rows)
        if not self._any_occupied:
            return inside
        cols, rows = self.grid.cols, self.grid.rows
        reach = self._r + EPS
        reach2 = reach * reach
        pad = reach + 0.5 + 1e-7
        ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
        # the columns of each segment
        i_lo = np.maximum(np.ceil(np.minimum(ax, bx) - pad), 0).astype(np.int64)
        i_hi = np.minimum(np.floor(np.maximum(ax, bx) + pad), cols - 1).astype(np.int64)
        seg, col = _expand(i_lo, np.maximum(i_hi - i_lo + 1, 0))
        sax, say, sbx, sby = ax[seg], ay[seg], bx[seg], by[seg]
        dx, dy = sbx - sax, sby - say
        # the rows that the segment widened by r reaches in each column's slab
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = (col - pad - sax) / dx
            t1 = (col + pad - sax) / dx
        t0, t1 = np.maximum(np.minimum(t0, t1), 0.0), np.minimum(np.maximum(t0, t1), 1.0)
        y0, y1 = say + t0 * dy, say + t1 * dy
        upright = dx == 0.0
        y_lo = np.where(upright, np.minimum(say, sby), np.minimum(y0, y1))
        y_hi = np.where(upright, np.maximum(say, sby), np.maximum(y0, y1))
        j_lo = np.maximum(np.ceil(y_lo - pad), 0).astype(np.int64)
        j_hi = np.minimum(np.floor(y_hi + pad), rows - 1).astype(np.int64)
        count = np.where(upright | (t0 <= t1), np.maximum(j_hi - j_lo + 1, 0), 0)
        cell, row = _expand(j_lo, count)
        col, seg = col[cell], seg[cell]
        # the occupied ones: a square lies between 1/2 and √2/2 from its centre, so the distance
        # to the centre decides most of them; the exact distance decides the rest (the margins
        # of 1e-9 leave every close call to it, so the decisions are the exact ones)
        hit = np.flatnonzero(self.occupied[col + row * cols])
        seg, ci, cj = seg[hit], col[hit].astype(np.float64), row[hit].astype(np.float64)
        centre = np.sqrt(_point_segment_d2_v(ci, cj, ax[seg], ay[seg], bx[seg], by[seg]))
        clear = np.ones(m, dtype=np.bool_)
        clear[seg[centre <= reach + 0.5 - 1e-9]] = False
        close = np.flatnonzero((centre < reach + SQRT2 / 2 + 1e-9) & clear[seg])
        seg, ci, cj = seg[close], ci[close], cj[close]
        d2 = _segment_box_d2_v(ax[seg], ay[seg], bx[seg], by[seg], ci - 0.5, ci + 0.5, cj - 0.5, cj + 0.5)
        clear[seg[d2 <= reach2]] = False
        return clear & inside

    def _connections(self, u: float, v: float) -> dict[int, float]:
        """Free nodes within √2 steps of (u, v) (grid units) seen through a free segment, with
        the segment's length in metres."""
        reach = SQRT2 + EPS
        cols, rows = self.grid.cols, self.grid.rows
        out: dict[int, float] = {}
        for j in range(max(0, math.ceil(v - reach)), min(rows - 1, math.floor(v + reach)) + 1):
            for i in range(max(0, math.ceil(u - reach)), min(cols - 1, math.floor(u + reach)) + 1):
                k = i + j * cols
                d = math.hypot(i - u, j - v)
                if d <= reach and self._free[k] and self._segment_clear((u, v), (i, j)):
                    out[k] = d * self.grid.step_m
        return out
