"""Interface mapping of one variable between the meshes of two components.

Every mapping is a linear operator from the source mesh's nodes to the target mesh's
nodes, applied to arrays of shape (n,) or (n, k) (the same operator for each of the k
components). Mappings are plug-ins chosen by name (``MAPPINGS``):

- ``identity``: same nodes, same order (checked by shape).
- ``nearest-neighbour``: ``consistent`` (for displacements: each target node takes the
  value of its nearest source node) or ``conservative`` (for forces: each source value
  goes to its nearest target node, so totals are preserved).
- ``nearest-neighbour-gradient``: consistent nearest-neighbour corrected to first order by the gradient the
  source writes at its node (a preCICE participant's ``write_gradient_data``).
- ``nearest-element``: on 2-D interfaces, each target node interpolated at its projection onto the nearest of the
  sender's line elements (``Component.lines``), or the transpose of that the other way (``conservative``).
- ``rbf``: radial basis functions (each basis preCICE lists, compact or global) with a linear
  polynomial fitted separately (preCICE's default), in the same system, or none; with the
  polynomial, constant and linear fields are reproduced exactly. ``conservative`` is the
  transpose of the consistent mapping in the other direction, so it preserves the total
  force to round-off.

The operators are built once at set-up (sparse where they can be); mapping is a product or a
factorised solve.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.errors import SceneError
from cosim.registry import Registry
from cosim.schema import Choice, Value
from coupler.linalg import solve

if TYPE_CHECKING:
    import scipy.sparse as sp  # imported where a mapping is built: a scene of matching meshes needs no SciPy

MAPPINGS: Registry[Mapping] = Registry("mapping")
CONSTRAINTS = ("consistent", "conservative")
WITHOUT_ELEMENTS = ("refuse", "nearest-node")


class Mapping:
    """A linear map from source nodes to target nodes (``matrix``: n_target x n_source)."""

    SETTINGS: dict[str, Any] = {}
    HELP: dict[str, str] = {}
    needs_meshes = True
    takes_gradients = False     # corrects its values by the gradients the source writes (``correction``)

    def __init__(self, source: np.ndarray, target: np.ndarray, **settings: Any):
        self.matrix = self.build(np.asarray(source, float), np.asarray(target, float), **settings)

    def build(self, source: np.ndarray, target: np.ndarray, **settings: Any) -> Any:
        raise NotImplementedError

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return self.matrix @ values

    def in_time(self, samples: np.ndarray) -> np.ndarray:
        """Samples in time (first axis), each mapped."""
        return samples if getattr(self, "identity", False) else np.stack([self(sample) for sample in samples])



@MAPPINGS.register("identity")
class IdentityMapping(Mapping):
    """The values as they are: both variables on the same nodes, in the same order."""

    needs_meshes = False

    identity = True

    def __init__(self, source: np.ndarray | None = None, target: np.ndarray | None = None):
        self.matrix = None

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return values


@MAPPINGS.register("nearest-neighbour")
class NearestNeighbour(Mapping):
    """Each target node takes its nearest source node's value (consistent), or each source node adds its value to its nearest target node (conservative)."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS)}
    HELP = {"constraint": "'consistent' keeps values (a displacement), 'conservative' keeps sums (a force)"}

    def build(self, source: np.ndarray, target: np.ndarray,  # type: ignore[override]  # a mapping's own settings
              constraint: str = "consistent") -> sp.csr_matrix:
        import scipy.sparse as sp
        from scipy.spatial import cKDTree
        if constraint == "consistent":
            _, nearest = cKDTree(source).query(target)
            rows, cols = np.arange(len(target)), nearest
        else:
            _, nearest = cKDTree(target).query(source)
            rows, cols = nearest, np.arange(len(source))
        if len(source) == len(target) and np.array_equal(rows, cols):
            self.identity = True        # coinciding meshes: the values as they are (a product would turn -0.0 to 0.0)
        return sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(target), len(source)))

    identity = False

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return np.array(values) if self.identity else self.matrix @ values


@MAPPINGS.register("nearest-neighbour-gradient")
class NearestNeighbourGradient(NearestNeighbour):
    """Consistent only: each target node takes its nearest source node's value, corrected to first order by the
    gradient the source gives there (preCICE's nearest-neighbor-gradient): v + G . (x_target - x_source). Without a
    gradient it is the nearest-neighbour mapping."""

    SETTINGS = {"constraint": Choice("consistent", ("consistent",))}
    HELP = {"constraint": "'consistent' only: a gradient corrects values, not sums"}
    takes_gradients = True

    def build(self, source: np.ndarray, target: np.ndarray,  # type: ignore[override]  # a mapping's own settings
              constraint: str = "consistent") -> sp.csr_matrix:
        from scipy.spatial import cKDTree
        _, self.nearest = cKDTree(source).query(target)
        self.offsets = target - source[self.nearest]       # n_target x dimensions
        return super().build(source, target, constraint)

    def correction(self, gradients: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """What the gradients add to values of ``shape`` (n_target, or n_target x k) mapped: per source node, the
        first component's d/dx, d/dy (, d/dz), then the next component's (n_source x k*dimensions), the layout
        preCICE 3.4.1 reads."""
        dimensions = self.offsets.shape[1]
        components = 1 if len(shape) == 1 else shape[1]
        at = np.asarray(gradients, float).reshape(len(gradients), components, dimensions)[self.nearest]
        return np.einsum("nd,nkd->nk", self.offsets, at).reshape(shape)


@MAPPINGS.register("nearest-element")
class NearestElement(Mapping):
    """Interpolation on the nearest line element (2-D interfaces; Kratos's ``nearest_element``, preCICE's
    nearest-projection): ``consistent``, each target node takes the linear interpolation at its projection onto the
    nearest of the sender's line elements (the nearest point of the sender's polyline; beyond its ends, a node);
    ``conservative``, the transpose of the consistent mapping the other way, onto the receiver's elements, so sums
    are kept."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS),
                "local_coordinate_tolerance": Value(0.25, low=0.0),
                "without_elements": Choice("refuse", WITHOUT_ELEMENTS)}
    HELP = {"constraint": "'consistent' interpolates on the sender's elements, 'conservative' transposes the "
                          "interpolation of the other direction (on the receiver's elements)",
            "local_coordinate_tolerance": "how far beyond a line's ends (in its local coordinate, -1 to 1) a "
                                          "projection is still taken, extrapolated, before the nearest node is",
            "without_elements": "a mesh that gives no elements: 'refuse' it, or map to the nearest node "
                                "(preCICE's fallback)"}
    needs_lines = True

    def __init__(self, source: np.ndarray, target: np.ndarray, lines: np.ndarray | None,  # noqa: D107
                 constraint: str = "consistent", local_coordinate_tolerance: float = 0.25,
                 without_elements: str = "refuse", cells: np.ndarray | None = None):
        source, target = np.asarray(source, float), np.asarray(target, float)
        if constraint == "conservative":
            source, target = target, source
        triangles = cells if cells is not None and source.shape[1] == 3 and np.shape(cells)[1:] == (3,) else None
        if triangles is not None and len(triangles):        # a 3-D surface: its triangles, then its edges
            matrix = _on_triangles(source, target, np.asarray(triangles, np.int64), lines)
        else:
            matrix = _on_lines(source, target, lines, local_coordinate_tolerance)
        self.matrix = matrix if constraint == "consistent" else matrix.T.tocsr()


@MAPPINGS.register("cell-interpolation")
class CellInterpolation(Mapping):
    """Linear interpolation in the sender's cells (triangles on 2-D meshes, tetrahedra on 3-D ones; preCICE's
    linear-cell-interpolation): ``consistent``, each target node takes the barycentric interpolation in the cell
    that holds it; a node in no cell is projected onto the nearest line element, or else takes the nearest node
    (preCICE's fallback to nearest-projection). ``conservative``, the transpose of the other direction."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS),
                "without_elements": Choice("refuse", WITHOUT_ELEMENTS)}
    HELP = {"constraint": NearestElement.HELP["constraint"].replace("elements", "cells"),
            "without_elements": NearestElement.HELP["without_elements"]}
    needs_lines = True

    def __init__(self, source: np.ndarray, target: np.ndarray, lines: np.ndarray | None,  # noqa: D107
                 constraint: str = "consistent", without_elements: str = "refuse", cells: np.ndarray | None = None):
        source, target = np.asarray(source, float), np.asarray(target, float)
        if constraint == "conservative":
            source, target = target, source
        matrix = _in_cells(source, target, cells, lines)
        self.matrix = matrix if constraint == "consistent" else matrix.T.tocsr()


def _nearest_node(nodes: np.ndarray, points: np.ndarray) -> sp.csr_matrix:
    """Each point takes its nearest node's value."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree
    _, nearest = cKDTree(nodes).query(points)
    return sp.csr_matrix((np.ones(len(points)), (np.arange(len(points)), nearest)), shape=(len(points), len(nodes)))


def _on_lines(nodes: np.ndarray, points: np.ndarray, lines: np.ndarray | None, tolerance: float) -> sp.csr_matrix:
    """Interpolation at each point's projection onto the nearest line element; the nearest node without lines."""
    if lines is None or len(lines) == 0:
        return _nearest_node(nodes, points)
    return _projection(nodes, points, np.asarray(lines, np.int64), tolerance)


def _on_triangles(nodes: np.ndarray, points: np.ndarray, triangles: np.ndarray, lines: np.ndarray | None,
                  candidates: int = 16) -> sp.csr_matrix:
    """Interpolation at each point's projection onto the nearest triangle that holds it (of the ``candidates``
    whose centres are nearest); a point projected onto none goes to the lines (``_on_lines``, no extrapolation)."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree
    a, b, c = (nodes[triangles[:, k]] for k in range(3))
    k = min(candidates, len(triangles))
    _, near = cKDTree((a + b + c) / 3.0).query(points, k=k)
    near = near.reshape(len(points), k)
    v0, v1, v2 = b[near] - a[near], c[near] - a[near], points[:, None, :] - a[near]       # (points, k, 3)
    d00, d01, d11 = (np.einsum("pkj,pkj->pk", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("pkj,pkj->pk", v2, v0), np.einsum("pkj,pkj->pk", v2, v1)
    denominator = d00 * d11 - d01 * d01
    flat = denominator <= 1e-14 * np.maximum(d00 * d11, np.finfo(float).tiny)     # a degenerate triangle
    denominator = np.where(flat, 1.0, denominator)
    v = (d11 * d20 - d01 * d21) / denominator
    w = (d00 * d21 - d01 * d20) / denominator
    weights = np.stack([1.0 - v - w, v, w], axis=-1)                                   # (points, k, 3)
    inside = (weights.min(axis=-1) >= -1e-10) & ~flat
    projected = np.einsum("pkc,pkcj->pkj", weights, np.stack([a[near], b[near], c[near]], axis=2))
    distance = np.where(inside, np.linalg.norm(points[:, None, :] - projected, axis=-1), np.inf)
    best = np.argmin(distance, axis=1)
    rows = np.flatnonzero(np.isfinite(distance[np.arange(len(points)), best]))
    chosen = near[rows, best[rows]]
    values = weights[rows, best[rows]]
    matrix = sp.csr_matrix((values.ravel(), (np.repeat(rows, 3), triangles[chosen].ravel())),
                           shape=(len(points), len(nodes)))
    if len(rows) == len(points):
        return matrix
    outside = np.setdiff1d(np.arange(len(points)), rows)
    rest = _on_lines(nodes, points[outside], lines, 0.0).tocoo()
    return matrix + sp.csr_matrix((rest.data, (outside[rest.row], rest.col)), shape=matrix.shape)


def _in_cells(nodes: np.ndarray, points: np.ndarray, cells: np.ndarray | None, lines: np.ndarray | None,
              candidates: int = 16, chunk: int = 64) -> sp.csr_matrix:
    """The (len(points), len(nodes)) barycentric interpolation in the simplex cell holding each point; points in no
    cell go to the lines (``_on_lines``, no extrapolation)."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree
    if cells is None or len(cells) == 0 or np.shape(cells)[1] != nodes.shape[1] + 1:     # simplices of the space
        return _on_lines(nodes, points, lines, 0.0)
    cells = np.asarray(cells, np.int64)
    corners = nodes[cells]                                        # (cells, d + 1, d)
    edges = np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2)    # (cells, d, d): columns v_k - v_0
    volume = np.abs(np.linalg.det(edges))
    usable = volume > 1e-12 * np.max(volume, initial=0.0)         # degenerate cells hold no point
    inverse = np.zeros_like(edges)
    inverse[usable] = np.linalg.inv(edges[usable])

    def weights(p: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Barycentric coordinates (..., d + 1) of points p (..., d) in cells c (...)."""
        local = np.einsum("...ij,...j->...i", inverse[c], p - corners[c, 0])
        return np.concatenate([1.0 - local.sum(axis=-1, keepdims=True), local], axis=-1)

    tolerance = 1e-10
    k = min(candidates, len(cells))
    _, near = cKDTree(corners.mean(axis=1)).query(points, k=k)
    near = near.reshape(len(points), k)
    lam = weights(points[:, None, :], near)
    inside = (lam.min(axis=-1) >= -tolerance) & usable[near]
    found = inside.any(axis=1)
    cell = near[np.arange(len(points)), np.argmax(inside, axis=1)]
    pending = np.flatnonzero(~found)
    for start in range(0, len(pending), chunk):                   # the rest: every cell, a chunk of points at a time
        batch = pending[start:start + chunk]
        every = np.broadcast_to(np.arange(len(cells)), (len(batch), len(cells)))
        held = (weights(points[batch, None, :], every).min(axis=-1) >= -tolerance) & usable[None, :]
        hit = held.any(axis=1)
        cell[batch[hit]] = np.argmax(held[hit], axis=1)
        found[batch[hit]] = True
    rows = np.flatnonzero(found)
    lam = weights(points[rows], cell[rows])
    matrix = sp.csr_matrix((lam.ravel(), (np.repeat(rows, lam.shape[1]), cells[cell[rows]].ravel())),
                           shape=(len(points), len(nodes)))
    if found.all():
        return matrix
    outside = np.flatnonzero(~found)
    rest = _on_lines(nodes, points[outside], lines, 0.0).tocoo()
    return matrix + sp.csr_matrix((rest.data, (outside[rest.row], rest.col)), shape=matrix.shape)


def _projection(nodes: np.ndarray, points: np.ndarray, lines: np.ndarray, tolerance: float,
                chunk: int = 256) -> sp.csr_matrix:
    """The (len(points), len(nodes)) matrix interpolating node values at each point's projection onto a line.

    The nearest projection inside a line wins; else the nearest one within ``tolerance`` of a line's local
    coordinate (-1 to 1) beyond its ends, extrapolated; else the nearest node."""
    import scipy.sparse as sp
    a, b = nodes[lines[:, 0]], nodes[lines[:, 1]]
    ab = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), np.finfo(float).tiny)
    margin = tolerance / 2          # in the line's parameter s = (xi + 1) / 2
    rows, cols, weights = [], [], []
    for start in range(0, len(points), chunk):
        p = points[start:start + chunk]
        s = np.einsum("pij,ij->pi", p[:, None, :] - a[None], ab) / length2          # (points, lines)
        offset = p[:, None, :] - (a[None] + s[..., None] * ab[None])
        distance = np.einsum("pij,pij->pi", offset, offset)
        inside = (s >= 0.0) & (s <= 1.0)
        near = (s >= -margin) & (s <= 1.0 + margin)
        best_inside = np.argmin(np.where(inside, distance, np.inf), axis=1)
        best_near = np.argmin(np.where(near, distance, np.inf), axis=1)
        index = np.arange(len(p))
        has_inside, has_near = inside[index, best_inside], near[index, best_near]
        best = np.where(has_inside, best_inside, best_near)
        t = s[index, best]
        to_node = ~(has_inside | has_near)           # no projection: the nearest node
        if to_node.any():
            node_distance = np.einsum("pnj,pnj->pn", p[to_node][:, None, :] - nodes[None], p[to_node][:, None, :] - nodes[None])
            nearest = np.argmin(node_distance, axis=1)
            best[to_node] = 0
            t[to_node] = 0.0
        first = lines[best, 0].copy()
        if to_node.any():
            first[to_node] = nearest
        rows += [start + index, start + index]
        cols += [first, lines[best, 1]]
        weights += [1.0 - t, t]
    return sp.csr_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(points), len(nodes)))


def _r_log_r(r: np.ndarray, power: int) -> np.ndarray:
    """r**power * log(r), 0 at r = 0."""
    safe = np.where(r > 0.0, r, 1.0)
    return np.where(r > 0.0, safe ** power * np.log(safe), 0.0)


# The basis functions of preCICE's configuration reference, of the distance r. Compact ones take r / support radius
# and vanish beyond 1 (Wendland's compact-polynomial-cN, the compact thin-plate spline).
COMPACT_BASES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "compact-polynomial-c0": lambda r: (1.0 - r) ** 2,
    "compact-polynomial-c2": lambda r: (1.0 - r) ** 4 * (4.0 * r + 1.0),
    "compact-polynomial-c4": lambda r: (1.0 - r) ** 6 * (35.0 * r * r + 18.0 * r + 3.0),
    "compact-polynomial-c6": lambda r: (1.0 - r) ** 8 * (32.0 * r ** 3 + 25.0 * r * r + 8.0 * r + 1.0),
    "compact-polynomial-c8": lambda r: (1.0 - r) ** 10 * (429.0 * r ** 4 + 450.0 * r ** 3 + 210.0 * r * r + 50.0 * r
                                                          + 5.0),
    "compact-tps-c2": lambda r: (1.0 - 30.0 * r * r - 10.0 * r ** 3 + 45.0 * r ** 4 - 6.0 * r ** 5
                                 - 60.0 * _r_log_r(r, 3)),
}
GLOBAL_BASES: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {     # of r and the shape parameter c
    "thin-plate-splines": lambda r, c: _r_log_r(r, 2),
    "volume-splines": lambda r, c: r,
    "multiquadrics": lambda r, c: np.sqrt(c * c + r * r),
    "inverse-multiquadrics": lambda r, c: 1.0 / np.sqrt(c * c + r * r),
    "gaussian": lambda r, c: np.exp(-(c * r) ** 2),
}
BASES = (*COMPACT_BASES, *GLOBAL_BASES)
SHAPED = ("multiquadrics", "inverse-multiquadrics", "gaussian")     # take a shape parameter
GAUSSIAN_DECAY = 1e-9    # a Gaussian given a support radius decays to this there, and is cut off beyond
POLYNOMIALS = ("separate", "on", "off")
DEAD_AXES = ("", "x", "y", "z", "xy", "xz", "yz")


@dataclass(frozen=True)
class Kernel:
    """One basis function with its parameters: ``matrix(points, centres)`` its values between two node sets."""

    basis: str
    support_radius: float = 0.0     # compact bases and a cut-off Gaussian; 0: none
    shape_parameter: float = 0.0

    def matrix(self, points: np.ndarray, centres: np.ndarray) -> Any:
        """Phi(|points_i - centres_j|): sparse where the kernel has a support radius, dense otherwise."""
        if self.basis in COMPACT_BASES:
            return _within(points, centres, self.support_radius, lambda d: COMPACT_BASES[self.basis](
                d / self.support_radius))
        if self.basis == "gaussian" and self.support_radius > 0.0:
            shape = np.sqrt(-np.log(GAUSSIAN_DECAY)) / self.support_radius
            return _within(points, centres, self.support_radius, lambda d: np.exp(-(shape * d) ** 2))
        from scipy.spatial.distance import cdist
        return GLOBAL_BASES[self.basis](cdist(points, centres), self.shape_parameter)


@MAPPINGS.register("rbf")
class RadialBasisFunctions(Mapping):
    """Radial basis function interpolation with a linear polynomial, in each of preCICE's forms."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS), "basis": Choice("compact-polynomial-c2", BASES),
                "support_radius": Value(0.0, low=0.0), "shape_parameter": Value(0.0, low=0.0),
                "polynomial": Choice("separate", POLYNOMIALS), "dead_axes": Choice("", DEAD_AXES)}
    HELP = {**NearestNeighbour.HELP,
            "basis": "the basis function (preCICE's names): Wendland's compact-polynomial-c0 to -c8 and "
                     "compact-tps-c2 need a support radius; thin-plate-splines and volume-splines take no "
                     "parameter; multiquadrics and inverse-multiquadrics a shape parameter; gaussian either",
            "support_radius": "a compact basis's support radius (a Gaussian's cut-off, where it has decayed to 1e-9); "
                              "0: none",
            "shape_parameter": "the shape parameter c of sqrt(c^2 + r^2), its inverse, or exp(-(c r)^2); 0: none",
            "polynomial": "the linear polynomial: 'separate' fitted first by least squares, the basis interpolating "
                          "the rest (preCICE's default), 'on' in one system with the basis, 'off' none",
            "dead_axes": "coordinates the mapping ignores, in distances and polynomial (preCICE's x-dead, y-dead, "
                         "z-dead): 'y' maps a 2-D interface that lies along x as a 1-D one"}

    @staticmethod
    def check_settings(settings: dict[str, Any], where: str, source: str = "", **_: Any) -> None:
        """A basis's parameters: a support radius for the compact ones, a shape parameter for the shaped ones."""
        basis, radius, shape = settings["basis"], settings["support_radius"], settings["shape_parameter"]
        at = f"{source}: " if source else ""
        if basis in COMPACT_BASES and radius <= 0.0:
            raise SceneError(f"{at}missing key '{where}.support_radius' (the {basis} basis needs a support radius)")
        if basis == "gaussian" and (radius > 0.0) == (shape > 0.0):
            raise SceneError(f"{at}'{where}': the gaussian basis takes a shape_parameter or a support_radius, one of "
                             "them")
        if basis in ("multiquadrics", "inverse-multiquadrics") and shape <= 0.0:
            raise SceneError(f"{at}missing key '{where}.shape_parameter' (the {basis} basis needs one)")

    def build(self, source: np.ndarray, target: np.ndarray,  # type: ignore[override]  # a mapping's own settings
              constraint: str = "consistent", support_radius: float = 0.0, shape_parameter: float = 0.0,
              basis: str = "compact-polynomial-c2", polynomial: str = "separate", dead_axes: str = "") -> Any:
        self.check_settings({"basis": basis, "support_radius": support_radius, "shape_parameter": shape_parameter},
                            "rbf")
        live = [axis for axis in range(source.shape[1]) if "xyz"[axis] not in dead_axes]
        source, target = source[:, live], target[:, live]
        kernel = Kernel(basis, support_radius, shape_parameter)
        if constraint == "consistent":
            return _RbfOperator(source, target, kernel, polynomial, transpose=False)
        return _RbfOperator(target, source, kernel, polynomial, transpose=True)


DENSE_VALUES = 1 << 20    # an RBF mapping whose kernel matrix between points and centres has no more values is dense


class _RbfOperator:
    """RBF interpolation from ``centres`` to ``points`` (consistent), or its transpose (conservative), factorised once.

    With K the kernel between the centres, B between the points and the centres, and P_c, P_p the linear polynomial
    at the centres and at the points, the consistent map of values f at the centres is
    - ``separate``: B K^-1 (f - P_c beta) + P_p beta, beta = P_c^+ f (the polynomial's least-squares fit);
    - ``on``: [B P_p] A^-1 [f; 0], A = [[K, P_c], [P_c^T, 0]];
    - ``off``: B K^-1 f.
    The conservative map is its transpose (K and A are symmetric), so it keeps the sum of what it maps.
    """

    def __init__(self, centres: np.ndarray, points: np.ndarray, kernel: Kernel, polynomial: str, transpose: bool):
        import scipy.sparse as sp
        columns = _polynomial_columns(centres)        # the centres decide the polynomial: the points follow
        P_c, P_p = _linear_basis(centres, columns), _linear_basis(points, columns)
        K, B = kernel.matrix(centres, centres), kernel.matrix(points, centres)
        self.n, self.m = len(centres), P_c.shape[1]
        self.polynomial, self.transpose = polynomial, transpose
        self.shape = (self.n, len(points)) if transpose else (len(points), self.n)
        if polynomial == "on":
            K = sp.bmat([[sp.csr_matrix(K), sp.csr_matrix(P_c)], [sp.csr_matrix(P_c.T), None]], format="csc")
            B = sp.hstack([sp.csr_matrix(B), sp.csr_matrix(P_p)], format="csr")
        if len(points) * len(centres) <= DENSE_VALUES:     # small meshes: dense arrays, each product one BLAS call
            K, B = (m.toarray() if sp.issparse(m) else np.asarray(m, float) for m in (K, B))
        self.solve = _factorised(K)
        self.B, self.B_T = B, B.T       # the transpose once (a view of B's arrays; each call's .T was a new one)
        if polynomial == "separate":
            self.Q, self.R = np.linalg.qr(P_c)         # P_c^+ = R^-1 Q^T
            self.P_p = P_p

    def __matmul__(self, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, float)
        if self.transpose:
            return self._conservative(values)
        if self.polynomial == "on":
            return np.asarray(self.B @ self.solve(np.concatenate([values, np.zeros((self.m,) + values.shape[1:])])))
        if self.polynomial == "off":
            return np.asarray(self.B @ self.solve(values))
        beta = solve(self.R, self.Q.T @ values)
        return np.asarray(self.B @ self.solve(values - self.Q @ (self.R @ beta))) + self.P_p @ beta

    def _conservative(self, values: np.ndarray) -> np.ndarray:
        spread = np.asarray(self.B_T @ values)
        if self.polynomial == "on":
            return self.solve(spread)[:self.n]
        if self.polynomial == "off":
            return self.solve(spread)
        inner = self.solve(spread)
        inner = inner - self.Q @ (self.Q.T @ inner)       # (I - P_c P_c^+), a symmetric projector
        return inner + self.Q @ solve(self.R.T, self.P_p.T @ values)


def _factorised(matrix: Any) -> Callable[[np.ndarray], np.ndarray]:
    """A solver of ``matrix`` x = b, factorised once: sparse LU, or dense LU."""
    import scipy.sparse as sp
    if sp.issparse(matrix):
        from scipy.sparse.linalg import splu
        lu = splu(sp.csc_matrix(matrix))
        return lambda b: lu.solve(np.asarray(b, float))
    from scipy.linalg import lu_factor
    from scipy.linalg.lapack import dgetrs
    lu, pivots = lu_factor(np.asarray(matrix, float))

    def solve(b: np.ndarray) -> np.ndarray:     # scipy.linalg.lu_solve's LAPACK call, without its checks' cost
        x, info = dgetrs(lu, pivots, b)
        if info != 0:
            raise ValueError(f"the RBF system's solve failed (LAPACK getrs info {info})")
        return x
    return solve


def _within(points: np.ndarray, centres: np.ndarray, radius: float,
            kernel: Callable[[np.ndarray], np.ndarray]) -> sp.csr_matrix:
    """``kernel`` of the distance between ``points`` and ``centres`` closer than ``radius``, as a sparse matrix."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree
    distances = cKDTree(points).sparse_distance_matrix(cKDTree(centres), radius, output_type="coo_matrix")
    inside = distances.data < radius
    values = kernel(distances.data[inside])
    return sp.coo_matrix((values, (distances.row[inside], distances.col[inside])),
                         shape=(len(points), len(centres))).tocsr()


def _polynomial_columns(centres: np.ndarray) -> list[int]:
    """The coordinates whose linear terms the centres can carry: not constant over them, and not a combination of
    the constant and the coordinates kept before (collinear or coplanar centres: preCICE's dead axes)."""
    scale = max(1.0, float(np.abs(centres).max(initial=0.0)))
    varying = [k for k in range(centres.shape[1]) if np.ptp(centres[:, k]) > 1e-12 * scale]
    kept: list[int] = []
    for k in varying:
        trial = np.hstack([np.ones((len(centres), 1)), centres[:, kept + [k]] / scale])
        if np.linalg.matrix_rank(trial, tol=1e-10 * np.sqrt(len(centres))) == len(kept) + 2:
            kept.append(k)
    return kept


def _linear_basis(points: np.ndarray, columns: list[int]) -> np.ndarray:
    """[1, and the ``columns`` coordinates] per point."""
    return np.hstack([np.ones((len(points), 1)), points[:, columns]])


class ScaledMapping(Mapping):
    """A mapping whose values are multiplied by ``scale`` (an exchange's ``scale``: -1 swaps the sign)."""

    identity = False

    def __init__(self, mapping: Mapping, scale: float):    # noqa: D107  (no mesh: it wraps a built mapping)
        self.mapping, self.scale = mapping, float(scale)
        self.matrix = getattr(mapping, "matrix", None)

    def __call__(self, values: np.ndarray) -> np.ndarray:
        return self.scale * self.mapping(values)

    def in_time(self, samples: np.ndarray) -> np.ndarray:
        return self.scale * self.mapping.in_time(samples)


def make_mapping(settings: dict[str, Any], source_nodes: np.ndarray, target_nodes: np.ndarray,
                 source_shape: tuple[int, ...], target_shape: tuple[int, ...], where: str,
                 source_lines: np.ndarray | None = None, target_lines: np.ndarray | None = None,
                 source_cells: np.ndarray | None = None, target_cells: np.ndarray | None = None) -> Mapping:
    """The mapping ``settings`` names, between two variables of the given shapes on the given nodes (and, for an
    element mapping, the line elements and cells of the sender's mesh, or the receiver's for the conservative
    form)."""
    cls = MAPPINGS.classes[settings["type"]]
    if not cls.needs_meshes:
        if tuple(source_shape) != tuple(target_shape):
            raise SceneError(f"{where}: identity mapping needs equal shapes, got {tuple(source_shape)} "
                             f"and {tuple(target_shape)}")
        return cls(source_nodes, target_nodes)     # the identity keeps no mesh
    if len(source_nodes) == 0 or len(target_nodes) == 0:
        raise SceneError(f"{where}: {settings['type']} mapping needs the meshes of both variables")
    if source_shape[1:] != target_shape[1:]:
        raise SceneError(f"{where}: the variables have {source_shape[1:] or (1,)} and {target_shape[1:] or (1,)} "
                         f"components per node")
    if source_shape[0] != len(source_nodes) or target_shape[0] != len(target_nodes):
        raise SceneError(f"{where}: shapes {tuple(source_shape)} -> {tuple(target_shape)} do not fit "
                         f"{len(source_nodes)} -> {len(target_nodes)} nodes")
    if np.shape(source_nodes)[1] != np.shape(target_nodes)[1]:
        raise SceneError(f"{where}: meshes of dimension {np.shape(source_nodes)[1]} and {np.shape(target_nodes)[1]}")
    if getattr(cls, "needs_lines", False):
        conservative = settings.get("constraint") == "conservative"
        lines, cells = (target_lines, target_cells) if conservative else (source_lines, source_cells)
        side = "receiver" if conservative else "sender"
        has = [kind for kind, elements in (("lines", lines), ("cells", cells)) if elements is not None and len(elements)]
        if not has and settings.get("without_elements", "refuse") == "refuse":
            raise SceneError(f"{where}: {settings['type']} mapping ({settings.get('constraint')}) needs the line "
                             f"elements{' or cells' if cls is CellInterpolation else ''} of the {side}'s mesh, "
                             "which its component does not declare (Component.lines)")
        return MAPPINGS.create(settings, source=source_nodes, target=target_nodes, lines=lines, cells=cells)
    return MAPPINGS.create(settings, source=source_nodes, target=target_nodes)
