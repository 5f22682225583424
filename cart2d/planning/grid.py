"""The planner's node grid, its numbers and its errors.

The floor is a grid of nodes `step_m` apart; an obstacle occupies its node's cell (a square of
side `step_m` centred on the node). Points are in metres; "grid units" measure in steps from
node (0, 0), so node (i, j) is at (i, j).
"""

from __future__ import annotations

import math
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
        return self.within(x, y, 0.0)

    def on_map(self, x: float, y: float) -> bool:
        """Whether (x, y) is within half a step of the outer nodes (it has a nearest node)."""
        return self.within(x, y, self.step_m / 2)

    def within(self, x: float, y: float, margin_m: float) -> bool:
        """Whether (x, y) is within `margin_m` of the node rectangle."""
        (x0, y0), (w, h) = self.origin, self.size_m
        m = margin_m + EPS * self.step_m
        return x0 - m <= x <= x0 + w + m and y0 - m <= y <= y0 + h + m

    def clamp(self, x: float, y: float) -> Point:
        """The point of the node rectangle nearest to (x, y)."""
        (x0, y0), (w, h) = self.origin, self.size_m
        return min(max(x, x0), x0 + w), min(max(y, y0), y0 + h)

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
