"""The report's PNGs: generic ones here, a scene's own from its component package.

Generic plots know nothing of a scene's physics:
- ``monitor_<run>.png``: the monitored value of the ROM-FOM run and its FOM-FOM reference,
  with their difference in a panel of its own and the switch time marked;
- ``error_and_iterations_<reference>.png``: per reference, e(t) and the accumulated
  coupling iterations over the reference's, one panel per reference;
- ``error_vs_cost.png``: per FOM-FOM reference, the error of every ROM-FOM variant (mean e(t), or
  the monitored value's error) against its solid cost in solid-FOM-call equivalents (calls
  weighted by median compute times), the reference itself at error 0.
A scene's own plots come from functions registered under the entry-point group
``cosim.report_plots``; each is called as ``plot(run, reference, out_dir)`` and returns the
PNGs it wrote (none for a scene that is not its own). ``run`` and ``reference`` offer
``scene``, ``time``, ``fields``, ``label``, ``switch_time`` and ``predicted()``.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from cosim.registry import entry_points

HOOKS = "cosim.report_plots"


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _value_label(run) -> str:
    output = run.scene.get("output", {})
    unit = output.get("plot_unit") or "dimensionless"
    return f"{output.get('plot_label') or output.get('plot_field', 'value')} [{unit}]"


def _mark_switch(ax, run) -> None:
    if run.switch_time is not None:
        ax.axvline(run.switch_time, color="k", lw=0.8, ls=":")
        ax.annotate(f"ROM from t = {run.switch_time:g} s", (run.switch_time, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(4, -12), textcoords="offset points", fontsize=8)


def monitor(run, reference, row: dict[str, Any], out: Path) -> Path:
    """The monitored value of both runs, and their difference below."""
    plt = _pyplot()
    name, index = row["monitor"].split("[")[0], int(row["monitor"].split("[")[1][:-1])
    ours, theirs = (f.reshape(len(f), -1)[:, index] for f in (run.fields[name], reference.fields[name]))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True,
                                      gridspec_kw={"height_ratios": [2, 1]})
    top.plot(reference.time, theirs, color="0.55", lw=2.2, label=f"FOM-FOM ({reference.label})")
    top.plot(run.time, ours, color="tab:blue", lw=0.8, label=f"ROM-FOM ({run.label})")
    top.set_ylabel(_value_label(run))
    top.legend(loc="upper right", fontsize=8)
    bottom.plot(run.time, ours - theirs, color="tab:red", lw=0.8)
    bottom.axhline(0.0, color="k", lw=0.5)
    bottom.set_ylabel("ROM-FOM minus FOM-FOM\n[same unit]")
    bottom.set_xlabel("time [s]")
    for ax in (top, bottom):
        _mark_switch(ax, run)
        ax.grid(alpha=0.3)
    top.set_title(f"{row['monitor']}: ROM-FOM '{run.label}' vs FOM-FOM '{reference.label}' "
                  f"(relative L2 error {row['monitor_error']:.2e} after the switch)", fontsize=10)
    path = out / f"monitor_{run.label}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def error_and_iterations(pairs, rows, out: Path) -> list[Path]:
    """Per reference: e(t) of every run against it, and its accumulated iterations over the reference's."""
    plt = _pyplot()
    by_reference: dict[str, list] = defaultdict(list)
    for (run, reference), row in zip(pairs, rows):
        by_reference[reference.label].append((run, reference, row))
    paths = []
    for label, items in by_reference.items():
        fig = iterations_figure(plt, label, items)
        path = out / f"error_and_iterations_{label}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def noted_labels(curves: list[tuple[str, np.ndarray]]) -> list[str]:
    """Each curve's legend label; a curve equal to an earlier one, bit for bit, says under which it is hidden."""
    labels = []
    for k, (label, values) in enumerate(curves):
        twin = next((other for other, earlier in curves[:k] if np.array_equal(earlier, values)), None)
        labels.append(label if twin is None else f"{label} (identical to {twin}: hidden under it)")
    return labels


def iterations_figure(plt, label: str, items: list):
    """e(t) of every run against the reference ``label``, and its accumulated iterations over the reference's."""
    fig, (ax_e, ax_i) = plt.subplots(2, 1, figsize=(10, 7), sharex=True, constrained_layout=True)
    errors = [(run.label, run.time[run.predicted()], np.maximum(row["_e"][run.predicted()], 1e-16))
              for run, _, row in items if "_e" in row]
    for (_, time, e), text in zip(errors, noted_labels([(name, e) for name, _, e in errors])):
        ax_e.semilogy(time, e, lw=0.8, label=text)
    ratios = [(run.label, run.time, 100 * (np.cumsum(run.iterations) / np.cumsum(reference.iterations) - 1))
              for run, reference, _ in items]
    for (_, time, ratio), text in zip(ratios, noted_labels([(name, r) for name, _, r in ratios])):
        ax_i.plot(time, ratio, lw=1.0, label=text)
    _mark_switch(ax_e, items[0][0])
    ax_e.set_ylabel("e(t) = ||U - U_rom|| / mean ||U - U_rest||\n[dimensionless]")
    ax_i.set_ylabel("accumulated coupling iterations,\nROM-FOM over FOM-FOM [%]")
    ax_i.set_xlabel("time [s]")
    ax_i.axhline(0, color="k", lw=0.5)
    if not errors:       # a run against a full-order run has no ROM and no e(t)
        ax_e.text(0.5, 0.5, "no ROM in these runs: no e(t)", ha="center", va="center", transform=ax_e.transAxes)
    for ax in (ax_e, ax_i):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    ax_e.set_title(f"ROM-FOM runs against the FOM-FOM reference '{label}'")
    return fig


def solid_cost(row: dict[str, Any]) -> float | None:
    """Solid cost of a ROM-FOM run in solid-FOM-call equivalents (calls weighted by their median CPU time)."""
    solid = row.get("solid")
    if not solid:
        return None
    ratio = solid["rom_cpu_quartiles_s"][1] / solid["fom_cpu_quartiles_s"][1]
    return row["fom_solid_calls"] + row["rom_solid_calls"] * ratio


def _error_of(row: dict[str, Any]) -> tuple[float, str]:
    """The run's error: e(t) averaged over the predicted windows where the report has it, else the monitor's."""
    if "displacement_error" in row:
        return row["displacement_error"]["mean"], "mean e(t) over the predicted windows"
    return row["monitor_error"], f"relative L2 error of {row['monitor']}"


def error_vs_cost(pairs, rows, out: Path) -> Path:
    """Error against solid cost, one panel per FOM-FOM reference: the reference's cost as a line (its error is 0)
    and every ROM-FOM variant run against it (labelled with its modes, regressor and decoder). Runs of one model
    (a ROM and its FMU) are joined: their costs differ only by the timing of their calls. The legend goes below
    the axes, where it hides no point."""
    plt = _pyplot()
    by_reference: dict[str, list] = defaultdict(list)
    for (run, reference), row in zip(pairs, rows):
        if solid_cost(row) is not None:
            by_reference[reference.label].append((run.label, row))
    fig = cost_figure(plt, by_reference)
    path = out / "error_vs_cost.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def cost_figure(plt, by_reference: dict[str, list]):
    """The panels of ``error_vs_cost``: (run label, report row) pairs by reference label."""
    import json
    n = max(len(by_reference), 1)
    rows_of_legend = max((len(items) for items in by_reference.values()), default=1) + 2
    fig, axes = plt.subplots(1, n, figsize=(6.5 * n, 4.5 + 0.22 * rows_of_legend), constrained_layout=True,
                             squeeze=False)
    for ax, (label, items) in zip(axes[0], by_reference.items()):
        calls = items[0][1]["reference_solid_calls"]
        ax.axvline(calls, color="k", ls="--", lw=1, label=f"FOM-FOM '{label}': {calls} solid calls (error 0)")
        models: dict[str, list[tuple[float, float, str]]] = defaultdict(list)
        for run_label, row in items:
            error, kind = _error_of(row)
            model = row.get("model", {})
            variant = (f"r_f={model.get('encoder', {}).get('modes')}, {model.get('regressor', {}).get('type')}, "
                       f"{model.get('decoder', {}).get('type')}" if model else "")
            key = json.dumps(model, sort_keys=True)
            twin = next((name for _, _, name in models[key]), None) if model else None
            same = f" (the model of {twin}: the cost differs by its calls' timing)" if twin else ""
            cost = float(solid_cost(row) or 0.0)        # the rows here all have a cost
            ax.plot([cost], [100 * max(error, 1e-12)], "o", label=f"{run_label}: {variant}{same}")
            models[key].append((cost, 100 * max(error, 1e-12), run_label))
        for points in models.values():
            if len(points) > 1:
                ax.plot([p[0] for p in points], [p[1] for p in points], color="0.6", lw=0.8, zorder=0)
        costs = [calls] + [solid_cost(row) for _, row in items]
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(0.7 * min(costs), 1.4 * max(costs))
        ax.set_xlabel("solid cost [solid-FOM-call equivalents: calls x median CPU time / FOM median]")
        ax.set_ylabel(f"{kind} [%]")
        ax.set_title(f"reference '{label}'", fontsize=10)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1, frameon=False)
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Accuracy against solid cost: ROM-FOM variants and their FOM-FOM reference")
    return fig


def scene_plots(run, reference, out: Path) -> list[Path]:
    """The plots the run's case registers (the entry point of ``HOOKS`` named by the scene's ``case``)."""
    case = run.scene.get("case", "")
    return [path for point in entry_points(group=HOOKS) if case and point.name == case
            for path in point.load()(run, reference, out)]


def error_vs_trust(run, row: dict[str, Any], out: Path) -> Path | None:
    """Per window: the ROM's displacement error against how far its input lay beyond the training range."""
    if run.trust is None or "_e" not in row:
        return None
    plt = _pyplot()
    fig = trust_figure(plt, run, row)
    path = out / f"error_vs_trust_{run.label}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trust_figure(plt, run, row: dict[str, Any]):
    """The error of each served window against how far beyond its training range the ROM's input lay; windows
    inside the range at a true 0, on an axis that is linear there."""
    served = np.isfinite(run.trust)
    excess, error = run.trust[served], np.maximum(row["_e"][served], 1e-16)
    inside = excess <= 0
    fig, ax = plt.subplots(figsize=(6, 4.5), constrained_layout=True)
    ax.scatter(np.zeros(int(inside.sum())), error[inside], s=8, color="tab:blue",
               label=f"{int(inside.sum())} windows inside the range (at 0)")
    if (~inside).any():
        ax.scatter(excess[~inside], error[~inside], s=8, color="tab:orange",
                   label=f"{int((~inside).sum())} windows beyond it")
        # linear near 0, where the windows inside the range sit, logarithmic beyond the smallest excess
        ax.set_xscale("symlog", linthresh=float(excess[~inside].min()))
        title = f"{run.label}: error against trust ({row.get('rom_fallback_windows', 0)} windows fell back)"
    else:
        title = f"{run.label}: the ROM never left its training range"
    ax.set_yscale("log")
    ax.set_xlabel("ROM input beyond its training range [range widths] (0: inside)")
    ax.set_ylabel("displacement error e(t) [-]")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig


def write_plots(pairs, rows, out: Path) -> list[Path]:
    """Every PNG of the report."""
    paths = [monitor(run, reference, row, out) for (run, reference), row in zip(pairs, rows)]
    paths += [p for p in (error_vs_trust(run, row, out) for (run, _), row in zip(pairs, rows)) if p is not None]
    paths += error_and_iterations(pairs, rows, out)
    paths.append(error_vs_cost(pairs, rows, out))
    for run, reference in pairs:
        paths += scene_plots(run, reference, out)
    return paths
