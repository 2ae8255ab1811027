"""Mok's run plots (hook ``mok`` of the ``cosim.run_plots`` entry points) and point A against the literature.

- ``points.png``: the x-displacement of point A and point B over time with the band the literature gives
  (shared/scenes/mok.md), and coupling iterations per window;
- ``last_window.png``: fluid speed on the deformed fluid mesh and the deformed wall at the end of the run.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cases.last_window import plot_last_window
from cosim.plots import iterations_panel
from cosim.results import RunResults

# point A's x-displacement as Mok (2001) and Valdes (2007) show it: the band the two curves span
BAND: dict[str, tuple[float, float]] = {"max_cm": (7.8, 8.2), "max_time_s": (8.0, 9.2), "final_cm": (6.0, 6.3),
                                        "point_b_max_cm": (2.7, 2.9)}
FINAL_TIME = 25.0
STRUCTURE = "structure"


@dataclass
class PointA:
    """Point A's x-displacement: its maximum, when, and at the end; point B's maximum; each against the band."""

    max_cm: float
    max_time_s: float
    final_cm: float
    final_time_s: float
    point_b_max_cm: float

    @property
    def in_band(self) -> dict[str, bool]:
        low, high = BAND["max_cm"]
        t_low, t_high = BAND["max_time_s"]
        f_low, f_high = BAND["final_cm"]
        b_low, b_high = BAND["point_b_max_cm"]
        return {"max": low <= self.max_cm <= high, "max_time": t_low <= self.max_time_s <= t_high,
                "final": f_low <= self.final_cm <= f_high and abs(self.final_time_s - FINAL_TIME) < 1e-9,
                "point_b_max": b_low <= self.point_b_max_cm <= b_high}

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "in_band": self.in_band}


def points(run: RunResults) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(window end times, point A (n, 2), point B (n, 2)) of each window's converged structure call, metres."""
    calls = run.calls(STRUCTURE, converged_only=True)
    return run.windows.time[:len(calls.window)], calls.outputs["point_a"], calls.outputs["point_b"]


def point_a_summary(results: str | Path) -> PointA:
    """Point A of a run against the literature's band."""
    with RunResults(results) as run:
        time, a, b = points(run)
    peak = int(np.argmax(a[:, 0]))
    return PointA(float(a[peak, 0] * 100), float(time[peak]), float(a[-1, 0] * 100), float(time[-1]),
                  float(b[:, 0].max() * 100))


def run_plots(results: str | Path, out_dir: str | Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    out_dir = Path(out_dir)
    with RunResults(results) as run:
        windows = run.windows
        time, a, b = points(run)
        finals = {name: run.component(name).final for name in run.component_names()}
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True, constrained_layout=True,
                                         gridspec_kw={"height_ratios": [2, 1]})
    top.plot(time, a[:, 0] * 100, lw=1.2, label="point A (0.5015, 0.25)")
    top.plot(time, b[:, 0] * 100, lw=1.0, label="point B (0.5015, 0.125)")
    (t0, t1), (d0, d1) = BAND["max_time_s"], BAND["max_cm"]
    top.add_patch(Rectangle((t0, d0), t1 - t0, d1 - d0, color="tab:red", alpha=0.35,
                            label="literature: A's maximum (Mok, Valdes)"))
    f0, f1 = BAND["final_cm"]
    top.add_patch(Rectangle((FINAL_TIME - 0.4, f0), 0.4, f1 - f0, color="tab:purple", alpha=0.5,
                            label="literature: A at t = 25 s"))
    b0, b1 = BAND["point_b_max_cm"]
    top.axhspan(b0, b1, color="tab:orange", alpha=0.15, label="literature: B's maximum")
    top.set_ylabel("x-displacement [cm]")
    top.legend(loc="lower right", fontsize=8)
    top.grid(alpha=0.3)
    iterations_panel(bottom, windows.time, windows.iterations)
    written = [out_dir / "points.png"]
    figure.savefig(written[-1], dpi=110)
    plt.close(figure)
    final_time = float(windows.time[-1]) if len(windows) else 0.0
    picture = plot_last_window(finals, final_time, out_dir / "last_window.png", figsize=(11, 3.6))
    if picture is not None:
        written.append(picture)
    return written



run_plots.recorded = (STRUCTURE,)   # type: ignore[attr-defined]  # the coupler checks the scene records them

def report_metrics(run: Any, reference: Any) -> dict[str, Any]:
    """Report hook (``cosim.report_metrics``): point A's x-displacement, ROM-FOM against FOM-FOM over the windows the
    ROM served: the largest difference and the relative L2 error, over the FOM-FOM run's deflection (its largest
    |x| over the run), and both runs' point A against the literature."""
    with RunResults(run.path) as ours, RunResults(reference.path) as theirs:
        a_ours, a_theirs = points(ours)[1][:, 0], points(theirs)[1][:, 0]
    served = run.predicted()[:len(a_ours)]
    deflection = float(np.abs(a_theirs).max())
    difference = np.abs(a_ours - a_theirs[:len(a_ours)])[served]
    return {"point_a": {
        "max_difference_cm": float(difference.max() * 100) if difference.size else float("nan"),
        "max_over_deflection": float(difference.max() / deflection) if difference.size else float("nan"),
        "l2_over_deflection": float(np.sqrt(np.mean(difference ** 2)) / deflection) if difference.size else float("nan"),
        "fom_deflection_cm": deflection * 100,
        "rom_fom": point_a_summary(run.path).as_dict(), "fom_fom": point_a_summary(reference.path).as_dict()}}
