"""A chain of masses and springs integrated by Newmark's average acceleration, whose windows are repeated with
perturbed forces as a coupling's sub-iterations repeat them: a structure whose step map is known, the data the
tests fit a step map to and the small step-map benchmark (``step_map_call --small``) runs."""

from __future__ import annotations

import numpy as np

from rom_component.dynamic.model import WindowData

DT = 0.1


def chain(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness of a clamped chain of ``n`` unit masses (stiffness 40 per spring)."""
    K = 40.0 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    K[-1, -1] = 40.0
    return np.eye(n), K


def newmark_calls(windows: int = 160, n: int = 12, seed: int = 0) -> WindowData:
    """Every call of a run: per window 2 to 4 calls from the same start state, the last at the converged force."""
    M, K = chain(n)
    rng = np.random.default_rng(seed)
    beta, gamma = 0.25, 0.5
    lhs = M / (beta * DT ** 2) + K
    u, v, a = np.zeros(n), np.zeros(n), np.zeros(n)
    shape = np.linspace(0.2, 1.0, n)
    F, U, window, converged = [], [], [], []
    for w in range(1, windows + 1):
        t = w * DT
        force = shape * (1 - np.cos(0.6 * t)) + 0.3 * np.sin(1.7 * t) * shape[::-1]

        start = M @ (u / (beta * DT ** 2) + v / (beta * DT) + (0.5 / beta - 1) * a)    # the window's start state
        calls = int(rng.integers(2, 5))
        for k in range(calls):
            f = force if k == calls - 1 else force + 0.05 * rng.standard_normal(n) * (calls - k)
            F.append(f)
            U.append(np.linalg.solve(lhs, f + start))
            window.append(w)
            converged.append(k == calls - 1)
        u_new = U[-1]
        a_new = (u_new - u - DT * v - DT ** 2 * (0.5 - beta) * a) / (beta * DT ** 2)
        v = v + DT * ((1 - gamma) * a + gamma * a_new)
        u, a = u_new, a_new
    return WindowData(np.array(F), np.array(U), np.array(window), np.array(converged))
