"""Interface mapping of one variable between the meshes of two components.

Every mapping is a linear operator from the source mesh's nodes to the target mesh's
nodes, applied to arrays of shape (n,) or (n, k) (the same operator for each of the k
components). Mappings are plug-ins chosen by name (``MAPPINGS``):

- ``identity``: same nodes, same order (checked by shape).
- ``nearest-neighbour``: ``consistent`` (for displacements: each target node takes the
  value of its nearest source node) or ``conservative`` (for forces: each source value
  goes to its nearest target node, so totals are preserved).
- ``nearest-element``: on 2-D interfaces, each target node interpolated at its projection onto the nearest of the
  sender's line elements (``Component.lines``), or the transpose of that the other way (``conservative``).
- ``rbf``: radial basis functions with compact support (Wendland C2, radius
  ``support_radius``) plus a linear polynomial, so constant and linear fields are
  reproduced exactly; ``conservative`` is the transpose of the consistent mapping in the
  other direction, so it preserves the total force to round-off.

The operators are sparse matrices built once at set-up; mapping is one product.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.errors import SceneError
from cosim.registry import Registry
from cosim.schema import Choice, Positive, Value

if TYPE_CHECKING:
    import scipy.sparse as sp  # imported where a mapping is built: a scene of matching meshes needs no SciPy

MAPPINGS: Registry[Mapping] = Registry("mapping")
CONSTRAINTS = ("consistent", "conservative")


class Mapping:
    """A linear map from source nodes to target nodes (``matrix``: n_target x n_source)."""

    SETTINGS: dict[str, Any] = {}
    HELP: dict[str, str] = {}
    needs_meshes = True

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


@MAPPINGS.register("nearest-element")
class NearestElement(Mapping):
    """Interpolation on the nearest line element (2-D interfaces; Kratos's ``nearest_element``, preCICE's
    nearest-projection): ``consistent``, each target node takes the linear interpolation at its projection onto the
    nearest of the sender's line elements (the nearest point of the sender's polyline; beyond its ends, a node);
    ``conservative``, the transpose of the consistent mapping the other way, onto the receiver's elements, so sums
    are kept."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS),
                "local_coordinate_tolerance": Value(0.25, low=0.0)}
    HELP = {"constraint": "'consistent' interpolates on the sender's elements, 'conservative' transposes the "
                          "interpolation of the other direction (on the receiver's elements)",
            "local_coordinate_tolerance": "how far beyond a line's ends (in its local coordinate, -1 to 1) a "
                                          "projection is still taken, extrapolated, before the nearest node is"}
    needs_lines = True

    def __init__(self, source: np.ndarray, target: np.ndarray, lines: np.ndarray,  # noqa: D107
                 constraint: str = "consistent", local_coordinate_tolerance: float = 0.25):
        source, target = np.asarray(source, float), np.asarray(target, float)
        lines = np.asarray(lines, np.int64)
        if constraint == "consistent":
            self.matrix = _projection(source, target, lines, local_coordinate_tolerance)
        else:
            self.matrix = _projection(target, source, lines, local_coordinate_tolerance).T.tocsr()


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


# Wendland's compactly supported functions of r = distance / support radius < 1 (preCICE's compact-polynomial-cN)
COMPACT_BASES = {
    "compact-polynomial-c0": lambda r: (1.0 - r) ** 2,
    "compact-polynomial-c2": lambda r: (1.0 - r) ** 4 * (4.0 * r + 1.0),
    "compact-polynomial-c4": lambda r: (1.0 - r) ** 6 * (35.0 * r * r + 18.0 * r + 3.0),
    "compact-polynomial-c6": lambda r: (1.0 - r) ** 8 * (32.0 * r ** 3 + 25.0 * r * r + 8.0 * r + 1.0),
}


@MAPPINGS.register("rbf")
class RadialBasisFunctions(Mapping):
    """Radial basis functions with compact support and a linear polynomial, as a sparse operator."""

    SETTINGS = {"constraint": Choice("consistent", CONSTRAINTS), "support_radius": Positive(),
                "basis": Choice("compact-polynomial-c2", tuple(COMPACT_BASES))}
    HELP = {**NearestNeighbour.HELP, "support_radius": "the compact kernel's support radius",
            "basis": "Wendland's compactly supported function of that smoothness (preCICE's compact-polynomial-c0 "
                     "to -c6)"}

    def build(self, source: np.ndarray, target: np.ndarray,  # type: ignore[override]  # a mapping's own settings
              constraint: str = "consistent", support_radius: float = 1.0,
              basis: str = "compact-polynomial-c2") -> Any:
        if constraint == "consistent":
            return _RbfOperator(source, target, support_radius, transpose=False, basis=basis)
        return _RbfOperator(target, source, support_radius, transpose=True, basis=basis)


class _RbfOperator:
    """Consistent RBF interpolation from ``centres`` to ``points`` (or its transpose), factorised once.

    With A = [[Phi, P], [P^T, 0]] on the centres and B = [Phi(points, centres), P(points)],
    the consistent map is B A^-1 [I; 0]; its transpose is [I 0] A^-1 B^T (A is symmetric).
    """

    def __init__(self, centres: np.ndarray, points: np.ndarray, radius: float, transpose: bool,
                 basis: str = "compact-polynomial-c2"):
        n = len(centres)
        columns = _polynomial_columns(centres)        # the centres decide the polynomial: the points follow
        polynomial_centres, polynomial_points = _linear_basis(centres, columns), _linear_basis(points, columns)
        import scipy.sparse as sp
        from scipy.sparse.linalg import splu
        kernel = COMPACT_BASES[basis]
        A = sp.bmat([[_compact(centres, centres, radius, kernel), sp.csr_matrix(polynomial_centres)],
                     [sp.csr_matrix(polynomial_centres.T), None]], format="csc")
        self.B = sp.hstack([_compact(points, centres, radius, kernel), sp.csr_matrix(polynomial_points)],
                           format="csr")
        self.lu = splu(A)
        self.n, self.m = n, polynomial_centres.shape[1]
        self.transpose = transpose
        self.shape = (n, len(points)) if transpose else (len(points), n)

    def __matmul__(self, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, float)
        if self.transpose:
            return self.lu.solve(np.asarray(self.B.T @ values))[:self.n]
        padded = np.concatenate([values, np.zeros((self.m,) + values.shape[1:])])
        return self.B @ self.lu.solve(padded)


def _compact(points: np.ndarray, centres: np.ndarray, radius: float, kernel: Any) -> sp.csr_matrix:
    """A compact kernel of r = distance / radius < 1 between ``points`` and ``centres``, as a sparse matrix."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree
    distances = cKDTree(points).sparse_distance_matrix(cKDTree(centres), radius, output_type="coo_matrix")
    values = kernel(distances.data / radius)
    return sp.coo_matrix((values, (distances.row, distances.col)), shape=(len(points), len(centres))).tocsr()


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
                 source_lines: np.ndarray | None = None, target_lines: np.ndarray | None = None) -> Mapping:
    """The mapping ``settings`` names, between two variables of the given shapes on the given nodes (and, for an
    element mapping, the line elements of the sender's mesh, or the receiver's for the conservative form)."""
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
        lines = target_lines if conservative else source_lines
        side = "receiver" if conservative else "sender"
        if lines is None or len(lines) == 0:
            raise SceneError(f"{where}: {settings['type']} mapping ({settings.get('constraint')}) needs the line "
                             f"elements of the {side}'s mesh, which its component does not declare (Component.lines)")
        return MAPPINGS.create(settings, source=source_nodes, target=target_nodes, lines=lines)
    return MAPPINGS.create(settings, source=source_nodes, target=target_nodes)
