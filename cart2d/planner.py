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
path; it is then simplified (collinear points dropped, then string pulling) into a few straight
segments, each of them checked free.

Nothing here does I/O or knows the robot beyond the numbers passed in, and the code is plain
Python (no platform assumptions). Building the graph (`GridGraph`) is separate from searching it
(`shortest_path`), so either can be replaced by a faster backend for very large grids.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

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


# --- the graph ---------------------------------------------------------------------------------


# The footprint may span at most this many grid steps (the seed's map: 0.85).
MAX_FOOTPRINT_STEPS = 50


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


class GridGraph:
    """The free nodes and free edges of a grid for a disc of a given radius (immutable).

    `occupied[k]`, `free[k]` and `edges[k]` (an 8-bit mask over DIRECTIONS) are indexed by node
    index k = i + j·cols. Built by stamping, for every obstacle, precomputed stencils of the
    nodes and edges it blocks: the work grows with the number of obstacles, not of segments.
    """

    def __init__(self, grid: Grid, obstacles: Iterable[Node], footprint_radius_m: float) -> None:
        r = footprint_radius_m
        if isinstance(r, bool) or not isinstance(r, int | float) or not math.isfinite(r) or r < 0:
            raise ValueError(f"footprint_radius_m must be a finite number >= 0, got {r!r}")
        if r > MAX_FOOTPRINT_STEPS * grid.step_m:
            # The clearance stencils grow with (radius / step)^2: refuse instead of exhausting memory.
            raise PlanError(
                f"the grid step {grid.step_m:g} m is too fine for the cart's footprint ({r:g} m): "
                f"use a step of at least {r / MAX_FOOTPRINT_STEPS:g} m"
            )
        self.grid = grid
        self.footprint_radius_m = float(r)
        nodes = frozenset((i, j) for i, j in obstacles)
        for i, j in nodes:
            if not (type(i) is int and type(j) is int):
                raise ValueError(f"obstacle nodes are pairs of integer indices, got ({i!r}, {j!r})")
            if not grid.has_node(i, j):
                raise OffMap(f"obstacle node ({i}, {j}) is not on the {grid.cols} x {grid.rows} grid")
        self.obstacles = nodes
        self._r = self.footprint_radius_m / grid.step_m  # radius in grid units
        cols, rows = grid.cols, grid.rows
        n = cols * rows

        occupied = bytearray(n)
        for i, j in nodes:
            occupied[i + j * cols] = 1

        free = bytearray(b"\x01" * n)
        edges = bytearray(n)
        for j in range(rows):
            for i in range(cols):
                mask = 0
                for d, (di, dj) in enumerate(DIRECTIONS):
                    if 0 <= i + di < cols and 0 <= j + dj < rows:
                        mask |= 1 << d
                edges[i + j * cols] = mask

        node_stencil = _stencil(self._r, (0, 0))
        edge_stencils = [(d, DIRECTIONS[d], _stencil(self._r, DIRECTIONS[d])) for d in range(4)]
        for oi, oj in nodes:
            for si, sj in node_stencil:
                i, j = oi - si, oj - sj
                if 0 <= i < cols and 0 <= j < rows:
                    k = i + j * cols
                    free[k] = 0
                    edges[k] = 0
                    # (the edges into a blocked node go too: an edge's stencil holds both
                    # ends' node stencils, since the capsule holds the discs at its ends)
            for d, (mi, mj), stencil in edge_stencils:
                bit, back = ~(1 << d) & 0xFF, ~(1 << (d + 4)) & 0xFF
                for si, sj in stencil:
                    i, j = oi - si, oj - sj  # the edge from (i, j) along (mi, mj) is blocked
                    if 0 <= i < cols and 0 <= j < rows and 0 <= i + mi < cols and 0 <= j + mj < rows:
                        edges[i + j * cols] &= bit
                        edges[i + mi + (j + mj) * cols] &= back
        self.occupied = bytes(occupied)
        self.free = bytes(free)
        self.edges = bytes(edges)
        step = grid.step_m
        offsets = [di + dj * cols for di, dj in DIRECTIONS]
        costs = [step * (SQRT2 if di and dj else 1.0) for di, dj in DIRECTIONS]
        # moves[mask]: the (index offset, length in metres) of every edge in an edge mask
        self.moves: tuple[tuple[tuple[int, float], ...], ...] = tuple(
            tuple((offsets[d], costs[d]) for d in range(8) if mask >> d & 1) for mask in range(256)
        )

    # node queries

    def node_free(self, i: int, j: int) -> bool:
        return bool(self.free[self.grid.index(i, j)])

    def edge_free(self, a: Node, b: Node) -> bool:
        """Whether the graph has the edge between the neighbouring nodes a and b."""
        move = (b[0] - a[0], b[1] - a[1])
        if move not in DIRECTIONS:
            return False
        return bool(self.edges[self.grid.index(*a)] >> DIRECTIONS.index(move) & 1)

    def neighbours(self, index: int) -> Iterator[tuple[int, float]]:
        """(node index, edge length in metres) of every edge of the node."""
        yield from ((index + off, cost) for off, cost in self.moves[self.edges[index]])

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

    def _segment_clear(self, a: Point, b: Point) -> bool:
        """Whether the capsule of radius r around ab misses every obstacle square (grid units).

        Only the cells near the segment are visited: column by column, the rows that the
        segment, widened by r, can reach inside that column's slab."""
        if not self.obstacles:
            return True
        occ = self.occupied
        cols, rows = self.grid.cols, self.grid.rows
        reach = self._r + EPS
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
                if d <= reach and self.free[k] and self._segment_clear((u, v), (i, j)):
                    out[k] = d * self.grid.step_m
        return out


# --- the search --------------------------------------------------------------------------------


def shortest_path(
    graph: GridGraph, sources: Mapping[int, float], targets: Mapping[int, float], bound: float = math.inf
) -> tuple[float, list[int]] | None:
    """Dijkstra from several source nodes (each with a starting cost) to the cheapest of several
    target nodes (each with a final cost): (total cost, node indices from a source to a target),
    or None when no route is cheaper than `bound`."""
    n = graph.grid.node_count
    dist = [math.inf] * n
    prev = [-1] * n
    heap: list[tuple[float, int]] = []
    for k, cost in sources.items():
        if cost < dist[k]:
            dist[k] = cost
            heap.append((cost, k))
    heapq.heapify(heap)
    best, best_k = bound, -1
    edges, moves = graph.edges, graph.moves
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        d, k = pop(heap)
        if d >= best:
            break
        if d > dist[k]:
            continue
        final = targets.get(k)
        if final is not None and d + final < best:
            best, best_k = d + final, k
        for off, cost in moves[edges[k]]:
            k2 = k + off
            nd = d + cost
            if nd < dist[k2]:
                dist[k2] = nd
                prev[k2] = k
                push(heap, (nd, k2))
    if best_k < 0:
        return None
    path = [best_k]
    while prev[path[-1]] >= 0:
        path.append(prev[path[-1]])
    path.reverse()
    return best, path


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


def _polyline_length(points: Iterable[Point]) -> float:
    return math.fsum(math.dist(p, q) for p, q in itertools.pairwise(points))


def _drop_collinear(points: list[Point]) -> list[int]:
    """Indices of the points that remain once repeated points and straight-through points are
    dropped (the first and last always remain)."""
    keep = [0]
    for k in range(1, len(points) - 1):
        (px, py), (qx, qy), (rx, ry) = points[keep[-1]], points[k], points[k + 1]
        ux, uy, vx, vy = qx - px, qy - py, rx - qx, ry - qy
        nu, nv = math.hypot(ux, uy), math.hypot(vx, vy)
        if nu == 0.0 or nv == 0.0:
            continue
        if abs(ux * vy - uy * vx) <= 1e-12 * nu * nv and ux * vx + uy * vy > 0.0:
            continue
        keep.append(k)
    keep.append(len(points) - 1)
    return keep


def _string_pull(graph: GridGraph, points: list[Point]) -> list[int]:
    """From each kept point, jump to the farthest later point reachable by a free segment."""
    keep = [0]
    last = len(points) - 1
    while keep[-1] < last:
        i = keep[-1]
        j = last
        while j > i + 1 and not graph._segment_clear(points[i], points[j]):
            j -= 1
        keep.append(j)
    return keep


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
            f"cart's footprint ({r:g} m): remove that obstacle or move the cart"
        )
    if not graph._point_clear(*g):
        raise GoalBlocked(
            f"the goal {_fmt(gx, gy)} is inside an obstacle or too close to one "
            f"for the cart's footprint ({r:g} m)"
        )

    direct_m = math.dist((sx, sy), (gx, gy))
    # The goal is one more neighbour of the start when it lies as close as the start's nodes do.
    near = math.dist(s, g) <= SQRT2 + EPS and graph._segment_clear(s, g)
    found = shortest_path(
        graph, graph._connections(*s), graph._connections(*g), direct_m if near else math.inf
    )
    if found is not None:
        nodes = [grid.node(k) for k in found[1]]
        path_g: list[Point] = [s, *((float(i), float(j)) for i, j in nodes), g]
        path_m: list[Point] = [(sx, sy), *(grid.node_xy(i, j) for i, j in nodes), (gx, gy)]
        # a node that is the start or the goal itself appears once, as the exact point
        if math.dist(path_g[0], path_g[1]) <= EPS:
            del path_g[1], path_m[1]
        if len(path_g) > 2 and math.dist(path_g[-2], path_g[-1]) <= EPS:
            del path_g[-2], path_m[-2]
    elif near or graph._segment_clear(s, g):
        # in sight: the straight segment (also when no grid route exists, e.g. a pocket)
        path_g, path_m = [s, g], [(sx, sy), (gx, gy)]
    else:
        raise Unreachable(
            f"the goal {_fmt(gx, gy)} cannot be reached from the cart's position {_fmt(sx, sy)}: "
            f"obstacles wall it off for the cart's footprint ({r:g} m)"
        )

    kept = _drop_collinear(path_g)
    pulled = _string_pull(graph, [path_g[k] for k in kept])
    simple = [path_m[kept[k]] for k in pulled]
    return Plan(
        start=(sx, sy),
        goal=(gx, gy),
        path=tuple(path_m),
        waypoints=tuple(simple[1:]),
        grid_length_m=_polyline_length(path_m),
        length_m=_polyline_length(simple),
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
