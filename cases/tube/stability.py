"""The elastic tube's stability: the continuum theory of plain Gauss-Seidel coupling, and the stability matrix
(stiffness x time step x acceleration) as ``cosim stability`` draws it (the theory's lines, spectral.csv,
contraction.png; the matrix itself is any scene's: ``workflow.stability_matrix``).

For the linearised tube the continuum theory gives the eigenvalues
lambda_m = -[1 / ((m - 1/2) pi kappa tau)]^2 with kappa = c_MK / v0, tau = v0 dt / L and
c_MK^2 = E_t / (2 rho r0) (``tube_eigenvalue``); Gauss-Seidel diverges when kappa tau < 2 / pi.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from workflow.gauss_seidel import gauss_seidel_spectrum


def tube_eigenvalue(m: int, tangent_modulus: float, rho: float, r0: float, v0: float, dt: float,
                    length: float) -> float:
    """The continuum theory's Gauss-Seidel eigenvalue of error mode m for the linearised tube."""
    kappa = math.sqrt(tangent_modulus / (2.0 * rho * r0)) / v0
    tau = v0 * dt / length
    return -(1.0 / ((m - 0.5) * math.pi * kappa * tau)) ** 2


def tube_critical_stiffness(tangent_modulus: float, rho: float, r0: float, v0: float, dt: float,
                            length: float) -> float:
    """The factor on ``tangent_modulus`` below which the continuum theory predicts divergence (kappa tau = 2 / pi).

    |lambda_1| scales as 1 / modulus, so the critical factor is |lambda_1| at the given modulus.
    """
    return abs(tube_eigenvalue(1, tangent_modulus, rho, r0, v0, dt, length))


# --- the theory on the stability matrix of `cosim stability` (stiffness factor x time step) -------------------

FACTOR, DT = "tube.stiffness_factor", "time.dt"


def spectral_table(scene_path: str, factors: list[float], dts: list[float], wall_law: str,
                   common: Sequence[str] = ()) -> list[dict[str, float]]:
    """Computed and theoretical Gauss-Seidel spectral radius at every (stiffness factor, dt)."""
    from cosim.scene import load_scene
    from coupler.scene_rules import resolve_plugins
    rows = []
    for factor in factors:
        for dt in dts:
            scene = load_scene(scene_path, [f'tube.wall_law="{wall_law}"', *common, f"tube.stiffness_factor={factor!r}",
                                            f"time.dt={dt!r}", f"time.end={dt!r}"])
            resolve_plugins(scene)
            tube, solid = scene["tube"], scene.component_parameters("solid")
            fluid = scene.component_parameters("fluid")
            theory = abs(tube_eigenvalue(1, factor * solid.get("E_small", 12500.0), fluid.get("rho", 1.0),
                                         math.sqrt(tube.get("a0", 1.0) / math.pi), fluid.get("v_ref", 6.0), dt,
                                         tube.get("length", 10.0)))
            rows.append({"stiffness_factor": factor, "dt": dt, "spectral_radius": gauss_seidel_spectrum(scene).radius,
                         "theory": theory})
    return rows


class TubeTheory:
    """The tube's continuum theory on a matrix whose rows are stiffness factors and columns time steps: the
    computed and theoretical rho = 1 lines, ``spectral.csv`` and ``contraction.png`` (``cosim.stability_theory``)."""

    def __init__(self, scene_path: str, axes: list[tuple[str, list[str]]], common: list[str]):
        self.scene_path, self.common = scene_path, [c for c in common if not c.startswith("coupling.acceleration")]
        self.factor_text, self.dt_text = axes[0][1], axes[1][1]
        self.factors, self.dts = [float(v) for v in self.factor_text], [float(v) for v in self.dt_text]
        self.wall_law = next((c.split("=", 1)[1].strip('"') for c in reversed(common)
                              if c.startswith("tube.wall_law=")), "piecewise")
        self.spectra: list[dict[str, float]] = []

    def prepare(self, out: Path) -> list[Path]:
        import csv
        self.spectra = spectral_table(self.scene_path, self.factors, self.dts, self.wall_law, self.common)
        path = out / "spectral.csv"
        with open(path, "w", newline="") as stream:
            writer = csv.DictWriter(stream, ["stiffness_factor", "dt", "spectral_radius", "theory"])
            writer.writeheader()
            writer.writerows(self.spectra)
        return [path]

    def draw(self, axis: Any, method: str) -> None:
        """Both rho = 1 boundaries between the grid's rows (rho scales as 1 / stiffness)."""
        spectrum = {(s["stiffness_factor"], s["dt"]): s for s in self.spectra}
        order = np.argsort(self.factors)
        logs = np.log10(np.asarray(self.factors)[order])
        for key, style, label in (("spectral_radius", "w-", "computed rho = 1"), ("theory", "w--", "theory rho = 1")):
            critical = [spectrum[(self.factors[0], dt)][key] * self.factors[0] for dt in self.dts]
            y = np.interp(np.log10(critical), logs, order.astype(float), left=-0.5, right=len(self.factors) - 0.5)
            axis.plot(np.arange(len(self.dts)), y, style, lw=1.5, label=label)
        axis.legend(loc="lower left", fontsize=7, facecolor="0.3", labelcolor="white")

    def finish(self, rows: list[dict[str, str]], out: Path) -> list[Path]:
        path = out / "contraction.png"
        plot_contraction(rows, self.spectra, path)
        return [path]


def tube_theory(scene_path: str, axes: list[tuple[str, list[str]]], common: list[str]) -> TubeTheory | None:
    """The theory of a matrix over stiffness factor (rows) and time step (columns); None for other axes."""
    return TubeTheory(scene_path, axes, common) if [key for key, _ in axes] == [FACTOR, DT] else None


def plot_contraction(table: list[dict[str, str]], spectra: list[dict[str, float]], png) -> None:
    """Plain Gauss-Seidel: measured contraction per iteration against the computed spectral radius."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spectrum = {(s["stiffness_factor"], s["dt"]): s for s in spectra}
    points = []
    for row in table:
        if row["coupling.acceleration"] != '{type="none"}' or row["contraction"] in ("", "nan"):
            continue
        s = spectrum[(float(row[FACTOR]), float(row[DT]))]
        points.append((s["spectral_radius"], s["theory"], float(row["contraction"]), row["failure"]))
    figure, axis = plt.subplots(figsize=(6, 5), constrained_layout=True)
    if points:
        rho, theory, measured, failure = zip(*points)
        span = [min(*rho, *measured) / 2, max(*rho, *measured) * 2]
        axis.plot(span, span, "k--", lw=0.8, label="measured = computed")
        for converged, marker, label in ((True, "o", "converged"), (False, "x", "diverged")):
            chosen = [i for i, f in enumerate(failure) if (f == "") == converged]
            axis.scatter([rho[i] for i in chosen], [measured[i] for i in chosen], marker=marker, label=label)
        axis.scatter(theory, measured, marker=".", color="0.6", label="against the continuum theory")
        axis.axvline(1.0, color="r", lw=0.6)
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.legend(fontsize=8)
    else:       # the contraction is measured on the unaccelerated runs only
        axis.text(0.5, 0.5, 'no run without acceleration (type "none") in this sweep', ha="center",
                  transform=axis.transAxes)
    axis.set_xlabel("spectral radius of plain Gauss-Seidel, computed [-]")
    axis.set_ylabel("measured residual contraction per iteration [-]")
    axis.grid(alpha=0.3, which="both")
    figure.savefig(png, dpi=110)
    plt.close(figure)
