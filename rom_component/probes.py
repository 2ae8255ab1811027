"""Probes: a solid's answers to chosen forces, trained on next to its recorded calls.

Along a coupled run the weak force modes move with the strong ones, so the recorded calls do not fix the
solid's response to each of them, and a ROM fitted to those calls alone answers them with gains of its own.
A static solid (each call a solve for the given force, nothing carried over from earlier calls) can be asked
directly: at a few converged forces of the training data, one call per POD force mode, at the force plus a
multiple of that mode's range in the data. On the double flap this fixes the ROM's response to the weak
modes and raises the coupling iterations (README, "Probes of the solid along the weak force modes").
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from rom_component.pod import centred_pod


def probe_forces(F: np.ndarray, windows: np.ndarray, n_bases: int, modes: Sequence[int], amplitude: float,
                 seed: int = 0, basis: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Forces to ask the solid for (n_bases * len(modes), N), and the row of ``F`` each one starts from.

    Bases: the last call of ``n_bases`` windows spread evenly over the data (the converged forces). Probe
    (b, k): base b plus ``amplitude`` times the range of mode k's coefficient in ``F``, along POD mode k of
    ``F`` (``modes``: their indices, 0 the leading one; or column k of ``basis``, orthonormal columns, such as
    a model's work basis), with a random sign.
    """
    all_modes = centred_pod(F)[1] if basis is None else np.asarray(basis)
    modes = all_modes[:, list(modes)]
    ranges = np.ptp((F - F.mean(axis=0)) @ modes, axis=0)
    last = np.flatnonzero(np.r_[windows[1:] != windows[:-1], True])
    bases = last[np.linspace(0, len(last) - 1, min(n_bases, len(last))).round().astype(int)]
    signs = np.random.default_rng(seed).choice([-1.0, 1.0], size=(len(bases), modes.shape[1]))
    steps = (signs * amplitude * ranges)[:, :, None] * modes.T[None, :, :]
    return (F[bases][:, None, :] + steps).reshape(-1, F.shape[1]), np.repeat(bases, modes.shape[1])


class ProbeFailed(RuntimeError):
    """The solid failed on one probe: ``row`` of the forces, ``reason`` the first line of its error."""

    def __init__(self, row: int, reason: str):
        super().__init__(f"row {row}: {reason}")
        self.row, self.reason = row, reason


def ask(solve: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], forces: np.ndarray) -> tuple[np.ndarray,
                                                                                                   np.ndarray]:
    """The solid's (output, field) rows for each force row (``solve`` takes one force row); a failed solve
    raises ProbeFailed."""
    answers = []
    for row, f in enumerate(forces):
        try:
            answers.append(solve(f))
        except Exception as exc:
            first_line = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise ProbeFailed(row, first_line) from None
    return np.array([a[0] for a in answers]), np.array([a[1] for a in answers])


def save_probes(path: str | Path, forces: np.ndarray, outputs: dict[str, np.ndarray], times: np.ndarray,
                windows: np.ndarray) -> Path:
    """An .npz that ``cosim train`` reads with ``snapshots.probes`` (no pickle)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, force=forces, time=times, window=windows, **outputs)
    return path
