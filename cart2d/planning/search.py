"""Dijkstra on a GridGraph with scipy's compiled implementation: the graph in compressed sparse
rows plus one virtual source node whose edges are rewritten for every search."""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np
from scipy.sparse import csr_array
from scipy.sparse.csgraph import dijkstra

from cart2d.planning.geometry import FloatArray, IndexArray
from cart2d.planning.graph import GridGraph
from cart2d.planning.grid import DIRECTIONS, SQRT2, PlanError


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
        # row k: the edges of node k in DIRECTIONS order: the (node, direction) table of edge bits,
        # read row by row, keeps exactly the edges the graph has, grouped by node
        has = np.unpackbits(edges[:, None], axis=1, bitorder="little").view(np.bool_).reshape(-1)
        offsets = np.array([di + dj * grid.cols for di, dj in DIRECTIONS], dtype=np.int32)
        lengths = np.array([grid.step_m * (SQRT2 if di and dj else 1.0) for di, dj in DIRECTIONS])
        self.slots = 9  # the virtual source's: the nodes within √2 steps of a point, at most 3 x 3
        self.indices: IndexArray = np.empty(nnz + self.slots, dtype=np.int32)
        self.indices[:nnz] = (np.arange(n, dtype=np.int32)[:, None] + offsets[None, :]).reshape(-1)[has]
        self.data: FloatArray = np.empty(nnz + self.slots, dtype=np.float64)
        # odd directions are the diagonals (a table of flags: an eighth of the bytes of lengths)
        diagonal = np.broadcast_to(np.arange(8) % 2 == 1, (n, 8)).reshape(-1)[has]
        np.copyto(self.data[:nnz], lengths[0])
        self.data[:nnz][diagonal] = lengths[1]
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


def _searcher(graph: GridGraph) -> _Search:
    """The graph's search structure, built once (a graph never changes)."""
    with graph._search_lock:
        if graph._search is None:
            graph._search = _Search(graph)
        found: _Search = graph._search
        return found


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
    search = _searcher(graph)
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
