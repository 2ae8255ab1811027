"""The stability matrix of any scene: one or two swept parameters crossed with accelerations, run as a sweep.

The parameters come from the scene's ``[stability]`` section or the command line (``key=v1,v2,...``, as
``cosim sweep --grid``); each run is the scene with those values, the section's ``settings`` (a criterion
and an iteration limit fit for the matrix, say) and one acceleration of ``METHODS`` on the data the scene
accelerates, for ``windows`` windows. The sweep's table classes every failed run (diverged, stalled,
max-iterations, non-finite, component-error); ``matrix.md`` and ``stability.png`` show mean iterations
per window, or the failure's class, per method. A case may add its theory: an entry point of the group
``cosim.stability_theory`` named by the scene's ``case`` (the tube: its continuum theory's rho = 1 line
and the measured contraction of plain Gauss-Seidel).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from cosim.errors import SceneError
from cosim.registry import entry_points
from cosim.schema import Value, validate

# each method's acceleration table, without its data (the scene's accelerated data are added)
METHODS: dict[str, dict[str, Any]] = {
    "none": {"type": "none"},
    "constant": {"type": "constant", "relaxation": 0.1},
    "aitken": {"type": "aitken", "initial_relaxation": 0.01},
    "iqn-ils": {"type": "iqn-ils", "initial_relaxation": 0.01, "reused_time_windows": 8},
    "iqn-ils-no-reuse": {"type": "iqn-ils", "initial_relaxation": 0.01, "reused_time_windows": 0},
    "iqn-imvj": {"type": "iqn-imvj", "initial_relaxation": 0.01},
    "iqn-surrogate": {"type": "iqn-surrogate", "initial_relaxation": 0.01, "reused_time_windows": 8},
}
# what a method needs besides its acceleration table: the online surrogate, trained on the first windows
METHOD_SETTINGS = {"iqn-surrogate": ["coupling.surrogate={start_window=6, retrain_every=5}"]}
ACCELERATION = "coupling.acceleration"
FAILURE_LETTERS = {"diverged": "D", "stalled": "S", "max-iterations": "M", "non-finite": "N",
                   "component-error": "C", "error": "E"}
THEORY = "cosim.stability_theory"
# a scene's [stability] table (the cosim.scene_rules entry point "stability")
STABILITY: dict[str, Any] = {"grid": [], "methods": [], "windows": Value(20, low=1), "settings": []}
MEANINGS = {
    "stability.grid": "`cosim stability`: the swept parameters, \"key=v1,v2,...\" each (one or two)",
    "stability.methods": "`cosim stability`: the accelerations crossed with the grid (default: all)",
    "stability.windows": "`cosim stability`: windows per run",
    "stability.settings": "`cosim stability`: \"key=value\" overrides of every run of the matrix (a criterion and "
                          "an iteration limit fit for it, say)",
}


class StabilityTable:
    """A scene's ``[stability]`` table: the grid, methods, windows and settings of ``cosim stability``."""

    tables = ("stability",)
    schemas = {"stability": STABILITY}
    meanings = MEANINGS

    def validate(self, raw: dict[str, Any], data: dict[str, Any], source: str) -> None:
        data["stability"] = validate(raw.get("stability", {}), STABILITY, "stability.", source)


RULES = StabilityTable()


class Theory(Protocol):
    """What a case adds to its matrix (``cosim.stability_theory``): files before the runs, lines on each panel,
    files after."""

    def prepare(self, out: Path) -> list[Path]: ...

    def draw(self, axis: Any, method: str) -> None: ...

    def finish(self, rows: list[dict[str, str]], out: Path) -> list[Path]: ...


def toml_inline(table: dict[str, Any]) -> str:
    """A flat table as a TOML inline table (strings, numbers, lists of strings)."""
    def value(v: Any) -> str:
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)
    return "{" + ", ".join(f"{key}={value(v)}" for key, v in table.items()) + "}"


def method_table(method: str, data: list[str]) -> str:
    """The acceleration override of ``method`` on ``data``."""
    if method not in METHODS:
        raise SceneError(f"unknown stability method '{method}'; known: {', '.join(METHODS)}")
    table = dict(METHODS[method])
    if table["type"] != "none":
        table = {"type": table.pop("type"), "data": list(data), **table}
    return toml_inline(table)


def accelerated_data(scene: Any) -> list[str]:
    """The data the scene's acceleration works on, else what the second participant sends back to the first."""
    acceleration = scene["coupling"]["acceleration"]
    if isinstance(acceleration, dict) and acceleration.get("data"):
        return list(acceleration["data"])
    first, second = scene["coupling"]["participants"]
    feedback = [e["data"] for e in scene["exchange"] if e["from"] == second and e["to"] == first]
    if not feedback:
        raise SceneError("the scene has no data sent from its second participant to its first to accelerate")
    return feedback


def parse_axes(grids: Sequence[str]) -> list[tuple[str, list[str]]]:
    """``key=v1,v2,...`` items as (key, values); one or two axes."""
    from workflow.sweep import split_values
    axes = []
    for text in grids:
        if not isinstance(text, str):
            raise SceneError(f"stability grid item {text!r} is not a string \"key=v1,v2,...\"")
        key, sep, values = text.partition("=")
        if not sep or not key.strip() or not split_values(values):
            raise SceneError(f"stability grid '{text}' is not of the form key=v1,v2,...")
        axes.append((key.strip(), split_values(values)))
    if not 1 <= len(axes) <= 2:
        raise SceneError(f"a stability matrix sweeps one or two parameters; got {len(axes)} "
                         f"({', '.join(k for k, _ in axes) or 'none'}): give stability.grid or --grid")
    if len({k for k, _ in axes}) != len(axes):
        raise SceneError("stability grid names the same key twice")
    return axes


def matrix_runs(axes: list[tuple[str, list[str]]], methods: Sequence[str], data: list[str], windows: int, dt_of: Any,
                start: float, common: Sequence[str] = ()) -> list:
    """Every (method, grid point) as a sweep run of ``windows`` windows (``dt_of(point)``: that run's time step)."""
    import itertools

    from workflow.sweep import SweepRun
    runs = []
    for method in methods:
        for values in itertools.product(*(v for _, v in axes)):
            point = dict(zip((k for k, _ in axes), values))
            end = start + windows * dt_of(point)
            runs.append(SweepRun((*common, f"{ACCELERATION}={method_table(method, data)}",
                                  *METHOD_SETTINGS.get(method, []),
                                  *(f"{k}={v}" for k, v in point.items()), f"time.end={end!r}")))
    return runs


def load_theory(case: str, scene_path: str, axes: list[tuple[str, list[str]]], common: Sequence[str]) -> Theory | None:
    """The case's theory for this matrix, if the case registers one and it applies to these axes."""
    if not case:
        return None
    for entry in entry_points(group=THEORY):
        if entry.name == case:
            return entry.load()(scene_path, axes, list(common))
    return None


def matrix_markdown(rows: list[dict[str, str]], axes: list[tuple[str, list[str]]], methods: Sequence[str],
                    data: list[str]) -> str:
    """Mean iterations per window (or the failure's class) per grid point and method, as a Markdown table."""
    cells = {}
    for row in rows:
        method = next(m for m in methods if row[ACCELERATION] == method_table(m, data))
        point = tuple(row[k] for k, _ in axes)
        cells[method, point] = row["failure"] or f"{float(row['mean_iterations']):.2f}"
    import itertools
    header = [*(k for k, _ in axes), *methods]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for point in itertools.product(*(v for _, v in axes)):
        lines.append("| " + " | ".join([*point, *(cells.get((m, point), "-") for m in methods)]) + " |")
    return "\n".join(lines) + "\n"


def plot_matrix(rows: list[dict[str, str]], axes: list[tuple[str, list[str]]], methods: Sequence[str],
                data: list[str], png: Path, title: str, theory: Theory | None = None) -> Path:
    """Heat maps of mean iterations per method over the grid, failures marked by their class's letter."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    (y_key, y_values), (x_key, x_values) = axes[0], (axes[1] if len(axes) > 1 else ("", [""]))
    columns = min(len(methods), 3)
    panels = math.ceil(len(methods) / columns)
    figure, grid_axes = plt.subplots(panels, columns, figsize=(4.6 * columns, 3.9 * panels), squeeze=False,
                                     constrained_layout=True)
    highest = max([float(r["mean_iterations"]) for r in rows if not r["failure"]] + [10.0])
    norm = LogNorm(vmin=1, vmax=highest)
    image = None
    for axis, method in zip(grid_axes.flat, methods):
        table = method_table(method, data)
        grid = np.full((len(y_values), len(x_values)), np.nan)
        for row in rows:
            if row[ACCELERATION] != table:
                continue
            i, j = y_values.index(row[y_key]), x_values.index(row[x_key]) if x_key else 0
            if row["failure"]:
                axis.text(j, i, FAILURE_LETTERS.get(row["failure"], "?"), ha="center", va="center", color="red",
                          fontsize=13, fontweight="bold")
            else:
                grid[i, j] = float(row["mean_iterations"])
                axis.text(j, i, f"{grid[i, j]:.1f}", ha="center", va="center", fontsize=8, color="white")
        image = axis.imshow(grid, origin="lower", cmap="viridis", norm=norm, aspect="auto")
        if theory is not None:
            theory.draw(axis, method)
        axis.set_xticks(range(len(x_values)), x_values)
        axis.set_yticks(range(len(y_values)), y_values)
        axis.set_xlabel(x_key)
        axis.set_ylabel(y_key)
        axis.set_title(method)
    for axis in list(grid_axes.flat)[len(methods):]:
        axis.set_visible(False)
    if image is not None:
        figure.colorbar(image, ax=grid_axes, label="mean coupling iterations per window [count]", shrink=0.8)
    figure.suptitle(f"{title} (D diverged, S stalled, M max iterations, N non-finite, C component error)")
    figure.savefig(png, dpi=110)
    plt.close(figure)
    return png
