"""Data in time across a coupling window (waveform iteration, as preCICE v3 has it).

A data item's window is a set of samples at normalised times 0 = s_0 < s_1 < ... < s_n = 1: the window's start
(the last window's end value), every substep its producer sent, and the window's end. A reader evaluates the
interpolant of the item's degree p through them at its own times:

- p = 0: constant, the window-end value;
- p >= 1: the B-spline of degree k = min(p, n) that interpolates the samples, with knots by averaging (de Boor):
  k + 1 knots at 0 and at 1, and interior knots t_j = (s_j + ... + s_{j+k-1}) / k, j = 1 .. n - k. For k = 1 this
  is piecewise linear through the samples; with n = k it is the polynomial through them.

The interpolant is linear in the samples, so resampling a waveform on another set of times is one matrix
(``resampling``); the coupler uses it to bring the accelerated data of an iteration on the window's time grid.
"""

from __future__ import annotations

import functools
from collections import OrderedDict
from typing import Any

import numpy as np

MAX_DEGREE = 3
END = 1.0


def knots(times: np.ndarray, degree: int) -> np.ndarray:
    """The knot vector of the degree-``degree`` B-spline interpolating at ``times`` (averaged, clamped)."""
    times = np.asarray(times, dtype=float)
    count = len(times) - degree - 1        # interior knots: each the mean of k consecutive interior times
    inner = (np.lib.stride_tricks.sliding_window_view(times[1:-1], degree).mean(axis=1) if count > 0
             else np.zeros(0))
    return np.concatenate([np.full(degree + 1, times[0]), inner, np.full(degree + 1, times[-1])])


def used_degree(degree: int, samples: int) -> int:
    """The degree an interpolant through ``samples`` samples has: at most one less than their number."""
    return min(int(degree), samples - 1)


def spline(times: np.ndarray, samples: np.ndarray, degree: int):
    """The interpolating B-spline (scipy's ``BSpline``) of degree ``min(degree, len(times) - 1)``, ``degree`` >= 1,
    through ``samples`` (first axis: time) at ``times``."""
    from scipy.interpolate import make_interp_spline
    k = used_degree(degree, len(times))
    return make_interp_spline(times, samples, k=k, t=knots(times, k), axis=0)


CACHE_BYTES = 256 << 20      # what the matrices kept per time grid may hold in all


def _cached_by_size(function: Any) -> Any:
    """``function``'s results kept per arguments, least recently used first to go once they hold more than
    ``CACHE_BYTES`` (a participant whose step count changes every window makes a new grid every window)."""
    kept: OrderedDict[tuple, Any] = OrderedDict()
    held = [0]

    def size(value: Any) -> int:
        return sum(part.nbytes for part in (value if isinstance(value, tuple) else (value,)))

    @functools.wraps(function)
    def cached(*key: Any) -> Any:
        if key in kept:
            kept.move_to_end(key)
            return kept[key]
        value = kept[key] = function(*key)
        held[0] += size(value)
        while held[0] > CACHE_BYTES and len(kept) > 1:
            held[0] -= size(kept.popitem(last=False)[1])
        return value

    cached.held = held      # type: ignore[attr-defined]  # the bytes held now (for tests)
    return cached


@_cached_by_size
def _interpolation(inner: bytes, degree: int) -> tuple[np.ndarray, np.ndarray]:
    grid = np.concatenate([[0.0], np.frombuffer(inner), [END]])
    identity = spline(grid, np.eye(len(grid)), degree)
    return identity.t, identity.c


def coefficients(inner: np.ndarray, samples: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The knots and coefficients of the spline of ``degree`` through ``samples`` at the window's start, the times
    ``inner`` inside it and its end, from the interpolation's matrix (kept per time grid: a window's iterations
    share theirs)."""
    knots_, matrix = _interpolation(np.ascontiguousarray(inner, dtype=float).tobytes(), int(degree))
    coefficients_ = (matrix @ samples.reshape(len(matrix), -1)).reshape((len(matrix),) + samples.shape[1:])
    # a clamped interpolating B-spline's first and last coefficients are its first and last samples: exactly so
    coefficients_[0], coefficients_[-1] = samples[0], samples[-1]
    return knots_, coefficients_


def evaluate(times: np.ndarray, samples: np.ndarray, degree: int, at: np.ndarray) -> np.ndarray:
    """The waveform through ``samples`` at ``times`` evaluated ``at`` (normalised times in [0, 1]); a time that is a
    sample's own gives that sample exactly."""
    at = np.atleast_1d(np.asarray(at, dtype=float))
    if degree == 0:
        return np.repeat(samples[-1:], len(at), axis=0)
    values = spline(times, samples, degree)(at)
    hit = np.searchsorted(times, at)
    exact = (hit < len(times)) & (times[np.minimum(hit, len(times) - 1)] == at)
    values[exact] = samples[hit[exact]]
    return values


def resampling(times: np.ndarray, degree: int, at: np.ndarray) -> np.ndarray:
    """The matrix P (len(at) x len(times)) with P @ samples = the waveform through them evaluated ``at`` (kept per
    pair of grids)."""
    return _resampling(np.ascontiguousarray(times, dtype=float).tobytes(), int(degree),
                       np.ascontiguousarray(at, dtype=float).tobytes())


@_cached_by_size
def _resampling(times: bytes, degree: int, at: bytes) -> np.ndarray:
    grid = np.frombuffer(times)
    return evaluate(grid, np.eye(len(grid)), degree, np.frombuffer(at))
