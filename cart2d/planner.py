"""Path planner: the seed's "Fixed Graph", done right.

The floor is a grid of nodes `step_m` apart; an obstacle occupies its node's cell (a square of
side `step_m` centred on the node). The cart is a disc of radius `footprint_radius_m`:

- a point is free when the disc centred on it touches no obstacle square (exact disc-square
  distance), and it lies inside the map rectangle spanned by the nodes;
- a straight segment is free when the swept disc (a capsule) touches no obstacle square (exact
  segment-square distance); touching counts as a collision, so with radius 0 a diagonal between
  two obstacles that meet at a corner is blocked (no corner cutting).

The graph holds the free nodes, 8-connected with their true lengths (step, step·√2); an edge
exists only if its segment is free. A plan starts at the cart's measured pose (not at a node,
not at the previous goal) and ends exactly at the requested goal: both connect to the free
nodes within √2·step that they see through a free segment. Dijkstra finds the optimal grid
path; it is then simplified into a few straight segments, each of them checked free: collinear
points are dropped, then the string is pulled (from each point kept, on to the farthest later
point such that it and every point before it are reached by a free segment), then the path is
pulled taut off the nodes (each corner slides towards its neighbours' chord while its segments
stay free; sharp bends get two more corners, twice), so that it hugs the obstacles as the true
shortest path does: within 4 % of it on the benchmark scenes, where the pulled path was up to
16 % longer.

Nothing here does I/O or knows the robot beyond the numbers passed in. The graph (`GridGraph`)
is built with numpy whole-array operations and searched (`shortest_path`) by scipy's compiled
Dijkstra, so a 1000 x 1000 grid plans in a fraction of a second (`python -m bench.planner`); the
exact geometry of a single point or segment stays in plain Python (a small map needs only a few
checks, and they are faster that way), with an array version for the many checks of long paths.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_array
from scipy.sparse.csgraph import dijkstra

Point = tuple[float, float]
Node = tuple[int, int]

SQRT2 = math.sqrt(2.0)
# Contact tolerance in grid units (fractions of a step): a clearance within EPS of the radius
# counts as touching (blocked). It absorbs rounding, so exact ties (radius 0 at a shared corner,
# radius = half a step next to an obstacle) are decided the same way everywhere.
EPS = 1e-9

# The 8 moves, counter-clockwise from +x. Bit d of a node's edge mask = the move DIRECTIONS[d]
# is an edge; the opposite move is (d + 4) % 8.
DIRECTIONS: tuple[Node, ...] = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))


class PlanError(ValueError):
    """A plan or map request that cannot be honoured; the message says why, for a person."""


class OffMap(PlanError):
    """A point outside the map (or not a finite point)."""


class GoalBlocked(PlanError):
    """The goal is inside an obstacle or closer to one than the cart's footprint allows."""


class StartBlocked(PlanError):
    """The cart's measured position is inside an obstacle or too close to one."""


class Unreachable(PlanError):
    """No free path joins the start and the goal."""


def _fmt(x: float, y: float) -> str:
    return f"({x:.3f}, {y:.3f})"


def _finite(x: float, y: float, what: str) -> None:
    if not (math.isfinite(x) and math.isfinite(y)):
        raise OffMap(f"{what} ({x}, {y}) is not a finite point")


@dataclass(frozen=True)
class Grid:
    """Nodes at origin + (i·step, j·step), i in [0, cols), j in [0, rows); node index i + j·cols."""

    cols: int = 10
    rows: int = 10
    step_m: float = 0.2
    origin: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("cols", "rows"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 2:
                raise ValueError(f"grid {name} must be an integer >= 2, got {value!r}")
        step = self.step_m
        if (
            isinstance(step, bool)
            or not isinstance(step, int | float)
            or not math.isfinite(step)
            or step <= 0
        ):
            raise ValueError(f"grid step_m must be a finite number > 0, got {step!r}")
        try:
            ox, oy = (float(c) for c in self.origin)
        except (TypeError, ValueError):
            raise ValueError(f"grid origin must be a pair of numbers, got {self.origin!r}") from None
        if not (math.isfinite(ox) and math.isfinite(oy)):
            raise ValueError(f"grid origin must be finite, got {self.origin!r}")
        object.__setattr__(self, "step_m", float(step))
        object.__setattr__(self, "origin", (ox, oy))

    @property
    def node_count(self) -> int:
        return self.cols * self.rows

    @property
    def size_m(self) -> tuple[float, float]:
        """Width and height of the rectangle spanned by the nodes."""
        return ((self.cols - 1) * self.step_m, (self.rows - 1) * self.step_m)

    def has_node(self, i: int, j: int) -> bool:
        return 0 <= i < self.cols and 0 <= j < self.rows

    def index(self, i: int, j: int) -> int:
        if not self.has_node(i, j):
            raise OffMap(f"node ({i}, {j}) is not on the {self.cols} x {self.rows} grid")
        return i + j * self.cols

    def node(self, index: int) -> Node:
        if not 0 <= index < self.node_count:
            raise OffMap(f"node index {index} is not on the {self.cols} x {self.rows} grid")
        return (index % self.cols, index // self.cols)

    def node_xy(self, i: int, j: int) -> Point:
        """The node's position in metres."""
        return (self.origin[0] + i * self.step_m, self.origin[1] + j * self.step_m)

    def to_grid(self, x: float, y: float) -> Point:
        """A point in grid units: node (i, j) is at (i, j)."""
        return ((x - self.origin[0]) / self.step_m, (y - self.origin[1]) / self.step_m)

    def inside(self, x: float, y: float) -> bool:
        """Whether (x, y) lies in the rectangle spanned by the nodes (where the cart's centre may go)."""
        u, v = self.to_grid(x, y)
        return -EPS <= u <= self.cols - 1 + EPS and -EPS <= v <= self.rows - 1 + EPS

    def on_map(self, x: float, y: float) -> bool:
        """Whether (x, y) is within half a step of the outer nodes (it has a nearest node)."""
        u, v = self.to_grid(x, y)
        return -0.5 - EPS <= u <= self.cols - 0.5 + EPS and -0.5 - EPS <= v <= self.rows - 0.5 + EPS

    def bounds_text(self, margin_m: float = 0.0) -> str:
        (x0, y0), (w, h) = self.origin, self.size_m
        m = margin_m
        return f"x {x0 - m:.3f}..{x0 + w + m:.3f} m, y {y0 - m:.3f}..{y0 + h + m:.3f} m"

    def nearest_node(self, x: float, y: float) -> Node:
        """The node nearest to (x, y) (ties round towards +x, +y); OffMap beyond half a step out."""
        _finite(x, y, "the point")
        if not self.on_map(x, y):
            raise OffMap(
                f"the point {_fmt(x, y)} is off the map: it must lie within "
                f"{self.bounds_text(self.step_m / 2)} (half a step around the grid's nodes)"
            )
        u, v = self.to_grid(x, y)
        i = min(max(math.floor(u + 0.5 + EPS), 0), self.cols - 1)
        j = min(max(math.floor(v + 0.5 + EPS), 0), self.rows - 1)
        return (i, j)


# --- exact geometry (any consistent unit; the planner uses grid units) -------------------------


def point_square_distance(p: Point, centre: Point, half_side: float) -> float:
    """Distance from p to the closed axis-aligned square (0 inside it)."""
    dx = max(abs(p[0] - centre[0]) - half_side, 0.0)
    dy = max(abs(p[1] - centre[1]) - half_side, 0.0)
    return math.hypot(dx, dy)


def _point_segment_d2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    return ex * ex + ey * ey


def point_segment_distance(p: Point, a: Point, b: Point) -> float:
    """Distance from p to the segment ab."""
    return math.sqrt(_point_segment_d2(p[0], p[1], a[0], a[1], b[0], b[1]))


def point_polyline_distance(p: Point, line: Sequence[Point]) -> float:
    """Distance from p to the nearest point of a polyline (of one point or more)."""
    if len(line) == 1:
        return math.dist(p, line[0])
    return min(point_segment_distance(p, a, b) for a, b in itertools.pairwise(line))


def _point_box_d2(px: float, py: float, x0: float, x1: float, y0: float, y1: float) -> float:
    dx = x0 - px if px < x0 else (px - x1 if px > x1 else 0.0)
    dy = y0 - py if py < y0 else (py - y1 if py > y1 else 0.0)
    return dx * dx + dy * dy


def _segment_meets_box(
    ax: float, ay: float, bx: float, by: float, x0: float, x1: float, y0: float, y1: float
) -> bool:
    """Liang-Barsky: does the segment share a point with the closed box?"""
    t0, t1 = 0.0, 1.0
    dx, dy = bx - ax, by - ay
    for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
        if p == 0.0:
            if q < 0.0:
                return False
        else:
            t = q / p
            if p < 0.0:
                t0 = max(t0, t)
            else:
                t1 = min(t1, t)
            if t0 > t1:
                return False
    return True


def _segment_box_d2(
    ax: float, ay: float, bx: float, by: float, x0: float, x1: float, y0: float, y1: float
) -> float:
    if _segment_meets_box(ax, ay, bx, by, x0, x1, y0, y1):
        return 0.0
    # Disjoint convex sets: the closest pair includes a vertex of one of them.
    return min(
        _point_box_d2(ax, ay, x0, x1, y0, y1),
        _point_box_d2(bx, by, x0, x1, y0, y1),
        _point_segment_d2(x0, y0, ax, ay, bx, by),
        _point_segment_d2(x1, y0, ax, ay, bx, by),
        _point_segment_d2(x0, y1, ax, ay, bx, by),
        _point_segment_d2(x1, y1, ax, ay, bx, by),
    )


def segment_square_distance(a: Point, b: Point, centre: Point, half_side: float) -> float:
    """Exact distance between the segment ab and the closed axis-aligned square (0 if they meet)."""
    cx, cy = centre
    h = half_side
    return math.sqrt(_segment_box_d2(a[0], a[1], b[0], b[1], cx - h, cx + h, cy - h, cy + h))


# the same, elementwise over arrays (the same operations in the same order, so the same results)

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.int32]


def _point_segment_d2_v(
    px: FloatArray, py: FloatArray, ax: FloatArray, ay: FloatArray, bx: FloatArray, by: FloatArray
) -> FloatArray:
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.minimum(np.maximum(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    t = np.where(length2 == 0.0, 0.0, t)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    out: FloatArray = ex * ex + ey * ey
    return out


def _point_box_d2_v(
    px: FloatArray, py: FloatArray, x0: FloatArray, x1: FloatArray, y0: FloatArray, y1: FloatArray
) -> FloatArray:
    dx = np.where(px < x0, x0 - px, np.where(px > x1, px - x1, 0.0))
    dy = np.where(py < y0, y0 - py, np.where(py > y1, py - y1, 0.0))
    out: FloatArray = dx * dx + dy * dy
    return out


def _segment_box_d2_v(
    ax: FloatArray,
    ay: FloatArray,
    bx: FloatArray,
    by: FloatArray,
    x0: FloatArray,
    x1: FloatArray,
    y0: FloatArray,
    y1: FloatArray,
) -> FloatArray:
    dx, dy = bx - ax, by - ay
    # Liang-Barsky as in _segment_meets_box: t0 only grows and t1 only shrinks, so testing
    # t0 > t1 once at the end decides as the early returns do
    t0 = np.zeros_like(ax)
    t1 = np.ones_like(ax)
    outside = np.zeros(ax.shape, dtype=np.bool_)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
            outside |= (p == 0.0) & (q < 0.0)
            t = q / p
            t0 = np.where(p < 0.0, np.maximum(t0, t), t0)
            t1 = np.where(p > 0.0, np.minimum(t1, t), t1)
    meets = ~outside & (t0 <= t1)
    d2 = np.minimum.reduce(
        [
            _point_box_d2_v(ax, ay, x0, x1, y0, y1),
            _point_box_d2_v(bx, by, x0, x1, y0, y1),
            _point_segment_d2_v(x0, y0, ax, ay, bx, by),
            _point_segment_d2_v(x1, y0, ax, ay, bx, by),
            _point_segment_d2_v(x0, y1, ax, ay, bx, by),
            _point_segment_d2_v(x1, y1, ax, ay, bx, by),
        ]
    )
    out: FloatArray = np.where(meets, 0.0, d2)
    return out


# --- the graph ---------------------------------------------------------------------------------


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

    def __init__(self, grid: Grid, obstacles: Iterable[Node], footprint_radius_m: float) -> None:
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
        self._r = self.footprint_radius_m / grid.step_m  # radius in grid units

        occupied = np.zeros((rows, cols), dtype=np.bool_)
        occupied[ij[:, 1], ij[:, 0]] = True
        free = np.ones((rows, cols), dtype=np.bool_)
        edges = np.zeros((rows, cols), dtype=np.uint8)
        if nodes:
            (node_runs, *edge_runs), pad = _footprint(self._r)
            dilation = _Dilation(occupied, pad)
            free = ~dilation.hits(node_runs)
            passable = [~dilation.hits(runs) for runs in edge_runs]
        else:
            passable = [free] * 4
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
        self._search: _Search | None = None
        self._search_lock = threading.Lock()

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
        segment, widened by r, can reach inside that column's slab."""
        if not self.obstacles:
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

    def _segments_clear(self, a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
        """_segment_clear for many segments at once (arrays of shape (m, 2)): the same cells, the
        same decisions."""
        m = len(a)
        if not self.obstacles or m == 0:
            return np.ones(m, dtype=np.bool_)
        if m <= _FEW_SEGMENTS:  # faster one by one
            return np.array([self._segment_clear(p, q) for p, q in zip(a.tolist(), b.tolist(), strict=True)])
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
        return clear

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

    def _searcher(self) -> _Search:
        with self._search_lock:
            if self._search is None:
                self._search = _Search(self)
            return self._search


# --- the search --------------------------------------------------------------------------------

# _DIRECTION_RANK[mask, r]: the direction of the r-th set bit of an edge mask
_DIRECTION_RANK = np.array(
    [[d for d in range(8) if mask >> d & 1] + [0] * (8 - mask.bit_count()) for mask in range(256)],
    dtype=np.intp,
).reshape(-1)


class _Search:
    """The graph in compressed sparse rows for scipy's Dijkstra, plus one virtual source node
    (index node_count) whose edges to the start's nodes are rewritten for every search."""

    def __init__(self, graph: GridGraph) -> None:
        grid = graph.grid
        n = grid.node_count
        edges = graph.edges
        count = np.bitwise_count(edges)
        nnz = int(count.sum(dtype=np.int64))
        self.n, self.nnz = n, nnz
        # scipy's own index type, so that it copies nothing (larger graphs would not fit in memory)
        if nnz + n + 64 >= 2**31:
            raise PlanError(f"the grid of {grid.cols} x {grid.rows} nodes is too large to search")
        self.indptr: IndexArray = np.empty(n + 2, dtype=np.int32)
        self.indptr[0] = 0
        np.cumsum(count, out=self.indptr[1 : n + 1])
        # row k: the edges of node k in DIRECTIONS order (the r-th is its mask's r-th set bit)
        node = np.repeat(np.arange(n, dtype=np.int32), count)
        rank = np.arange(nnz, dtype=np.int32) - self.indptr[node]
        d = _DIRECTION_RANK[edges[node].astype(np.intp) * 8 + rank]
        offsets = np.array([di + dj * grid.cols for di, dj in DIRECTIONS], dtype=np.int32)
        lengths = np.array([grid.step_m * (SQRT2 if di and dj else 1.0) for di, dj in DIRECTIONS])
        self.slots = 9  # the virtual source's: the nodes within √2 steps of a point, at most 3 x 3
        self.indices: IndexArray = np.empty(nnz + self.slots, dtype=np.int32)
        np.add(node, offsets[d], out=self.indices[:nnz])
        self.data: FloatArray = np.empty(nnz + self.slots, dtype=np.float64)
        np.take(lengths, d, out=self.data[:nnz], mode="clip")  # (unbuffered)
        self.indptr[n + 1] = nnz + self.slots
        self.matrix = csr_array((self.data, self.indices, self.indptr), shape=(n + 1, n + 1))
        self.lock = threading.Lock()

    def _reserve(self, slots: int) -> None:
        """Room for `slots` edges of the virtual source (a caller of shortest_path may give many)."""
        if slots > self.slots:
            n, nnz = self.n, self.nnz
            self.indices = np.concatenate((self.indices[:nnz], np.empty(slots, np.int32)))
            self.data = np.concatenate((self.data[:nnz], np.empty(slots)))
            self.indptr[n + 1] = nnz + slots
            self.matrix = csr_array((self.data, self.indices, self.indptr), shape=(n + 1, n + 1))
            self.slots = slots

    def run(self, sources: Mapping[int, float], limit: float) -> tuple[FloatArray, IndexArray]:
        """Distances (metres) and predecessors from the virtual source, up to `limit`."""
        n, nnz = self.n, self.nnz
        with self.lock:
            self._reserve(len(sources))
            # unused slots: self-loops of infinite length
            self.indices[nnz:] = n
            self.data[nnz:] = math.inf
            for slot, (k, cost) in enumerate(sources.items()):
                self.indices[nnz + slot] = k
                self.data[nnz + slot] = cost
            dist, pred = dijkstra(self.matrix, indices=[n], return_predecessors=True, limit=limit)
        return dist[0], pred[0]


def _search(
    graph: GridGraph,
    sources: Mapping[int, float],
    targets: Mapping[int, float],
    bound: float,
    hint: float,
) -> tuple[float, np.ndarray] | None:
    """shortest_path, with the node path as an array. `hint` (metres): a guess of the cost within
    which the search may first look (cheaper for near targets on a large map)."""
    if not sources or not targets:
        return None
    search = graph._searcher()
    n = graph.grid.node_count
    limits = [bound] if hint >= bound else [hint, bound]
    for limit in limits:
        dist, pred = search.run(sources, limit)
        best, best_k = math.inf, -1
        for k, final in targets.items():
            total = float(dist[k]) + final
            if total < best:
                best, best_k = total, k
        # every route cheaper than the limit was explored, so a total below it is the optimum
        if best < limit:
            break
    else:
        return None
    path = []
    k = best_k
    while k != n:
        path.append(k)
        k = int(pred[k])
    return best, np.array(path[::-1], dtype=np.int64)


def shortest_path(
    graph: GridGraph, sources: Mapping[int, float], targets: Mapping[int, float], bound: float = math.inf
) -> tuple[float, list[int]] | None:
    """Dijkstra from several source nodes (each with a starting cost) to the cheapest of several
    target nodes (each with a final cost): (total cost, node indices from a source to a target),
    or None when no route is cheaper than `bound`."""
    found = _search(graph, sources, targets, bound, bound)
    if found is None:
        return None
    return found[0], found[1].tolist()


# --- plans -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Plan:
    """A path from the cart's measured position to the goal, in metres.

    `path`: the optimal grid path (start, nodes, goal); `waypoints`: the simplified path the cart
    drives in straight lines (without the start, ending exactly at the goal); their lengths."""

    start: Point
    goal: Point
    path: tuple[Point, ...]
    waypoints: tuple[Point, ...]
    grid_length_m: float
    length_m: float


def polyline_length(points: Sequence[Point] | np.ndarray) -> float:
    """The length of the polyline through the points (0 for fewer than two)."""
    steps = np.diff(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    return math.fsum(np.hypot(steps[:, 0], steps[:, 1]).tolist())


def _drop_collinear(points: np.ndarray) -> np.ndarray:
    """Indices of the points that remain once repeated points and straight-through points are
    dropped (the first and last always remain)."""
    u = points[1:-1] - points[:-2]  # into each inner point
    v = points[2:] - points[1:-1]  # out of it
    nu, nv = np.hypot(u[:, 0], u[:, 1]), np.hypot(v[:, 0], v[:, 1])
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    dot = u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1]
    through = (np.abs(cross) <= 1e-12 * nu * nv) & (dot > 0.0)
    turns = np.flatnonzero(~((nu == 0.0) | (nv == 0.0) | through)) + 1
    return np.concatenate(([0], turns, [len(points) - 1]))


# String pulling looks this many points ahead: from each point kept, on to the farthest of the
# next _PULL_WINDOW points that it reaches by a free segment; and when it reaches them all, on
# along the path as long as it reaches every point. On a path of up to _PULL_WINDOW + 1 points
# that is the farthest point reached, as the planner always did; on longer paths too, in practice
# (a point seen again after one hidden comes within a few points): on 300 random plans of 10 x 10
# to 41 x 41 nodes, of up to 21 points, a window of 6 already gave the same waypoints.
_PULL_WINDOW = 8
_PULL_CELLS = 1 << 20  # cells visited per array check, about (bounds the memory)


def _clear_all(graph: GridGraph, a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
    """graph._segments_clear, in chunks of about _PULL_CELLS cells."""
    band = 2.0 * graph._r + 3.0  # the width of a segment's band of cells, about
    size = (np.maximum(np.abs(b[:, 0] - a[:, 0]), np.abs(b[:, 1] - a[:, 1])) + band) * band
    ends = np.searchsorted(np.cumsum(size), np.arange(1, int(size.sum() // _PULL_CELLS) + 1) * _PULL_CELLS)
    cuts = [0, *np.unique(np.maximum(ends, 1)).tolist(), len(a)]
    return np.concatenate(
        [graph._segments_clear(a[i:j], b[i:j]) for i, j in itertools.pairwise(cuts) if j > i]
        or [np.ones(0, dtype=np.bool_)]
    )


def _string_pull(graph: GridGraph, points: FloatArray) -> list[int]:
    """The indices of the points (grid units) kept: from each point kept, on to the farthest of
    the next _PULL_WINDOW points that it reaches by a free segment, or, when it reaches them all,
    on along the path while it reaches every point. Consecutive points are joined by free grid
    edges or connections, so a point always reaches the next one.

    The segments are checked as arrays, for all the points at once: first, in rounds, how far
    along the path each point reaches every point; then, for the points that stop short of their
    window's end, the later points of the window."""
    last = len(points) - 1
    index = np.arange(last + 1)
    # sees[k]: k reaches k + 1 .. k + sees[k]
    sees = np.ones(last + 1, dtype=np.int64)
    open_ = index[: max(last - 1, 0)]  # the points that may reach farther
    t = 2
    while open_.size and t <= _PULL_WINDOW:
        open_ = open_[_clear_all(graph, points[open_], points[open_ + t])]
        sees[open_] = t
        open_ = open_[open_ + t < last]
        t += 1
    onward = np.zeros(last + 1, dtype=np.bool_)
    onward[open_] = True  # reaches its whole window, and the path goes on
    far = index + sees
    # beyond the first point that k does not reach: the rest of its window
    first = far + 2  # the first candidate after the point not reached
    count = np.maximum(np.minimum(index + _PULL_WINDOW, last) - first + 1, 0)
    owner, later = _expand(first, count)
    clear = _clear_all(graph, points[owner], points[later])
    np.maximum.at(far, owner[clear], later[clear])
    keep = [0]
    i = 0
    while i < last:
        j = int(far[i])
        batch = 8
        while onward[i] and j < last:
            ahead = np.arange(j + 1, min(j + batch, last) + 1)
            clear = _clear_all(graph, np.broadcast_to(points[i], (len(ahead), 2)), points[ahead])
            if not clear.all():
                j = int(ahead[np.argmin(clear)]) - 1
                break
            j = int(ahead[-1])
            batch *= 2
        keep.append(j)
        i = j
    return keep


# Tightening: at most this many sweeps over the corners, each corner found by this many halvings;
# paths with more corners than _TIGHTEN_MAX (mazes, not a path the cart can hold) stay as pulled.
_TIGHTEN_SWEEPS = 30
_TIGHTEN_HALVINGS = 8
_TIGHTEN_MAX = 100
_TIGHTEN_MARGIN = 1e-4  # grid units


def _slide(pts: list[Point], k: int, clear: Callable[[Point, Point], bool]) -> float:
    """Slides corner k towards the chord of its neighbours as far as both of its segments stay
    free (deleting it when it reaches the chord); returns how far it moved."""
    (ax, ay), (vx, vy), (bx, by) = pts[k - 1], pts[k], pts[k + 1]
    dx, dy = bx - ax, by - ay
    span = dx * dx + dy * dy
    t = 0.0 if span == 0.0 else min(1.0, max(0.0, ((vx - ax) * dx + (vy - ay) * dy) / span))
    px, py = ax + t * dx, ay + t * dy  # the nearest point of the chord
    if clear(pts[k - 1], (px, py)) and clear((px, py), pts[k + 1]):
        del pts[k]
        return math.hypot(px - vx, py - vy)
    lo, hi = 0.0, 1.0
    for _ in range(_TIGHTEN_HALVINGS):
        mid = (lo + hi) / 2
        q = (vx + mid * (px - vx), vy + mid * (py - vy))
        if clear(pts[k - 1], q) and clear(q, pts[k + 1]):
            lo = mid
        else:
            hi = mid
    if lo > 0.0:
        pts[k] = (vx + lo * (px - vx), vy + lo * (py - vy))
    return lo * math.hypot(px - vx, py - vy)


def _clear_with_margin(graph: GridGraph) -> Callable[[Point, Point], bool]:
    # a hair more than the radius: a corner pulled up to the obstacle must stay free whatever
    # the rounding of any later check
    return functools.partial(graph._segment_clear, margin=_TIGHTEN_MARGIN)


def _tighten(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The pulled path (grid units) pulled taut: each corner slides towards the chord of its
    neighbours as far as both of its segments stay free, sweep after sweep, until nothing moves
    by more than a hundredth of a step. Every move shortens the path (the two segments' length
    only falls on the way to the chord), and a corner that reaches the chord is dropped. Grid
    corners sit on nodes, up to a step further from the obstacles than the disc needs: taut, the
    path touches them as the true shortest path does, only with one corner per bend."""
    pts = list(points)
    if len(pts) < 3 or len(pts) > _TIGHTEN_MAX:
        return pts
    clear = _clear_with_margin(graph)
    for _ in range(_TIGHTEN_SWEEPS):
        moved = 0.0
        k = 1
        while k < len(pts) - 1:
            before = len(pts)
            moved = max(moved, _slide(pts, k, clear))
            k += len(pts) == before  # a deleted corner's successor is now at k
        if moved < 1e-2:
            break
    return pts


# A bend sharper than this gets two more corners before it is pulled taut again, twice over: one
# corner per bend leaves the path up to r (2 tan(a/2) - a) longer than the arc of radius r it
# stands for (9 cm for r = 0.2 m and a = 90 deg); three corners leave less than a centimetre.
_BEND_RAD = math.radians(30.0)
_BEND_ROUNDS = 2
_BEND_SHARE = 0.3  # where the new corners go: this share of each segment from the bend
# Corners are added for length only while the path keeps at most this many points, so that it
# still goes to the firmware in one piece (it holds 32) with room for rounded corners.
_SPLIT_MAX = 24


def _split_bends(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The points with two more on the segments next to every bend sharper than _BEND_RAD; the
    bend itself then slides towards the chord of the new pair (before anything else can: the
    new points lie on the old segments, so a sweep would drop them at once). The points as they
    are if that would make more than _SPLIT_MAX."""
    out = [points[0]]
    bends = []
    for k in range(1, len(points) - 1):
        (ax, ay), (vx, vy), (bx, by) = points[k - 1], points[k], points[k + 1]
        ux, uy, wx, wy = vx - ax, vy - ay, bx - vx, by - vy
        cos_turn = (ux * wx + uy * wy) / max(math.hypot(ux, uy) * math.hypot(wx, wy), 1e-12)
        if cos_turn < math.cos(_BEND_RAD):
            out.append((vx - _BEND_SHARE * ux, vy - _BEND_SHARE * uy))
            bends.append(len(out))
            out += [points[k], (vx + _BEND_SHARE * wx, vy + _BEND_SHARE * wy)]
        else:
            out.append(points[k])
    out.append(points[-1])
    if len(out) > _SPLIT_MAX:
        return points
    clear = _clear_with_margin(graph)
    for k in reversed(bends):  # from the end: a deletion does not shift the bends before it
        _slide(out, k, clear)
    return out


def _taut(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The pulled path pulled taut, its sharp bends given more corners so that they wrap the
    obstacles' rounded corners closely (see _tighten and _split_bends)."""
    pts = _tighten(graph, points)
    for _ in range(_BEND_ROUNDS):
        split = _split_bends(graph, pts)
        if len(split) == len(pts):
            break
        pts = _tighten(graph, split)
    return pts


def simplify(graph: GridGraph, path_g: FloatArray) -> FloatArray:
    """A grid path (grid units) with as few corners as stay clear: collinear nodes dropped, the
    rest string-pulled, then pulled taut off the nodes."""
    kept = _drop_collinear(path_g)
    pulled = kept[_string_pull(graph, path_g[kept])]
    return np.array(_taut(graph, [(float(u), float(v)) for u, v in path_g[pulled]]))


def plan_path(graph: GridGraph, start: Point, goal: Point) -> Plan:
    """The shortest grid path from the measured `start` to the exact `goal` (metres), and its
    simplification. Raises OffMap, StartBlocked, GoalBlocked or Unreachable; changes nothing."""
    grid = graph.grid
    sx, sy = float(start[0]), float(start[1])
    gx, gy = float(goal[0]), float(goal[1])
    r = graph.footprint_radius_m
    _finite(sx, sy, "the cart's position")
    _finite(gx, gy, "the goal")
    # The measured position may stray a little outside the node rectangle (odometry noise at an
    # edge node): accept it up to half a step out, as for obstacles.
    if not grid.on_map(sx, sy):
        raise OffMap(
            f"the cart's position {_fmt(sx, sy)} is off the map: it must lie within "
            f"{grid.bounds_text(grid.step_m / 2)}"
        )
    if not grid.inside(gx, gy):
        raise OffMap(
            f"the goal {_fmt(gx, gy)} is off the map: the cart's centre must stay within {grid.bounds_text()}"
        )
    s, g = grid.to_grid(sx, sy), grid.to_grid(gx, gy)
    if not graph._point_clear(*s):
        raise StartBlocked(
            f"the cart's position {_fmt(sx, sy)} is inside an obstacle or too close to one for the "
            f"cart, which keeps {r:g} m from obstacles: remove that obstacle or move the cart"
        )
    if not graph._point_clear(*g):
        raise GoalBlocked(
            f"the goal {_fmt(gx, gy)} is inside an obstacle or too close to one "
            f"for the cart, which keeps {r:g} m from obstacles"
        )

    direct_m = math.dist((sx, sy), (gx, gy))
    # The goal is one more neighbour of the start when it lies as close as the start's nodes do.
    near = math.dist(s, g) <= SQRT2 + EPS and graph._segment_clear(s, g)
    bound = direct_m if near else math.inf
    # Search first within twice the octile distance (plus the ends): most goals are reached
    # without visiting the whole map; the search widens only when that finds nothing.
    du, dv = abs(g[0] - s[0]), abs(g[1] - s[1])
    hint = 2.0 * (max(du, dv) + (SQRT2 - 1.0) * min(du, dv) + 4.0) * grid.step_m
    found = _search(graph, graph._connections(*s), graph._connections(*g), bound, hint)
    if found is not None:
        nodes = found[1]
        ij = np.column_stack((nodes % grid.cols, nodes // grid.cols)).astype(np.float64)
        path_g = np.vstack((s, ij, g))
        path_m = np.vstack(((sx, sy), np.asarray(grid.origin) + ij * grid.step_m, (gx, gy)))
        # a node that is the start or the goal itself appears once, as the exact point
        if math.dist(path_g[0], path_g[1]) <= EPS:
            path_g, path_m = np.delete(path_g, 1, axis=0), np.delete(path_m, 1, axis=0)
        if len(path_g) > 2 and math.dist(path_g[-2], path_g[-1]) <= EPS:
            path_g, path_m = np.delete(path_g, -2, axis=0), np.delete(path_m, -2, axis=0)
    elif near or graph._segment_clear(s, g):
        # in sight: the straight segment (also when no grid route exists, e.g. a pocket)
        path_g, path_m = np.array([s, g]), np.array([(sx, sy), (gx, gy)])
    else:
        raise Unreachable(
            f"the goal {_fmt(gx, gy)} cannot be reached from the cart's position {_fmt(sx, sy)}: "
            f"obstacles wall it off for the cart, which keeps {r:g} m from obstacles"
        )

    simple = np.asarray(grid.origin) + simplify(graph, path_g) * grid.step_m
    simple[0], simple[-1] = path_m[0], path_m[-1]  # exactly the measured start and the goal
    points = tuple(zip(path_m[:, 0].tolist(), path_m[:, 1].tolist(), strict=True))
    waypoints = tuple(zip(simple[1:, 0].tolist(), simple[1:, 1].tolist(), strict=True))
    return Plan(
        start=(sx, sy),
        goal=(gx, gy),
        path=points,
        waypoints=waypoints,
        grid_length_m=polyline_length(path_m),
        length_m=polyline_length(simple),
    )


class Planner:
    """The map (grid, footprint, obstacle nodes) and its plans; the graph is rebuilt lazily after
    the obstacles change. Obstacles are edited by a point in metres, rounded to the nearest node."""

    def __init__(
        self, grid: Grid | None = None, footprint_radius_m: float = 0.0, obstacles: Iterable[Node] = ()
    ) -> None:
        self.grid = grid if grid is not None else Grid()
        self._graph = GridGraph(self.grid, obstacles, footprint_radius_m)  # validates everything
        self.footprint_radius_m = self._graph.footprint_radius_m
        self._obstacles = set(self._graph.obstacles)
        self._stale = False

    @property
    def obstacles(self) -> frozenset[Node]:
        return frozenset(self._obstacles)

    @property
    def graph(self) -> GridGraph:
        if self._stale:
            self._graph = GridGraph(self.grid, self._obstacles, self.footprint_radius_m)
            self._stale = False
        return self._graph

    def add_obstacle(self, x: float, y: float) -> Node:
        """Puts an obstacle on the node nearest to (x, y); returns that node."""
        node = self.grid.nearest_node(x, y)
        if node not in self._obstacles:
            self._obstacles.add(node)
            self._stale = True
        return node

    def remove_obstacle(self, x: float, y: float) -> Node:
        """Clears the node nearest to (x, y) (nothing happens if it holds no obstacle); returns it."""
        node = self.grid.nearest_node(x, y)
        if node in self._obstacles:
            self._obstacles.discard(node)
            self._stale = True
        return node

    def toggle_obstacle(self, x: float, y: float) -> bool:
        """Flips the node nearest to (x, y); True when it now holds an obstacle."""
        node = self.grid.nearest_node(x, y)
        if node in self._obstacles:
            self._obstacles.discard(node)
            present = False
        else:
            self._obstacles.add(node)
            present = True
        self._stale = True
        return present

    def set_obstacles(self, nodes: Iterable[Node]) -> None:
        """Replaces every obstacle (node indices); refused as a whole if one is off the grid."""
        graph = GridGraph(self.grid, nodes, self.footprint_radius_m)
        self._graph, self._obstacles, self._stale = graph, set(graph.obstacles), False

    def plan(self, start: Point, goal: Point) -> Plan:
        """A plan from the cart's measured position `start` to `goal` (metres); see plan_path."""
        return plan_path(self.graph, start, goal)
