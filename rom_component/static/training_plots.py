"""The PNGs of ``cosim train``, written next to the model file (``<model>_<name>.png``).

- ``singular_values``: the normalised singular values of the force and displacement snapshots,
  the chosen r_f and r_u marked;
- ``holdout``: the hold-out error against r_f for each split (random snapshots, whole windows);
- ``terms`` (sparse polynomial only): which of the regression's terms (linear x_i, then the
  products x_i x_j) survive the Lasso-LARS/BIC selection, per reduced displacement.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _finish(plt, fig, ax, xlabel: str, ylabel: str, title: str, path: Path) -> Path:
    """Labels, legend and grid of a line plot, saved and closed."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def holdout_figure(plt, tables: dict):
    """The hold-out error against r_f: one colour per r_u (a sequential colour map, as many as there are), one line
    style per split, the legend beside the axes, not over the curves."""
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    styles = {"windows": "-", "snapshots": "--"}
    for split, table in tables.items():
        colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, len(table.disp_modes)))
        for i, r in enumerate(table.disp_modes):
            ax.semilogy(table.force_modes, 100 * table.relative[i], marker="o", ms=3, ls=styles.get(split, ":"),
                        color=colours[i], label=f"r_u = {r}, split by {split}")
    bests = "; ".join(f"split by {split}: best r_f = {t.best[0]}" + (f", chosen {t.chosen[0]}" if t.chosen != t.best
                                                                      else "") for split, t in tables.items())
    ax.set_xlabel("force modes r_f [count]")
    ax.set_ylabel("hold-out error, mean ||U - ROM(F)|| / mean ||U - mean|| [%]")
    ax.set_title(f"Hold-out cross-validation of the number of force modes\n{bests}", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.grid(alpha=0.3, which="both")
    return fig


def write_training_plots(model_path: str | Path, estimator, tables: dict) -> list[Path]:
    """Every PNG for a fitted ``SolidRom`` and its hold-out tables (by split name)."""
    plt = _pyplot()
    stem = Path(model_path).with_suffix("")
    paths = []
    r_f, r_u = estimator.modes
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for values, chosen, label in ((estimator.encoder_.singular_values_, r_f, "interface force"),
                                  (estimator.decoder_.singular_values_, r_u, "displacement field")):
        s = values / values[0]
        line, = ax.semilogy(np.arange(1, len(s) + 1), s, lw=1.2, label=f"{label} (r = {chosen})")
        ax.plot([chosen], [s[chosen - 1]], "o", color=line.get_color())
    ax.set_xscale("log")
    paths.append(_finish(plt, fig, ax, "mode number [count]", "singular value / largest [dimensionless]",
                         "Singular values of the training snapshots (centred)", Path(f"{stem}_singular_values.png")))

    if tables:
        fig = holdout_figure(plt, tables)
        fig.savefig(Path(f"{stem}_holdout.png"), dpi=110)
        plt.close(fig)
        paths.append(Path(f"{stem}_holdout.png"))

    coefficients = getattr(estimator.regressor_, "coefficients_", None)
    if coefficients is not None:
        n = estimator.regressor_.n_inputs_
        cubic = len(estimator.regressor_.cube_i_)
        products = len(estimator.regressor_.quad_i_) + cubic
        order = np.r_[products:products + n, 0:products]         # linear terms first, then the products
        kept = coefficients[order].T != 0                        # (r_u, terms)
        fig, ax = plt.subplots(figsize=(11, 3.2), constrained_layout=True)
        ax.imshow(kept, aspect="auto", interpolation="nearest", cmap="Greys")
        ax.axvline(n - 0.5, color="tab:red", lw=0.8)
        ax.set_xlabel(f"polynomial term [index]: {n} linear x_i, then {products - cubic} products x_i x_j"
                      + (f" and {cubic} cubic terms x_i x_j x_k" if cubic else ""))
        ax.set_ylabel("reduced displacement [index]")
        ax.set_yticks(range(kept.shape[0]))
        fit = "a ridge fit" if estimator.regressor_.method == "ridge" else "Lasso-LARS with the BIC"
        ax.set_title(f"Terms kept by {fit}: {int(kept.sum())} of {kept.size} "
                     f"({kept.sum(axis=1).min()}-{kept.sum(axis=1).max()} of {kept.shape[1]} per output)", fontsize=10)
        paths.append(Path(f"{stem}_terms.png"))
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths
