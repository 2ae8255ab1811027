"""Run plots of the double flap (hook ``double_flap`` of the ``cosim.run_plots`` entry points).

- ``tips.png``: x-displacement of the left and right flap tips over time, and coupling
  iterations per window;
- ``last_window.png``: fluid velocity magnitude on the deformed fluid mesh and the deformed
  solid at the end of the run (from the arrays both components hand back at terminate).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cases.last_window import plot_last_window
from cosim.plots import iterations_panel
from cosim.results import RunResults

TIPS = {"left": (1.2, 0.28), "right": (1.52, 0.28)}


def tip_displacements(run: RunResults) -> dict[str, np.ndarray]:
    """x-displacement of each flap tip per window (solid interface nodes nearest the undeformed tips)."""
    displacement = run.fields()["displacement"]
    interface = next(record.meshes["interface"] for record in map(run.component, run.component_names())
                     if "interface" in record.meshes and len(record.meshes["interface"]) == displacement.shape[1]
                     and record.attributes.get("participant") == "solid")
    nodes = {side: int(np.argmin(np.linalg.norm(interface - xy, axis=1))) for side, xy in TIPS.items()}
    return {side: displacement[:, node, 0] for side, node in nodes.items()}


def run_plots(results: str | Path, out_dir: str | Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    with RunResults(results) as run:
        windows = run.windows
        tips = tip_displacements(run)
        finals = {name: run.component(name).final for name in run.component_names()}
    written = []
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, constrained_layout=True)
    for side, values in tips.items():
        top.plot(windows.time[:len(values)], values * 1e3, lw=1.0, label=f"{side} tip")
    top.set_ylabel("tip x-displacement [mm]")
    top.legend(loc="upper left")
    top.grid(alpha=0.3)
    iterations_panel(bottom, windows.time, windows.iterations)
    written.append(out_dir / "tips.png")
    figure.savefig(written[-1], dpi=110)
    plt.close(figure)

    time = windows.time[-1] if len(windows) else 0.0
    picture = plot_last_window(finals, time, out_dir / "last_window.png")
    if picture is not None:
        written.append(picture)
    return written


def _tips_of(run) -> dict[str, np.ndarray]:
    with RunResults(run.path) as results:
        return tip_displacements(results)


def report_plots(run, reference, out: Path) -> list[Path]:
    """Report hook (``cosim.report_plots``): ``tips_<run>.png``, the left and right tip x-displacement of
    ROM-FOM against FOM-FOM with their difference, and ``phase_<run>.png``, the phase space (u_L, u_R)
    over the predicted windows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ours, theirs = _tips_of(run), _tips_of(reference)
    predicted = run.predicted()
    fig, axes = plt.subplots(2, 2, figsize=(12, 6), sharex=True, constrained_layout=True,
                             gridspec_kw={"height_ratios": [2, 1]})
    for column, side in enumerate(TIPS):
        top, bottom = axes[0, column], axes[1, column]
        top.plot(reference.time, theirs[side] * 1e3, color="0.55", lw=2.2, label=f"FOM-FOM ({reference.label})")
        top.plot(run.time, ours[side] * 1e3, color="tab:blue", lw=0.8, label=f"ROM-FOM ({run.label})")
        amplitude = np.ptp(theirs[side][predicted]) if predicted.any() else np.nan
        difference = (ours[side] - theirs[side]) * 1e3
        worst = np.abs(difference[predicted]).max() / (amplitude * 1e3) if predicted.any() else np.nan
        top.set_title(f"{side} tip: max |ROM-FOM - FOM-FOM| = {worst:.2%} of the FOM amplitude after the switch",
                      fontsize=9)
        top.set_ylabel("tip x-displacement [mm]")
        bottom.plot(run.time, difference, color="tab:red", lw=0.8)
        bottom.set_ylabel("ROM-FOM minus FOM-FOM [mm]")
        bottom.set_xlabel("time [s]")
        for ax in (top, bottom):
            if run.switch_time is not None:
                ax.axvline(run.switch_time, color="k", lw=0.8, ls=":")
            ax.grid(alpha=0.3)
        top.legend(fontsize=8, loc="lower right")
    paths = [out / f"tips_{run.label}.png"]
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 5.5), constrained_layout=True)
    ax.plot(theirs["left"][predicted] * 1e3, theirs["right"][predicted] * 1e3, color="0.55", lw=2.2,
            label=f"FOM-FOM ({reference.label})")
    ax.plot(ours["left"][predicted] * 1e3, ours["right"][predicted] * 1e3, color="tab:blue", lw=0.8,
            label=f"ROM-FOM ({run.label})")
    ax.set_xlabel("left tip x-displacement u_L [mm]")
    ax.set_ylabel("right tip x-displacement u_R [mm]")
    start = f"t > {run.switch_time:g} s" if run.switch_time is not None else "all windows"
    ax.set_title(f"phase space of the flap tips, {start}", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    paths.append(out / f"phase_{run.label}.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths


def report_metrics(run, reference) -> dict:
    """Report hook (``cosim.report_metrics``): per flap tip, the largest |ROM-FOM - FOM-FOM| x-displacement over
    the predicted windows, in mm and over the FOM-FOM amplitude there."""
    ours, theirs = _tips_of(run), _tips_of(reference)
    predicted = run.predicted()
    tips = {}
    for side in TIPS:
        difference = np.abs(ours[side] - theirs[side])[predicted]
        amplitude = float(np.ptp(theirs[side][predicted]))
        tips[side] = {"max_difference_mm": float(difference.max() * 1e3),
                      "max_over_amplitude": float(difference.max() / amplitude) if amplitude > 0 else float("nan"),
                      "fom_amplitude_mm": amplitude * 1e3}
    return {"tips": tips}
