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

The modules, one concern each: grid (nodes, numbers, errors), geometry (exact distances),
graph (free nodes and edges for the footprint), search (Dijkstra), simplification (few straight
segments), plan (plans and the Planner that keeps the map).
"""

from cart2d.planning.geometry import (
    point_polyline_distance,
    point_segment_distance,
    point_square_distance,
    polyline_length,
    segment_square_distance,
)
from cart2d.planning.graph import MAX_FOOTPRINT_STEPS, GridGraph
from cart2d.planning.grid import (
    DIRECTIONS,
    EPS,
    SQRT2,
    GoalBlocked,
    Grid,
    Node,
    OffMap,
    PlanError,
    Point,
    StartBlocked,
    Unreachable,
)
from cart2d.planning.plan import CellKinds, Plan, Planner, plan_path
from cart2d.planning.search import shortest_path
from cart2d.planning.simplification import simplify

__all__ = [
    "DIRECTIONS",
    "EPS",
    "MAX_FOOTPRINT_STEPS",
    "SQRT2",
    "CellKinds",
    "GoalBlocked",
    "Grid",
    "GridGraph",
    "Node",
    "OffMap",
    "Plan",
    "PlanError",
    "Planner",
    "Point",
    "StartBlocked",
    "Unreachable",
    "plan_path",
    "point_polyline_distance",
    "point_segment_distance",
    "point_square_distance",
    "polyline_length",
    "segment_square_distance",
    "shortest_path",
    "simplify",
]
