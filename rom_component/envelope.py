"""The training envelope of a ROM in its reduced (scaled) force coordinates, and a call's trust.

Per mode the training data span [low, high]; a call whose reduced force lies beyond a mode's
range by more than a margin (a fraction of that range) is out of range. The Mahalanobis
distance to the training data, relative to the largest among the training data, is reported
beside it (about 1 or less inside the training cloud).
"""

from __future__ import annotations

import numpy as np


def fit_envelope(X: np.ndarray) -> dict[str, np.ndarray]:
    """Per-mode bounds, mean, precision matrix and largest training distance of reduced forces ``X`` (m, r)."""
    mean = X.mean(axis=0)
    precision = np.linalg.pinv(np.atleast_2d(np.cov(X, rowvar=False)))
    centred = X - mean
    distances = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", centred, precision, centred), 0.0))
    return {"envelope_low": X.min(axis=0), "envelope_high": X.max(axis=0), "envelope_mean": mean,
            "envelope_precision": precision, "envelope_max_distance": np.array([max(distances.max(), 1e-300)])}


def range_excess(X: np.ndarray, envelope: dict[str, np.ndarray]) -> np.ndarray:
    """How far each row of reduced forces ``X`` (..., r) lies beyond the per-mode bounds, in range widths (0
    inside): the largest over the modes."""
    low, high = envelope["envelope_low"], envelope["envelope_high"]
    width = np.maximum(high - low, 1e-300)
    return np.max(np.maximum(np.maximum(low - X, X - high), 0.0) / width, axis=-1)


def trust(x: np.ndarray, envelope: dict[str, np.ndarray]) -> tuple[float, float]:
    """(excess, distance): how far ``x`` lies beyond the per-mode bounds, in range widths (0 inside), and
    its Mahalanobis distance over the largest training distance."""
    excess = float(range_excess(x, envelope))
    centred = x - envelope["envelope_mean"]
    distance = float(np.sqrt(max(centred @ envelope["envelope_precision"] @ centred, 0.0)))
    return excess, distance / float(envelope["envelope_max_distance"][0])
