"""``cosim train``: fit a solid ROM on the snapshots recorded in a results file.

Selects the recorded calls of one component (by window end time, optionally only the
converged ones), prints the hold-out cross-validation table over a grid of mode
numbers, fits the model with the configured (or selected) numbers of modes, and
saves the online arrays plus metadata.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX
from cosim.errors import SceneError
from cosim.scene import apply_override, parse_override, read_toml
from cosim.schema import Choice, PluginChoice, Value, validate
from rom_component import model_file
from rom_component.recorded import interface_index, read_interface, read_training_set
from rom_component.static.estimator import DEFAULT_PARTS, SolidRom, resolve_parts
from rom_component.static.selection import energy_choice, holdout_table

CONFIG: dict[str, dict[str, Any]] = {
    "snapshots": {"component": "solid", "input": "pressure", "output": "section", "field": "",
                  "t_min": 0.0, "t_max": 1e300, "converged_only": False, "skip_first_iteration": False},
    "model": {kind: PluginChoice(name) for kind, name in DEFAULT_PARTS.items()},
    "output": {"plots": True},
    "selection": {"choose": Choice("fixed", ("fixed", "holdout", "energy")), "table": False,
                  "force_modes": [1, 2, 3, 4, 5, 6], "disp_modes": [1, 3, 5, 7, 9, 11, 13],
                  "test_fraction": Value(0.2, low=0.0, high=1.0, low_open=True, high_open=True),
                  "seed": 0, "energy": Value(0.9999, low=0.0, high=1.0, low_open=True),
                  "split": Choice("snapshots", ("snapshots", "windows")), "compare_splits": False,
                  "tolerance": Value(0.0, low=0.0)},
    "dynamics": {"memory": False, "history": [2, 3, 4], "quadratic_modes": [0],
                 "ridge": [1e-12, 1e-10, 1e-8],
                 "holdout_fraction": Value(0.25, low=0.0, high=1.0, low_open=True, high_open=True),
                 "max_radius": Value(1.0, low=0.0, low_open=True)},
}
MEANINGS = {
    "snapshots.component": "the recorded component whose calls are the training data",
    "snapshots.input": "the force: an input of that component",
    "snapshots.output": "the displacement the ROM serves: an output of that component",
    "snapshots.field": "a recorded local holding the whole displacement field (the double flap's "
                       "displacement_field): the decoder learns it and the ROM serves its part on the output's nodes "
                       "(empty: the output itself)",
    "snapshots.t_min": "the first window end time whose calls are used [s]",
    "snapshots.t_max": "the last window end time whose calls are used [s]",
    "snapshots.converged_only": "true: only each window's converged call; false: every sub-iteration",
    "snapshots.skip_first_iteration": "true: a window's first call (the predicted iterate) is left out unless it "
                                      "converged; for a run whose prediction strays far from the trajectory",
    "model.encoder": "forces to reduced coordinates: a registered encoder (below)",
    "model.regressor": "reduced forces to reduced displacements: a registered regressor (below)",
    "model.decoder": "reduced displacements to the field: a registered decoder (below)",
    "output.plots": "write the singular values, the hold-out table and the kept terms next to the model (.png)",
    "selection.choose": "the numbers of modes: 'fixed' (the encoder's and decoder's modes), 'holdout' (the "
                        "hold-out table's choice) or 'energy' (the energy criterion)",
    "selection.table": "print the hold-out table even when it chooses nothing (choose = \"fixed\" or \"energy\"; "
                       "off by default: it refits the model for every pair of mode counts)",
    "selection.force_modes": "the r_f of the hold-out grid",
    "selection.disp_modes": "the r_u of the hold-out grid",
    "selection.test_fraction": "the share of snapshots (or windows) held out",
    "selection.seed": "the seed of the random hold-out split",
    "selection.energy": "the energy criterion's share of the snapshot energy (sum of squared singular values)",
    "selection.split": "hold out random 'snapshots' or random whole 'windows' (a random snapshot's neighbouring "
                       "sub-iterations are no test)",
    "selection.compare_splits": "print the table of the other split too",
    "selection.tolerance": "choose = 'holdout': the fewest modes whose hold-out error is within this fraction of "
                           "the best",
    "dynamics.memory": "true: a structure with inertia, modelled by a step map with memory "
                       "(rom_component.dynamic.model): the reduced displacement from the window's force and the last "
                       "windows' converged displacements and forces, every setting chosen by hold-out over whole "
                       "windows (selection.force_modes and disp_modes are its mode grids; model is not used)",
    "dynamics.history": "the numbers of past converged displacements the hold-out tries (the force enters through "
                        "Newmark's weighted sum of the window's and the two before it)",
    "dynamics.quadratic_modes": "the numbers of leading reduced displacements whose products enter the map (0: a "
                                "linear map) the hold-out tries",
    "dynamics.ridge": "the ridge penalties (relative, per snapshot) the hold-out tries",
    "dynamics.holdout_fraction": "the share of the training windows, at their end, that each model is run over",
    "dynamics.max_radius": "the largest spectral radius of the map's linear part; one above is scaled down to it",
}


def load_config(path: str | Path | None, overrides: Sequence[str] = ()) -> dict[str, Any]:
    raw: dict[str, Any] = {}
    source = "ROM config"
    if path:
        source = str(path)
        raw = read_toml(path, "ROM config")[1]
    for item in overrides:
        apply_override(raw, *parse_override(item))
    config = validate(raw, CONFIG, source=source)
    config["model"] = resolve_parts(config["model"], source)
    return config


def train(results: str | Path | Sequence[str | Path], out: str | Path, config: dict[str, Any],
          echo=print) -> dict[str, Any]:
    """Train on the calls of one or more runs, print the selection table, save; returns the metadata written."""
    sources = [results] if isinstance(results, (str, Path)) else list(results)
    results = sources[0]     # meshes and interface nodes: those of the first run (all runs share them)
    F, U, times, windows = read_training_set(sources, config["snapshots"])
    echo(f"{len(F)} snapshots of '{config['snapshots']['component']}' from {len(sources)} run(s), "
         f"t in [{times.min():g}, {times.max():g}]: F {F.shape}, U {U.shape}")
    model = SolidRom.from_settings(config["model"])
    try:
        model.check_params()
    except ValueError as exc:
        raise SceneError(f"model: {exc}") from None
    K = interface_index(results, config["snapshots"]) if config["snapshots"]["field"] else None
    selection = config["selection"]
    table = None
    # the ridge fit cross-validates over whole windows
    fit_windows = windows if model.parts()["regressor"].windows_group_fit else None
    started = time.perf_counter()
    tables = {}
    if selection["table"] or selection["choose"] == "holdout":
        splits = ["snapshots", "windows"] if selection["compare_splits"] else [selection["split"]]
        for split in sorted(splits, key=lambda s: s != selection["split"]):   # the one that chooses first
            split_started = time.perf_counter()
            tables[split] = holdout_table(model, F, U, selection["force_modes"], selection["disp_modes"],
                                          selection["test_fraction"], selection["seed"], selection["energy"],
                                          windows if split == "windows" else None, selection["tolerance"],
                                          fit_windows)
            echo(tables[split].format())
            echo(f"cross-validation time (split by {split}): {time.perf_counter() - split_started:.2f} s")
        table = tables[selection["split"]]
    cv_seconds = time.perf_counter() - started
    r_f, r_u = model.parts()["encoder"].modes, model.parts()["decoder"].modes
    if selection["choose"] == "holdout":
        assert table is not None       # choose = "holdout" makes the table
        r_f, r_u = table.chosen
    elif selection["choose"] == "energy":
        r_f, r_u = energy_choice(F, U, selection["energy"])
    elif table is not None:
        echo(f"the configuration fixes r_f = {r_f}, r_u = {r_u} (selection.choose = \"fixed\"; \"holdout\" or "
             "\"energy\" would choose them): the table informs only")
    model.set_params(encoder__modes=r_f, decoder__modes=r_u)
    fit_started = time.perf_counter()
    model.fit(F, U, windows=fit_windows)
    fit_seconds = time.perf_counter() - fit_started
    params = model.settings()
    params["encoder"]["modes"], params["decoder"]["modes"] = model.modes   # as used (capped by the data)
    U_fit = model.predict(F)
    training_error = float(np.linalg.norm(U_fit - U, axis=1).mean())
    metadata = {
        "regressor": params["regressor"]["type"], "params": params,
        "input_variable": config["snapshots"]["input"], "output_variable": config["snapshots"]["output"],
        "component": config["snapshots"]["component"], "results": str(results),
        "t_range": [float(times.min()), float(times.max())], "n_snapshots": int(len(F)),
        "fit_seconds": fit_seconds, "cv_seconds": cv_seconds, "training_error": training_error,
        "results_all": [str(path) for path in sources],
    }
    variables, meshes = read_interface(results, config["snapshots"])
    metadata["variables"] = variables   # the meshes the ROM declares, as the full-order solid did
    if table is not None:
        metadata["selection"] = {"force_modes": table.force_modes, "disp_modes": table.disp_modes,
                                 "errors": table.errors.tolist(), "relative": table.relative.tolist(),
                                 "best": list(table.best), "chosen": list(table.chosen), "split": table.split,
                                 "energy_choice": list(table.energy_choice),
                                 "by_split": {split: {"errors": t.errors.tolist(), "relative": t.relative.tolist(),
                                                      "best": list(t.best)} for split, t in tables.items()}}
    if K is not None:
        metadata["field_variable"] = config["snapshots"]["field"]
    coefficients = getattr(model.regressor_, "coefficients_", None)
    if coefficients is not None:
        kept = (coefficients != 0).sum(axis=0)
        metadata["terms_kept"] = {"per_output": kept.tolist(), "of": int(coefficients.shape[0])}
        penalty = getattr(model.regressor_, "ridge_penalty_", None)
        if penalty is None:
            echo(f"sparse polynomial: {int(kept.sum())} of {coefficients.size} terms kept "
                 f"({kept.min()}-{kept.max()} of {coefficients.shape[0]} per reduced displacement)")
        else:
            metadata["ridge_penalty"] = penalty
            echo(f"polynomial of {coefficients.shape[0]} terms per reduced displacement, ridge penalty {penalty:.1e} "
                 f"per snapshot (cross-validated over whole windows)")
    model_file.save(out, {**model.online_arrays(K), **{MESH_PREFIX + k: v for k, v in meshes.items()}}, metadata)
    if config["output"]["plots"]:
        from rom_component.static.training_plots import write_training_plots
        written = write_training_plots(out, model, tables)
        echo(f"plots: {', '.join(str(p) for p in written)}")
    echo(f"fitted r_f = {model.modes[0]}, r_u = {model.modes[1]}, {params['regressor']['type']} regression, "
         f"{params['decoder']['type']} decoder in {fit_seconds:.3f} s (training time); mean training error {training_error:.3e}")
    for note in getattr(model.parts()["regressor"], "notes_", []):
        echo(f"note: {note}")
    echo(f"saved {out}")
    return metadata
