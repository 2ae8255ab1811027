"""Interface mapping between the node sets of two components.

- ``identity``: same nodes, same order (checked by size).
- ``nearest-neighbour``: each target node takes the value of its nearest source node
  (``consistent``, for displacements); ``conservative`` (for forces) sums each
  source value into its nearest target node, so totals are preserved. The KD-tree
  query runs once at set-up; mapping is one gather or one ``bincount``.
"""

from __future__ import annotations

import numpy as np

KINDS = ("identity", "nearest-neighbour", "nearest-neighbour-conservative")


class Mapping:
    def __call__(self, values: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class IdentityMapping(Mapping):
    def __call__(self, values: np.ndarray) -> np.ndarray:
        return values


class NearestNeighbourConsistent(Mapping):
    def __init__(self, source: np.ndarray, target: np.ndarray, components: int = 1):
        from scipy.spatial import cKDTree
        _, nearest = cKDTree(source).query(target)
        self.index = _expand(nearest, components)

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return values[self.index]


class NearestNeighbourConservative(Mapping):
    def __init__(self, source: np.ndarray, target: np.ndarray, components: int = 1):
        from scipy.spatial import cKDTree
        _, nearest = cKDTree(target).query(source)
        self.index = _expand(nearest, components)
        self.size = len(target) * components

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return np.bincount(self.index, weights=values, minlength=self.size)


def _expand(nodes: np.ndarray, components: int) -> np.ndarray:
    """Indices of node-major values (node 0 x, node 0 y, ...) for ``components`` per node."""
    return (nodes[:, None] * components + np.arange(components)).ravel()


def make_mapping(kind: str, source: np.ndarray, target: np.ndarray, source_size: int, target_size: int,
                 where: str) -> Mapping:
    """The mapping ``kind`` from ``source`` nodes to ``target`` nodes; errors name ``where``."""
    if kind == "identity":
        if source_size != target_size:
            raise ValueError(f"{where}: identity mapping needs equal sizes, got {source_size} and {target_size}")
        return IdentityMapping()
    if len(source) == 0 or len(target) == 0:
        raise ValueError(f"{where}: {kind} mapping needs interface coordinates from both components")
    components = source_size // len(source)
    if components * len(source) != source_size or components * len(target) != target_size:
        raise ValueError(f"{where}: sizes {source_size} -> {target_size} do not fit "
                         f"{len(source)} -> {len(target)} nodes with the same number of components")
    if kind == "nearest-neighbour":
        return NearestNeighbourConsistent(source, target, components)
    if kind == "nearest-neighbour-conservative":
        return NearestNeighbourConservative(source, target, components)
    raise ValueError(f"{where}: unknown mapping {kind!r} (known: {', '.join(KINDS)})")
