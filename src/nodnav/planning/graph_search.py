"""Dijkstra's shortest path on a small undirected graph given as an edge list, compiled.

The visibility graph's searches around standing robots (:meth:`VisibilityGraph._search_with_discs`)
build a graph of every wall vertex plus a few per query: a few dozen nodes on the built-in
worlds, but a thousand and hundreds of thousands of edges on a map's, where a Python heap and
adjacency lists cost more than everything else in a trial. This is the same algorithm as a
binary-heap Dijkstra on adjacency lists filled in edge order, step for step: the heap's keys
``(distance, node)`` are all distinct (a node is pushed again only at a strictly smaller
distance), so any binary heap pops them in the same order, and each node's neighbours are
relaxed in the order of the edges, so ties are broken the same way and the same chain results.
"""

from __future__ import annotations

import numpy as np

from nodnav.compiled import compiled


def shortest_chain(n_nodes: int, i: np.ndarray, j: np.ndarray, length: np.ndarray, source: int,
                   target: int) -> list[int]:
    """Nodes of a shortest path from ``source`` to ``target`` in an undirected graph with edges
    ``(i[e], j[e])`` of ``length[e]`` (Dijkstra with a binary heap); empty if unreachable."""
    chain = _dijkstra_chain(int(n_nodes), np.ascontiguousarray(i, dtype=np.int64),
                            np.ascontiguousarray(j, dtype=np.int64), np.ascontiguousarray(length, dtype=float),
                            int(source), int(target))
    return chain.tolist()


@compiled
def _less(da, ua, db, ub):
    """Whether the heap key ``(da, ua)`` comes before ``(db, ub)`` (as Python compares tuples)."""
    return da < db or (da == db and ua < ub)


@compiled
def _dijkstra_chain(n_nodes, i, j, length, source, target):
    """The search of :func:`shortest_chain`; the chain as an array (empty if unreachable)."""
    n_edges = i.shape[0]
    degree = np.zeros(n_nodes + 1, dtype=np.int64)
    for e in range(n_edges):
        degree[i[e] + 1] += 1
        degree[j[e] + 1] += 1
    start = np.cumsum(degree)
    fill = start[:-1].copy()
    other = np.empty(2 * n_edges, dtype=np.int64)
    weight = np.empty(2 * n_edges)
    for e in range(n_edges):  # each node's neighbours in the order of the edges
        a, b = i[e], j[e]
        other[fill[a]], weight[fill[a]] = b, length[e]
        fill[a] += 1
        other[fill[b]], weight[fill[b]] = a, length[e]
        fill[b] += 1
    dist = np.full(n_nodes, np.inf)
    prev = np.full(n_nodes, -1, dtype=np.int64)
    dist[source] = 0.0
    heap_d = np.empty(2 * n_edges + 1)
    heap_u = np.empty(2 * n_edges + 1, dtype=np.int64)
    heap_d[0], heap_u[0] = 0.0, source
    size = 1
    while size:
        d, u = heap_d[0], heap_u[0]
        size -= 1  # pop: the last entry sifts down from the root
        if size:
            ld, lu = heap_d[size], heap_u[size]
            k = 0
            while True:
                c = 2 * k + 1
                if c >= size:
                    break
                if c + 1 < size and _less(heap_d[c + 1], heap_u[c + 1], heap_d[c], heap_u[c]):
                    c += 1
                if not _less(heap_d[c], heap_u[c], ld, lu):
                    break
                heap_d[k], heap_u[k] = heap_d[c], heap_u[c]
                k = c
            heap_d[k], heap_u[k] = ld, lu
        if u == target:
            break
        if d > dist[u]:
            continue
        for q in range(start[u], start[u + 1]):
            v, nd = other[q], d + weight[q]
            if nd < dist[v]:
                dist[v] = nd
                prev[v] = u
                k = size  # push: sift up
                size += 1
                while k > 0:
                    parent = (k - 1) // 2
                    if not _less(nd, v, heap_d[parent], heap_u[parent]):
                        break
                    heap_d[k], heap_u[k] = heap_d[parent], heap_u[parent]
                    k = parent
                heap_d[k], heap_u[k] = nd, v
    if not np.isfinite(dist[target]):
        return np.zeros(0, dtype=np.int64)
    count = 1
    node = target
    while node != source:
        node = prev[node]
        count += 1
    chain = np.empty(count, dtype=np.int64)
    node = target
    for k in range(count - 1, -1, -1):
        chain[k] = node
        if k:
            node = prev[node]
    return chain
