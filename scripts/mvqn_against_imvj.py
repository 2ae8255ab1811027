"""Is Kratos CoSimulation's ``mvqn`` accelerator our IQN-IMVJ? Both driven on the same five windows of a linear
fixed-point problem x = A_w x + b_w (6 unknowns, A_w = B + 0.05 w I with a random B of norm well below 1), each from
its own iterates, with alpha = initial relaxation 0.5 and 15 columns; the script prints both iteration counts and
the first iterate at which they part (for the issue "Kratos CoSimulation cases, unmodified").

Usage: python -m scripts.mvqn_against_imvj   (needs KratosMultiphysics with its CoSimulationApplication)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from coupler.accelerations.quasi_newton import IQNIMVJ

UNKNOWNS, WINDOWS, TOLERANCE = 6, 5, 1e-12


def iterates(update: Callable[[np.ndarray, np.ndarray], np.ndarray], start: Callable[[], None],
             end: Callable[[], None]) -> list[np.ndarray]:
    """Every iterate of the five windows, each window from the last one's result."""
    base = np.random.default_rng(0).normal(size=(UNKNOWNS, UNKNOWNS)) * 0.3
    x, seen = np.zeros(UNKNOWNS), []
    for window in range(WINDOWS):
        matrix = base + 0.05 * window * np.eye(UNKNOWNS)
        b = np.random.default_rng(10 + window).normal(size=UNKNOWNS)
        start()
        for _ in range(60):
            x_tilde = matrix @ x + b
            seen.append(x.copy())
            if np.linalg.norm(x_tilde - x) < TOLERANCE:
                break
            x = update(x, x_tilde)
        end()
    return seen


def main() -> int:
    import KratosMultiphysics as KM
    from KratosMultiphysics.CoSimulationApplication.convergence_accelerators import mvqn
    kratos = mvqn.Create(KM.Parameters('{"type": "mvqn", "horizon": 15, "alpha": 0.5}'))
    kratos.Initialize()
    theirs = iterates(lambda x, x_tilde: x + kratos.UpdateSolution(x_tilde - x, x), kratos.InitializeSolutionStep,
                      kratos.FinalizeSolutionStep)
    ours_acceleration = IQNIMVJ(0.5, max_used_iterations=15)

    def ours_update(x: np.ndarray, x_tilde: np.ndarray) -> np.ndarray:
        ours_acceleration.observe(x, x_tilde)
        return ours_acceleration.next_iterate()

    ours = iterates(ours_update, ours_acceleration.start_window, ours_acceleration.end_window)
    common = min(len(theirs), len(ours))
    gaps = [float(np.abs(a - b).max()) for a, b in zip(theirs[:common], ours[:common])]
    parted = next((i for i, gap in enumerate(gaps) if gap > 1e-9), None)
    print(f"iterations over {WINDOWS} windows: Kratos mvqn {len(theirs)}, cosim iqn-imvj {len(ours)}; first iterate "
          f"that differs by more than 1e-9: {parted} (largest difference {max(gaps):.3g})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
