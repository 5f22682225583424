"""Frontiers for exploration (issue 26): where floor seen free meets floor never seen, grouped
into connected runs of cells, each chosen by what it would show (its size) against the way to
it; a frontier the planner cannot reach is set aside with the reason, not tried again and again
(explore_lite's users' complaint). The driving loop: cart2d/gateway/exploration.py."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cart2d.maps.occupancy import FREE, UNKNOWN, OccupancyMap

Point = tuple[float, float]
MIN_CELLS = 3  # smaller runs are noise at a wall's foot, not a way into the unknown
CROSS = ((1, 0), (-1, 0), (0, 1), (0, -1))


@dataclass(frozen=True)
class Frontier:
    centre: Point  # the cell of the run nearest its centroid, in m (a free cell: a goal to drive to)
    cells: int

    def gain_m(self, resolution_m: float) -> float:
        """How much unknown edge it opens, m."""
        return self.cells * resolution_m


def frontier_mask(occupancy: OccupancyMap) -> np.ndarray:
    """Free cells with an unknown cell beside them (4-neighbours)."""
    cells = occupancy.cells
    unknown = cells == UNKNOWN
    beside = np.zeros_like(unknown)
    beside[1:, :] |= unknown[:-1, :]
    beside[:-1, :] |= unknown[1:, :]
    beside[:, 1:] |= unknown[:, :-1]
    beside[:, :-1] |= unknown[:, 1:]
    return np.asarray((cells == FREE) & beside)


def frontiers(occupancy: OccupancyMap, min_cells: int = MIN_CELLS) -> list[Frontier]:
    mask = frontier_mask(occupancy)
    seen = np.zeros_like(mask)
    out = []
    r = occupancy.resolution_m
    ox, oy = occupancy.origin_m
    for j, i in zip(*np.nonzero(mask), strict=True):
        if seen[j, i]:
            continue
        run, todo = [], [(int(j), int(i))]
        seen[j, i] = True
        while todo:
            cj, ci = todo.pop()
            run.append((cj, ci))
            for dj in (-1, 0, 1):
                for di in (-1, 0, 1):
                    nj, ni = cj + dj, ci + di
                    if (
                        0 <= nj < mask.shape[0]
                        and 0 <= ni < mask.shape[1]
                        and mask[nj, ni]
                        and not seen[nj, ni]
                    ):
                        seen[nj, ni] = True
                        todo.append((nj, ni))
        if len(run) < min_cells:
            continue
        mj, mi = np.mean(run, axis=0)
        cj, ci = min(run, key=lambda c: (c[0] - mj) ** 2 + (c[1] - mi) ** 2)
        out.append(Frontier((ox + (ci + 0.5) * r, oy + (cj + 0.5) * r), len(run)))
    return out


def choose(
    found: list[Frontier],
    resolution_m: float,
    path_length: Callable[[Point], float | None],
    blacklist: dict[Point, str],
    near_m: float = 0.2,
) -> Frontier | None:
    """The frontier with the most gain per metre of driving (its size over 0.5 m plus the path's
    length), leaving out those within `near_m` of a blacklisted place; one without a path
    (path_length None) goes on the blacklist with why; one whose path_length is infinite is left
    out of this choice only."""
    best: tuple[float, Frontier] | None = None
    for f in found:
        if any(math.dist(f.centre, p) < near_m for p in blacklist):
            continue
        length = path_length(f.centre)
        if length is not None and math.isinf(length):
            continue  # not now (a way not safe yet): looked at again on the next choice
        if length is None:
            blacklist[f.centre] = f"no path to the frontier at ({f.centre[0]:.2f}, {f.centre[1]:.2f})"
            continue
        score = f.gain_m(resolution_m) / (0.5 + length)
        if best is None or score > best[0]:
            best = (score, f)
    return best[1] if best else None
