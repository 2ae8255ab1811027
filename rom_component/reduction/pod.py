"""Centred proper orthogonal decomposition of snapshot rows, and the energy criterion."""

from __future__ import annotations

import numpy as np


def centred_pod(X: np.ndarray, rank: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean (N,), modes (N, r) and all singular values of the centred snapshots ``X`` (m, N)."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"snapshots must be a 2-D array (m, N), got shape {X.shape}")
    mean = X.mean(axis=0)
    _, s, vt = np.linalg.svd(X - mean, full_matrices=False)
    rank = len(s) if rank is None else rank
    if not 1 <= rank <= len(s):
        raise ValueError(f"rank {rank} is outside 1..{len(s)} for snapshots of shape {X.shape}")
    # a deterministic sign: the largest entry of each mode is positive
    modes = vt[:rank].T
    signs = np.sign(modes[np.argmax(np.abs(modes), axis=0), np.arange(rank)])
    return mean, modes * np.where(signs == 0, 1.0, signs), s


def energy_rank(singular_values: np.ndarray, energy: float = 0.9999) -> int:
    """Smallest r whose modes hold at least ``energy`` of the snapshot energy (sum of s^2)."""
    s2 = np.asarray(singular_values, dtype=np.float64) ** 2
    cumulative = np.cumsum(s2) / s2.sum()
    return int(np.searchsorted(cumulative, energy - 1e-15) + 1)
