"""The elastic tube's stability: the continuum theory of plain Gauss-Seidel coupling, and the stability matrix
(stiffness x time step x acceleration) that ``cosim stability`` runs as a sweep.

For the linearised tube the continuum theory gives the eigenvalues
lambda_m = -[1 / ((m - 1/2) pi kappa tau)]^2 with kappa = c_MK / v0, tau = v0 dt / L and
c_MK^2 = E_t / (2 rho r0) (``tube_eigenvalue``); Gauss-Seidel diverges when kappa tau < 2 / pi.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from coupler.stability import gauss_seidel_spectrum


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


# --- the stability matrix: a sweep over stiffness and time step for several methods --------------

METHODS = {
    "none": '{type="none"}',
    "constant": '{type="constant", data=["section"], relaxation=0.1}',
    "aitken": '{type="aitken", data=["section"], initial_relaxation=0.01}',
    "iqn-ils": '{type="iqn-ils", data=["section"], initial_relaxation=0.01, reused_time_windows=8}',
    "iqn-ils-reuse0": '{type="iqn-ils", data=["section"], initial_relaxation=0.01, reused_time_windows=0}',
    "iqn-imvj": '{type="iqn-imvj", data=["section"], initial_relaxation=0.01}',
    "iqn-surrogate": '{type="iqn-surrogate", data=["section"], initial_relaxation=0.01, reused_time_windows=8}',
}
# what a method needs besides its acceleration table: the online surrogate, trained on the first windows
METHOD_SETTINGS = {"iqn-surrogate": ["coupling.surrogate={start_window=6, retrain_every=5}"]}
MATRIX_KEYS = ["coupling.acceleration", "tube.stiffness_factor", "time.dt"]
MATRIX_SETTINGS = ['coupling.convergence=[{data="section", type="relative", limit=1e-8}]',
                   "coupling.max_iterations=200"]


def matrix_runs(factors: list[float], dts: list[float], methods: list[str], windows: int, wall_law: str,
                common: Sequence[str] = ()) -> list:
    """The sweep of the stability matrix: every (method, stiffness factor, dt), ``windows`` windows each."""
    from coupler.sweep import SweepRun
    runs = []
    for method in methods:
        for factor in factors:
            for dt in dts:
                runs.append(SweepRun((*MATRIX_SETTINGS, f'tube.wall_law="{wall_law}"', *common,
                                      f"coupling.acceleration={METHODS[method]}", *METHOD_SETTINGS.get(method, []),
                                      f"tube.stiffness_factor={factor!r}",
                                      f"time.dt={dt!r}", f"time.end={windows * dt!r}")))
    return runs


def spectral_table(scene_path: str, factors: list[float], dts: list[float], wall_law: str,
                   common: Sequence[str] = ()) -> list[dict[str, float]]:
    """Computed and theoretical Gauss-Seidel spectral radius at every (stiffness factor, dt)."""
    from cosim.scene import load_scene
    from coupler.plugins import resolve_plugins
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


def plot_matrix(table: list[dict[str, str]], spectra: list[dict[str, float]], methods: list[str],
                factors: list[float], dts: list[float], png) -> None:
    """Heat maps of mean iterations per method, failures marked, both stability boundaries drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    columns = min(len(methods), 3)
    rows = math.ceil(len(methods) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.6 * columns, 3.9 * rows), squeeze=False,
                                constrained_layout=True)
    norm = LogNorm(vmin=1, vmax=200)
    letters = {"diverged": "D", "stalled": "S", "max-iterations": "M", "non-finite": "N", "component-error": "C",
               "error": "E"}
    x_of, y_of = {dt: i for i, dt in enumerate(sorted(dts, reverse=True))}, {f: j for j, f in enumerate(sorted(factors))}
    spectrum = {(s["stiffness_factor"], s["dt"]): s for s in spectra}
    for axis, method in zip(axes.flat, methods):
        grid = np.full((len(factors), len(dts)), np.nan)
        for row in table:
            if row["coupling.acceleration"] != METHODS[method]:
                continue
            factor, dt = float(row["tube.stiffness_factor"]), float(row["time.dt"])
            i, j = y_of[factor], x_of[dt]
            if row["failure"]:
                axis.text(j, i, letters.get(row["failure"], "?"), ha="center", va="center", color="red",
                          fontsize=13, fontweight="bold")
            else:
                grid[i, j] = float(row["mean_iterations"])
                axis.text(j, i, f"{grid[i, j]:.1f}", ha="center", va="center", fontsize=8, color="white")
        image = axis.imshow(grid, origin="lower", cmap="viridis", norm=norm, aspect="auto")
        # the boundaries: rho = 1 between grid rows (rho scales as 1 / stiffness)
        for key, style, label in (("spectral_radius", "w-", "computed rho = 1"), ("theory", "w--", "theory rho = 1")):
            critical = [spectrum[(factors[0], dt)][key] * factors[0] for dt in sorted(dts, reverse=True)]
            logs = np.log10(sorted(factors))
            y = np.interp(np.log10(critical), logs, np.arange(len(factors)), left=-0.5, right=len(factors) - 0.5)
            axis.plot(np.arange(len(dts)), y, style, lw=1.5, label=label)
        axis.set_xticks(range(len(dts)), [f"{dt:g}" for dt in sorted(dts, reverse=True)])
        axis.set_yticks(range(len(factors)), [f"{f:g}" for f in sorted(factors)])
        axis.set_xlabel("time step dt [s]")
        axis.set_ylabel("stiffness factor [-]")
        axis.set_title(method)
        axis.legend(loc="lower left", fontsize=7, facecolor="0.3", labelcolor="white")
    for axis in list(axes.flat)[len(methods):]:
        axis.set_visible(False)
    figure.colorbar(image, ax=axes, label="mean coupling iterations per window [count]", shrink=0.8)
    figure.suptitle("tube stability matrix (D diverged, S stalled, M max iterations, N non-finite, C component error)")
    figure.savefig(png, dpi=110)
    plt.close(figure)


def plot_contraction(table: list[dict[str, str]], spectra: list[dict[str, float]], png) -> None:
    """Plain Gauss-Seidel: measured contraction per iteration against the computed spectral radius."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spectrum = {(s["stiffness_factor"], s["dt"]): s for s in spectra}
    points = []
    for row in table:
        if row["coupling.acceleration"] != METHODS["none"] or row["contraction"] in ("", "nan"):
            continue
        s = spectrum[(float(row["tube.stiffness_factor"]), float(row["time.dt"]))]
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
    axis.set_xlabel("spectral radius of plain Gauss-Seidel, computed [-]")
    axis.set_ylabel("measured residual contraction per iteration [-]")
    axis.legend(fontsize=8)
    axis.grid(alpha=0.3, which="both")
    figure.savefig(png, dpi=110)
    plt.close(figure)
