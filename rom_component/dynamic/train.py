"""``cosim train`` for a structure with inertia (``dynamics.memory = true``): a step-map ROM
(``rom_component.dynamic.model``) chosen by hold-out over whole windows and saved as a model file.

The hold-out fits every combination of the grid (mode counts, history lengths, ridge penalties,
quadratic modes) on the first windows of the training range and runs each over the last
``dynamics.holdout_fraction`` of them, driven by their recorded converged forces and started from the
recorded history; the smallest field error e chooses. The chosen settings are then fitted on every
window of the range. The probes the full-order structure recorded (locals of two values, such as Mok's
``point_a``) are found among the field's nodes and served by the ROM too.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import MESH_PREFIX
from cosim.errors import SceneError
from rom_component import model_file
from rom_component.dynamic.model import StepMapRom, UnstableModel, WindowData, holdout
from rom_component.envelope import fit_envelope
from rom_component.recorded import interface_index, read_interface, recorded_calls

KIND = "step-map"


def read_window_data(results: str | Path, spec: dict[str, Any]) -> tuple[WindowData, np.ndarray, float, dict]:
    """Every recorded call of the component, its window end times, the window size, and its two-value locals."""
    calls, times = recorded_calls(results, spec, spec["converged_only"])
    field = spec["field"] or spec["output"]
    finished = calls.window <= len(times)
    F = calls.inputs[spec["input"]][finished].reshape(int(finished.sum()), -1)
    U = calls.outputs[field][finished].reshape(len(F), -1)
    try:
        data = WindowData(F, U, calls.window[finished], calls.converged[finished])
    except ValueError as exc:
        raise SceneError(f"'{results}': {exc}") from None
    dt = float(times[1] - times[0]) if len(times) > 1 else float(times[0])
    probes = {name: values[finished].reshape(len(F), -1) for name, values in calls.outputs.items()
              if name not in (field, spec["output"]) and values[0].size == 2}
    return data, times, dt, probes


def probe_rows(U: np.ndarray, probes: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """For each recorded probe, the two field positions (node-major x, y) whose values it repeats."""
    found = {}
    for name, values in probes.items():
        gaps = np.abs(U.reshape(len(U), -1, 2) - values[:, None, :]).max(axis=(0, 2))
        node = int(np.argmin(gaps))
        if gaps[node] <= 1e-12 * max(float(np.abs(values).max()), 1e-300):
            found[name] = np.array([2 * node, 2 * node + 1])
    return found


def model_contents(model: StepMapRom, data: WindowData, last: int, K: np.ndarray, probes: dict[str, np.ndarray],
               dt: float, input_name: str, output_name: str) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The arrays and metadata of a fitted model's file: the served output's rows ``K`` of the field, the probes'
    rows (``probe_rows``), the training envelope of the reduced forces of windows 1 to ``last``."""
    r_f, r_u = model.modes
    step, encoder, decoder = model.map_, model.bases_.encoder, model.bases_.decoder
    Phi_u = np.ascontiguousarray(decoder.components_[:, :r_u])
    probe_index = np.concatenate(list(probes.values())) if probes else np.zeros(0, dtype=np.int64)
    arrays = {"E": np.ascontiguousarray(encoder.jacobian()[:r_f]), "e": encoder.online_arrays()["e"][:r_f],
              "W_f": step.W_f, "W_z": step.A, "W_q": step.Q, "c": step.c,
              "A": np.ascontiguousarray(Phi_u[K]), "base": decoder.mean_[K].copy(), "u_mean": decoder.mean_,
              "Phi_u": Phi_u, "P": np.ascontiguousarray(Phi_u[probe_index]), "p0": decoder.mean_[probe_index].copy(),
              "force_singular_values": encoder.singular_values_, "disp_singular_values": decoder.singular_values_,
              **fit_envelope(model.bases_.x_all[data.select(1, last), :r_f])}
    metadata = {"kind": KIND, "regressor": KIND, "params": {"step_map": model.settings()},
                "input_variable": input_name, "output_variable": output_name, "windows": last, "dt": dt,
                "n_snapshots": int(data.select(1, last).sum()), "history": model.history,
                "quadratic_modes": model.quadratic_modes,
                "radius": step.radius, "radius_served": step.radius_served, "probes": list(probes)}
    return arrays, metadata


def train_step_map(results: str | Path, out: str | Path, config: dict[str, Any], echo=print) -> dict[str, Any]:
    spec, dynamics, selection = config["snapshots"], config["dynamics"], config["selection"]
    data, times, dt, probes = read_window_data(results, spec)
    last = int(np.searchsorted(times, spec["t_max"] + 1e-9))          # windows 1..last end by t_max
    if spec["t_min"] > 0:
        raise SceneError("snapshots.t_min: a step-map ROM trains from the run's start (the history begins at rest)")
    if last < 4:
        raise SceneError(f"snapshots.t_max = {spec['t_max']:g}: only {last} windows to train on")
    grid = {"force_modes": selection["force_modes"], "disp_modes": selection["disp_modes"],
            "history": dynamics["history"], "ridge": dynamics["ridge"], "quadratic_modes": dynamics["quadratic_modes"]}
    echo(f"{int(data.select(1, last).sum())} calls of '{spec['component']}' in {last} windows (t <= "
         f"{times[last - 1]:g} s, {_which_calls(spec)}), force {data.F.shape[1]}, field {data.U.shape[1]} values")
    started = time.perf_counter()
    rows = holdout(data, last, grid, dynamics["holdout_fraction"], dynamics["max_radius"])
    cv_seconds = time.perf_counter() - started
    ranked = sorted(rows, key=lambda row: row.error)
    refused = sum(1 for row in rows if row.refused)
    echo(f"hold-out: {len(rows)} models fitted on the first {1 - dynamics['holdout_fraction']:.0%} of the windows, "
         f"each run over the rest from the recorded history ({refused} refused: free response grows), "
         f"{cv_seconds:.1f} s; best five by the field error e:")
    for row in ranked[:5]:
        echo(f"  e = {row.error:.3e}  radius {row.radius:.4f}  " + " ".join(f"{k}={v}" for k, v in row.settings.items()))
    fit_started = time.perf_counter()
    model, refusals = None, []
    for row in (row for row in ranked if np.isfinite(row.error)):   # the best one whose fit on every window holds
        try:
            model = StepMapRom(**row.settings, max_radius=dynamics["max_radius"]).fit(data, last)
            break
        except UnstableModel as exc:
            refusals.append(f"{row.settings}: {exc}")
            echo(f"refused on all {last} windows, the next one tried: " + refusals[-1])
    if model is None:
        raise SceneError("every model of the hold-out grid was refused: its free response grows"
                         + (f" (the last: {refusals[-1]})" if refusals else ""))
    fit_seconds = time.perf_counter() - fit_started
    step = model.map_
    if step.radius_served < step.radius:
        echo(f"stabilised: the linear part's spectral radius {step.radius:.6f} scaled to {step.radius_served:.6f}")
    training_error = model.validation_error(data, 1, last)
    r_f, r_u = model.modes
    echo(f"fitted r_f = {r_f}, r_u = {r_u}, history of {model.history} windows' displacements, ridge {model.ridge:g}, quadratic modes {model.quadratic_modes} in {fit_seconds:.3f} s; linear "
         f"part's spectral radius {step.radius_served:.6f}; rollout over the training windows e = {training_error:.3e}")
    K = interface_index(results, spec) if spec["field"] else np.arange(data.U.shape[1])
    found = probe_rows(data.U, probes)
    arrays, metadata = model_contents(model, data, last, K, found, dt, spec["input"], spec["output"])
    variables, meshes = read_interface(results, spec)
    metadata.update({
        "field_variable": spec["field"], "component": spec["component"], "results": str(results),
        "variables": variables, "t_range": [0.0, float(times[last - 1])],
        "fit_seconds": fit_seconds, "cv_seconds": cv_seconds, "training_error": training_error,
        "selection": {"grid": grid, "holdout_fraction": dynamics["holdout_fraction"],
                      "rows": [{**row.settings, "error": row.error if np.isfinite(row.error) else None,
                                "radius": row.radius if np.isfinite(row.radius) else None} for row in rows]},
    })
    model_file.save(out, {**arrays, **{MESH_PREFIX + k: v for k, v in meshes.items()}}, metadata)
    echo(f"saved {out}")
    return metadata


def _which_calls(spec: dict[str, Any]) -> str:
    if spec["converged_only"]:
        return "converged calls only"
    return "every sub-iteration but a window's unconverged first" if spec["skip_first_iteration"] else \
        "every sub-iteration"
