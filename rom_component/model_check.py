"""What a model file may hold: the arrays a ROM reads, their dtypes, their shapes, finite values.

``check_members`` runs on the zip archive before anything is decompressed: only known array
names, no object arrays, and at most ``MAX_MODEL_BYTES`` in all as the arrays' own headers
declare them. ``check_arrays`` runs on the loaded arrays: every shape follows from the model's
mode counts and mesh sizes, index arrays stay in range, and every float is finite. Whatever
reads a model (the online ROM, its compiled C path, the FMU export) reads only what passed both,
so no C code is ever handed an array shorter than it expects.
"""

from __future__ import annotations

import math
import re
import zipfile
from collections.abc import Mapping
from typing import Any

import numpy as np

from cosim.npz import member_header

MAX_MODEL_BYTES = 1 << 30          # 1 GiB decompressed; a double-flap model with its full field is a few MB
MAX_METADATA_BYTES = 1 << 20
FLOATS = {"E", "e", "A", "base", "u_mean", "Phi_u", "f_mean", "Phi_f", "force_singular_values",
          "disp_singular_values", "B", "Phi_bar", "centres", "H", "envelope_low", "envelope_high", "envelope_mean",
          "envelope_precision", "envelope_max_distance", "W_f", "W_z", "W_q", "c", "P", "p0"}
REQUIRED = ("E", "e", "H", "A", "base", "u_mean", "Phi_u")
INDICES = {"quad_i", "quad_j", "cube_i", "cube_j", "cube_k"}
MESH = re.compile(r"mesh:[A-Za-z0-9_.-]{1,64}")


class ModelContentError(ValueError):
    """A model file holds an array it should not, or one of the wrong kind or shape."""


def known(name: str) -> bool:
    return name in FLOATS or name in INDICES or name == "metadata_json" or MESH.fullmatch(name) is not None


def check_members(archive: zipfile.ZipFile) -> None:
    """Names and declared sizes of every member, read from the .npy headers alone."""
    total = 0
    for info in archive.infolist():
        name = info.filename.removesuffix(".npy")
        if not info.filename.endswith(".npy") or not known(name):
            raise ModelContentError(f"it holds an unknown array '{info.filename}' (a model file holds only a ROM's "
                                    "arrays)")
        try:
            declared = member_header(archive, info)
        except ValueError as exc:
            raise ModelContentError(f"array '{name}': {exc}") from None
        if declared.dtype.hasobject:
            raise ModelContentError(f"array '{name}' holds Python objects")
        size = declared.data_bytes
        limit = MAX_METADATA_BYTES if name == "metadata_json" else MAX_MODEL_BYTES
        total += size
        if size > limit or total > MAX_MODEL_BYTES:
            raise ModelContentError(f"array '{name}' declares {size:,} bytes; a model holds at most "
                                    f"{MAX_MODEL_BYTES:,} in all")


STEP_MAP_REQUIRED = ("E", "e", "W_f", "W_z", "W_q", "c", "A", "base", "u_mean", "Phi_u", "P", "p0")


def check_arrays(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any]) -> None:
    """Dtypes, shapes and values of a model's arrays against each other."""
    if metadata.get("kind") == "step-map":
        check_step_map(arrays, metadata)
        return
    for name in REQUIRED:
        if name not in arrays:
            raise ModelContentError(f"it lacks the array '{name}'")
    regressor = metadata.get("regressor")
    if not isinstance(regressor, str):      # "rbf" or "poly"
        raise ModelContentError(f"its metadata names no regressor (got {regressor!r})")
    _check_values(arrays)
    E, A = arrays["E"], arrays["A"]
    if E.ndim != 2 or A.ndim != 2:
        raise ModelContentError(f"arrays 'E' {E.shape} and 'A' {A.shape} must be matrices")
    (r_f, n_in), (n_out, r_u) = E.shape, A.shape
    n_full = arrays["u_mean"].size
    terms = r_u * (r_u + 1) // 2
    expected = {"e": (r_f,), "base": (n_out,), "u_mean": (n_full,), "Phi_u": (n_full, r_u), "f_mean": (n_in,),
                "Phi_f": (n_in, r_f), "B": (n_out, terms), "Phi_bar": (n_full, terms), **_envelope_shapes(r_f)}
    if regressor == "rbf":
        if "centres" not in arrays or arrays["centres"].ndim != 2:
            raise ModelContentError("an rbf model needs the matrix 'centres'")
        m = len(arrays["centres"])
        expected["centres"] = (m, r_f)
    else:
        for name in ("quad_i", "quad_j"):
            if name not in arrays:
                raise ModelContentError(f"a poly model needs the array '{name}'")
        m = _index_terms(arrays, ("quad_i", "quad_j"), r_f) + _index_terms(arrays, ("cube_i", "cube_j", "cube_k"), r_f)
    expected["H"] = (r_u, m + r_f + 1)
    if "B" in arrays and "Phi_bar" not in arrays:
        raise ModelContentError("it has the quadratic decoder 'B' but not its full field 'Phi_bar'")
    _check_shapes(arrays, expected, f"r_f = {r_f}, r_u = {r_u}, {n_in} inputs, {n_out} outputs, {n_full} field values")
    _check_meshes(arrays)


def _envelope_shapes(r_f: int) -> dict[str, tuple[int, ...]]:
    return {"envelope_low": (r_f,), "envelope_high": (r_f,), "envelope_mean": (r_f,), "envelope_precision": (r_f, r_f),
            "envelope_max_distance": (1,)}


def check_step_map(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any]) -> None:
    """A step-map ROM (``rom_component.dynamic.model``): its matrices' shapes follow from r_f, r_u and the histories."""
    for name in STEP_MAP_REQUIRED:
        if name not in arrays:
            raise ModelContentError(f"it lacks the array '{name}'")
    _check_values(arrays)
    counts = {}
    for key in ("history", "quadratic_modes"):
        value = metadata.get(key)
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 64:
            raise ModelContentError(f"its metadata's '{key}' is {value!r}; expected a whole number from 0 to 64")
        counts[key] = value
    E, A = arrays["E"], arrays["A"]
    if E.ndim != 2 or A.ndim != 2:
        raise ModelContentError(f"arrays 'E' {E.shape} and 'A' {A.shape} must be matrices")
    (r_f, _), (n_out, r_u) = E.shape, A.shape
    k = counts["quadratic_modes"]
    if k > r_u:
        raise ModelContentError(f"its metadata's quadratic_modes {k} exceeds r_u = {r_u}")
    n_full, n_probe = arrays["u_mean"].size, arrays["p0"].size
    expected = {"e": (r_f,), "W_f": (r_u, r_f), "W_z": (r_u, counts["history"] * r_u),
                "W_q": (r_u, k * (k + 1) // 2), "c": (r_u,),
                "base": (n_out,), "u_mean": (n_full,), "Phi_u": (n_full, r_u), "P": (n_probe, r_u), "p0": (n_probe,),
                **_envelope_shapes(r_f)}
    _check_shapes(arrays, expected, f"r_f = {r_f}, r_u = {r_u}, history {counts['history']}, {n_out} outputs, "
                                    f"{n_full} field values")
    if len(metadata.get("probes", [])) * 2 != n_probe:
        raise ModelContentError(f"its metadata names {len(metadata.get('probes', []))} probes for {n_probe} probe "
                                "values (two each)")
    dt = metadata.get("dt")
    if not isinstance(dt, int | float) or isinstance(dt, bool) or not math.isfinite(dt) or dt <= 0:
        raise ModelContentError(f"its metadata's 'dt' (the window it was trained on) is {dt!r}; expected a number > 0")
    radius, given = companion_radius(arrays["W_z"]), metadata.get("radius_served")
    known = isinstance(given, int | float) and not isinstance(given, bool) and math.isfinite(given)
    recorded = float(given) if isinstance(given, int | float) and known else 1.0     # without a record: at most 1
    if (radius - recorded > 1e-6 * max(1.0, abs(recorded))) if not known else \
            abs(radius - recorded) > 1e-6 * max(1.0, abs(recorded)):
        raise ModelContentError(f"its history matrix W_z has spectral radius {radius:.6g}, not the {recorded:.6g} "
                                "its training left: the arrays were changed, and the model's free response may grow")
    _check_meshes(arrays)


def companion_radius(A: np.ndarray) -> float:
    """Spectral radius of z_{n+1} = sum_k A_k z_{n+1-k}: the companion matrix of [A_1 ... A_p]."""
    r, pr = A.shape
    companion = np.zeros((pr, pr))
    companion[:r] = A
    companion[r:, :pr - r] = np.eye(pr - r)
    return float(np.max(np.abs(np.linalg.eigvals(companion)))) if pr else 0.0


def _check_shapes(arrays: Mapping[str, np.ndarray], expected: Mapping[str, tuple[int, ...]], sizes: str) -> None:
    for name, shape in expected.items():
        if name in arrays and arrays[name].shape != shape:
            raise ModelContentError(f"array '{name}' has shape {arrays[name].shape}, expected {shape} ({sizes})")


def _check_meshes(arrays: Mapping[str, np.ndarray]) -> None:
    for name, value in arrays.items():
        if MESH.fullmatch(name) and (value.ndim != 2 or not 1 <= value.shape[1] <= 3):
            raise ModelContentError(f"mesh array '{name}' has shape {value.shape}, expected (nodes, 1 to 3)")


def _check_values(arrays: Mapping[str, np.ndarray]) -> None:
    for name, value in arrays.items():
        if name in INDICES:
            if value.dtype.kind not in "iu" or value.ndim != 1:
                raise ModelContentError(f"array '{name}' is {value.dtype} of shape {value.shape}; expected 1-D integers")
        elif value.dtype != np.float64:
            raise ModelContentError(f"array '{name}' is {value.dtype}; expected float64")
        elif not np.isfinite(value).all():
            raise ModelContentError(f"array '{name}' holds {np.count_nonzero(~np.isfinite(value))} values that are "
                                    "not finite")


def _index_terms(arrays: Mapping[str, np.ndarray], names: tuple[str, ...], r_f: int) -> int:
    """The number of terms the index arrays ``names`` define (equal lengths, every index below r_f)."""
    present = [arrays[n] for n in names if n in arrays]
    if not present:
        return 0
    if len(present) != len(names) or len({len(a) for a in present}) != 1:
        raise ModelContentError(f"arrays {', '.join(names)} must all be present, of one length")
    for name, value in zip(names, present):
        if len(value) and (value.min() < 0 or value.max() >= r_f):
            raise ModelContentError(f"array '{name}' indexes reduced forces outside 0 to {r_f - 1}")
    return len(present[0])
