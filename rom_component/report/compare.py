"""``cosim report``: ROM-FOM runs against their FOM-FOM references (the figures; PNGs in ``report_plots``).

Per run: the relative L2 error of a monitored value (the tube's inlet pressure) over
the predicted range, per-window errors of every exchanged field and of the full
displacement field (the paper's e(t) = ||U - U_rom|| / mean_t ||U||), accumulated
coupling iterations against the reference (with a bootstrap interval over the predicted windows),
the solid speed-up sigma (compute and round trip per call), the total speed-up and its bound
(T_f + T_s) / (T_f + T_s / sigma).
Writes ``report.json``, ``report.txt`` and the PNGs of ``rom_component.report.plots``, which
adds a scene's own plots from its component package. A reference must have run the same scene.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import SceneError
from cosim.results import RunResults
from rom_component.model_file import ModelFileError, load_arrays
from rom_component.parts import describe_parts
from rom_component.report.plots import write_plots


def iterations_interval(iterations: np.ndarray, reference: np.ndarray, block: int = 10, resamples: int = 4000,
                        seed: int = 0) -> list[float]:
    """90 % interval of the ratio of accumulated iterations, run over reference, over the same windows: a
    moving-block bootstrap of the per-window difference (blocks of ``block`` windows, which keeps the windows'
    correlation). It says how far one run's count can be told from another's; NaN for fewer than 2 blocks."""
    difference = np.asarray(iterations, dtype=float) - np.asarray(reference, dtype=float)
    n, total = len(difference), float(np.sum(reference))
    if n < 2 * block or total <= 0:
        return [math.nan, math.nan]
    starts = np.random.default_rng(seed).integers(0, n - block + 1, (resamples, -(-n // block)))
    rows = (starts[:, :, None] + np.arange(block)).reshape(resamples, -1)[:, :n]
    low, high = np.percentile(difference[rows].sum(axis=1), [5, 95])
    return [1 + float(low) / total, 1 + float(high) / total]


@dataclass
class Run:
    """What the report needs from one results file."""

    path: Path
    label: str
    scene: dict[str, Any]
    time: np.ndarray
    iterations: np.ndarray
    wall: float
    fields: dict[str, np.ndarray]
    window_wall: np.ndarray
    components: dict[str, dict[str, Any]]
    rom_backend: str | None = None
    switch_time: float | None = None
    full_field: tuple[np.ndarray, np.ndarray] | None = None   # (time, rows) rebuilt by the ROM
    initial: dict[str, np.ndarray] = field(default_factory=dict)  # data values before the first window
    fallback_windows: int = 0            # windows the solid FOM took over from a ROM out of its range
    surrogate: dict[str, Any] = field(default_factory=dict)   # the online surrogate's attributes, if it had one
    trust: np.ndarray | None = None      # per window: the converged ROM call's excess beyond its training range
    model: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def read(cls, directory: str | Path) -> Run:
        directory = Path(directory)
        with RunResults(directory) as results:
            components = {}
            for name in results.component_names():
                record = results.component(name)
                components[name] = {**record.attributes, "compute_seconds": record.compute_seconds,
                                    "cpu_seconds": record.cpu_seconds, "roundtrip_seconds": record.roundtrip_seconds,
                                    "final": record.final}
            windows = results.windows
            run = cls(results.path, directory.name if directory.is_dir() else results.path.parent.name, results.scene,
                      windows.time, windows.iterations, float(results.attributes.get("wall_seconds", np.nan)),
                      results.fields(), windows.wall_seconds, components, initial=results.initial(),
                      fallback_windows=int(results.attributes.get("rom_fallback_windows", 0)),
                      surrogate={k: v for k, v in results.attributes.items() if k.startswith("surrogate_")})
            for name in results.recorded():
                calls = results.calls(name, converged_only=True)
                if "rom_excess" in calls.outputs and len(calls.window) == len(windows):
                    run.trust = calls.outputs["rom_excess"][:, 0]
        for name, info in components.items():
            if info.get("kind") in ("rom", "fmu"):
                run.rom_backend, run.switch_time = name, float(info["start_time"])
                if "full_field" in info["final"]:
                    run.full_field = (info["final"]["time"], info["final"]["full_field"])
        if run.rom_backend:
            participant = components[run.rom_backend]["participant"]
            model_path = run.scene.get("components", {}).get(participant, {}).get("rom", {}).get("model", "")
            try:
                run.model = load_arrays(model_path)[1] if model_path else {}
            except ModelFileError:
                run.model = {}
        return run

    def predicted(self) -> np.ndarray:
        """Windows served by the ROM (all windows of a run without one)."""
        if self.switch_time is None:
            return np.ones(len(self.time), dtype=bool)
        half_window = 0.5 * (self.time[1] - self.time[0]) if len(self.time) > 1 else 1e-9
        return self.time > self.switch_time + half_window

    @property
    def participant(self) -> str | None:
        return self.components[self.rom_backend]["participant"] if self.rom_backend else None

    def output_of(self, participant: str) -> str:
        """The data item the participant sends (the solid's displacement)."""
        for exchange in self.scene.get("exchange", []):
            if exchange["from"] == participant:
                return exchange["data"]
        raise SceneError(f"{self.path}: component '{participant}' sends no data")

    def displacement_field(self, participant: str, field: str = "") -> np.ndarray:
        """Per-window displacement field, one flat row per window: the FOM's output (or, with ``field``, the
        recorded local holding the whole field, from each window's converged call), and the ROM's rebuilt
        field where the ROM served."""
        if field:
            with RunResults(self.path) as results:
                calls = results.calls(participant, converged_only=True)
            if field in calls.outputs:
                U = calls.outputs[field].reshape(len(calls.window), -1).copy()
            elif self.full_field is not None and len(self.full_field[0]) == len(self.time):   # a ROM served all
                U = np.zeros((len(self.time), self.full_field[1].shape[1]))
            else:
                raise SceneError(f"'{self.path}': the recorded calls of '{participant}' have no '{field}'")
        else:
            values = self.fields[self.output_of(participant)]
            U = values.reshape(len(values), -1).copy()
        if self.full_field is not None:
            times, rows = self.full_field
            index = np.searchsorted(self.time, times - 1e-9)
            if rows.shape[1] == U.shape[1]:
                U[index] = rows
        return U


def _flat(values: np.ndarray) -> np.ndarray:
    """One row per window, node-major (the plot index counts values, as in the run plot)."""
    return values.reshape(len(values), -1)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


BACKEND_KEYS = ("backend", "rom", "fmu")   # what may differ between a run and its reference
PRESENTATION_KEYS = ("name", "output")


def scene_difference(a: Any, b: Any, where: str = "") -> str | None:
    """The first dotted key at which two resolved scenes differ, ignoring backends and presentation."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            backend_key = where.startswith("components.") and where.count(".") == 2 and key in BACKEND_KEYS
            if (where == "" and key in PRESENTATION_KEYS) or backend_key:
                continue
            if key not in a or key not in b:
                return f"{where}{key}"
            found = scene_difference(a[key], b[key], f"{where}{key}.")
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            found = scene_difference(x, y, f"{where}{i}.")
            if found:
                return found
        return None
    return None if a == b else where.rstrip(".")


def _lookup(scene: dict[str, Any], key: str) -> Any:
    node: Any = scene
    for part in key.split("."):
        try:
            node = node[int(part)] if isinstance(node, list) else node[part]
        except (KeyError, IndexError, ValueError, TypeError):
            return "(absent)"
    return node


def _never_reached_the_maximum(reference: Run) -> bool:
    limit = reference.scene.get("coupling", {}).get("max_iterations", np.inf)
    return bool(len(reference.iterations)) and reference.iterations.max() < limit


def _never_changed_backend(reference: Run) -> bool:
    return all(c.get("backend", "fom") == "fom" for c in reference.scene.get("components", {}).values())


# settings that cannot have mattered for a reference that passes the test: it ran the same under any value
# (``on_map_change``: one recorded before the setting existed has none)
MOOT_FOR_REFERENCE = {"coupling.on_max_iterations": _never_reached_the_maximum,
                      "coupling.acceleration.on_map_change": _never_changed_backend}


def _as_in(scene: dict[str, Any], other: dict[str, Any], key: str) -> dict[str, Any]:
    """A copy of ``scene`` whose dotted ``key`` is as in ``other`` (absent if absent there)."""
    head, _, rest = key.partition(".")
    if rest:
        return {**scene, head: _as_in(scene.get(head, {}), other.get(head, {}), rest)}
    copy = {k: v for k, v in scene.items() if k != head}
    return {**copy, head: other[head]} if head in other else copy


def without_surrogate(scene: dict[str, Any], reference: dict[str, Any]) -> dict[str, Any]:
    """``scene`` as its run would be without the online surrogate (``coupling.surrogate``), for the comparison with
    ``reference``: the surrogate changes where iterations start and which steps they take, not what a window
    converges to. Its table goes, its quasi-Newton (``iqn-surrogate``) counts as the reference's acceleration with
    the settings both have, and its predictor as the reference's."""
    coupling = dict(scene.get("coupling", {}))
    coupling.pop("surrogate", None)
    theirs = reference.get("coupling", {})
    acceleration, their_acceleration = coupling.get("acceleration"), theirs.get("acceleration")
    if isinstance(acceleration, dict) and acceleration.get("type") == "iqn-surrogate" and \
            isinstance(their_acceleration, dict):
        coupling["acceleration"] = {k: v for k, v in acceleration.items() if k in their_acceleration} | \
            {"type": their_acceleration.get("type")}
    if coupling.get("predictor") == "surrogate":
        coupling["predictor"] = theirs.get("predictor", "none")
    return {**scene, "coupling": coupling}


def compare(run: Run, reference: Run) -> dict[str, Any]:
    """The report's figures for ``run`` against ``reference`` (which must have run the same scene, but for the solid
    backend and the online surrogate)."""
    scene, moot = without_surrogate(reference.scene, reference.scene), set()
    ours = without_surrogate(run.scene, reference.scene)
    different = scene_difference(ours, scene)
    while different in MOOT_FOR_REFERENCE and different not in moot and MOOT_FOR_REFERENCE[different](reference):
        moot.add(different)
        scene = _as_in(scene, ours, different)
        different = scene_difference(ours, scene)
    if different:
        raise SceneError(f"reference '{reference.path.parent}' ran another scene than '{run.path.parent}': "
                         f"{different} is {_lookup(reference.scene, different)!r} there and "
                         f"{_lookup(run.scene, different)!r} here; only the solid backend may differ")
    if len(run.time) != len(reference.time) or not np.allclose(run.time, reference.time):
        raise SceneError(f"'{run.path}' and its reference '{reference.path}' have different time windows")
    predicted = run.predicted()
    output = run.scene.get("output", {})
    monitor, index = output.get("plot_field", "pressure"), int(output.get("plot_index", 0))
    result: dict[str, Any] = {
        "run": str(run.path.parent), "reference": str(reference.path.parent),
        "label": run.label, "reference_label": reference.label,
        "switch_time": run.switch_time, "predicted_windows": int(predicted.sum()),
        "monitor": f"{monitor}[{index}]",
        "monitor_error": _relative(_flat(run.fields[monitor])[predicted, index],
                                   _flat(reference.fields[monitor])[predicted, index]),
        "iterations": int(run.iterations.sum()), "reference_iterations": int(reference.iterations.sum()),
        "wall_seconds": run.wall, "reference_wall_seconds": reference.wall,
        "model": run.model.get("params", {}),
        "rom_fallback_windows": run.fallback_windows,
    }
    if run.surrogate:
        result["surrogate"] = run.surrogate
    result["iterations_ratio"] = result["iterations"] / result["reference_iterations"]
    result["predicted_iterations_ratio"] = float(run.iterations[predicted].sum() / reference.iterations[predicted].sum())
    result["predicted_iterations_interval"] = iterations_interval(run.iterations[predicted],
                                                                  reference.iterations[predicted])
    result["field_errors"] = {}
    for name, values in run.fields.items():
        mine, theirs = values.reshape(len(values), -1), reference.fields[name].reshape(len(values), -1)
        per_window = np.linalg.norm(mine - theirs, axis=1) / np.linalg.norm(theirs, axis=1)
        result["field_errors"][name] = {"mean": float(per_window[predicted].mean()), "max": float(per_window[predicted].max())}
    participant = run.participant
    if participant and run.rom_backend:
        field = run.model.get("field_variable", "")     # the whole field the ROM learnt, if it learnt one
        U_ref = reference.displacement_field(participant, field)
        U_run = run.displacement_field(participant, field)
        rest = np.zeros(U_ref.shape[1]) if field else \
            np.ravel(reference.initial.get(reference.output_of(participant), np.zeros(U_ref.shape[1])))
        # e(t) = ||U - U_rom|| / mean_t ||U - U_rest||: displacements from the rest state (the tube: a - a0)
        e = np.linalg.norm(U_run - U_ref, axis=1) / np.linalg.norm(U_ref - rest, axis=1).mean()
        result["displacement_error"] = {"mean": float(e[predicted].mean()), "max": float(e[predicted].max())}
        result["_e"] = e
        fom, rom = reference.components[participant], run.components[run.rom_backend]
        # costs from each call's CPU time in the component's process (the machine's load moves wall times)
        fom_cpu, rom_cpu = _quartiles(fom["cpu_seconds"]), _quartiles(rom["cpu_seconds"])
        sigma = fom_cpu[1] / rom_cpu[1]
        sigma_rt = float(np.median(fom["roundtrip_seconds"]) / np.median(rom["roundtrip_seconds"]))
        solid_total = fom["cpu_seconds"].sum()
        others = sum(c["cpu_seconds"].sum() for n, c in reference.components.items() if n != participant)
        result["fom_solid_calls"] = int(len(run.components[participant]["compute_seconds"])) \
            if participant in run.components else 0
        result["rom_solid_calls"] = int(len(rom["compute_seconds"]))
        result["reference_solid_calls"] = int(len(fom["compute_seconds"]))
        result["solid"] = {
            "fom_cpu_quartiles_s": list(fom_cpu), "rom_cpu_quartiles_s": list(rom_cpu),
            "fom_cpu_per_call_s": float(fom["cpu_seconds"].mean()), "rom_cpu_per_call_s": float(rom["cpu_seconds"].mean()),
            "fom_compute_median_s": float(np.median(fom["compute_seconds"])),
            "rom_compute_median_s": float(np.median(rom["compute_seconds"])),
            "fom_roundtrip_median_s": float(np.median(fom["roundtrip_seconds"])),
            "rom_roundtrip_median_s": float(np.median(rom["roundtrip_seconds"])),
            "speedup_compute": float(sigma), "speedup_compute_range": [fom_cpu[0] / rom_cpu[2], fom_cpu[2] / rom_cpu[0]],
            "speedup_roundtrip": float(sigma_rt)}
        # the bound for this run's schedule: the ROM replaces the solid FOM in the predicted windows only
        in_predicted = predicted[call_windows(reference)]      # per call of a once-per-iteration component
        solid_predicted = float(fom["cpu_seconds"][in_predicted].sum()) \
            if len(fom["cpu_seconds"]) == reference.iterations.sum() else solid_total
        result["total_speedup"] = reference.wall / run.wall
        result["total_speedup_bound"] = float((others + solid_total) /
                                              (others + solid_total - solid_predicted + solid_predicted / sigma))
        # the bound is what the ROM's cost allows at the reference's iterations; more than that (and than the
        # iterations saved) is the wall clock's noise, not a result
        allowed = result["total_speedup_bound"] / min(result["predicted_iterations_ratio"], 1.0)
        result["total_speedup_noise"] = bool(result["total_speedup"] > allowed)
        result["reference_fluid_compute_s"], result["reference_solid_compute_s"] = float(others), float(solid_total)
        # the same over the predicted windows alone (window wall times; fluid and solid compute of those windows)
        fluid_calls = [c["cpu_seconds"] for n, c in reference.components.items()
                       if n != participant and len(c["cpu_seconds"]) == reference.iterations.sum()]
        if fluid_calls and solid_predicted > 0:
            fluid_predicted = float(sum(c[in_predicted].sum() for c in fluid_calls))
            result["predicted_range"] = {
                "speedup": float(reference.window_wall[predicted].sum() / run.window_wall[predicted].sum()),
                "bound": float((fluid_predicted + solid_predicted) / (fluid_predicted + solid_predicted / sigma)),
                "fluid_compute_s": fluid_predicted, "solid_compute_s": solid_predicted}
    result.update(scene_metrics(run, reference))
    return result


def _quartiles(values: np.ndarray) -> tuple[float, float, float]:
    """The first quartile, the median and the third quartile of per-call times."""
    q1, median, q3 = np.percentile(values, [25, 50, 75]) if len(values) else (np.nan, np.nan, np.nan)
    return float(q1), float(median), float(q3)


def call_windows(run: Run) -> np.ndarray:
    """The window (0-based) of each call of a component called once per coupling iteration."""
    return np.repeat(np.arange(len(run.iterations)), run.iterations)


def scene_metrics(run: Run, reference: Run) -> dict[str, Any]:
    """Figures the run's case adds (the entry point of ``cosim.report_metrics`` named by the scene's ``case``:
    ``f(run, reference)`` returns a dict)."""
    from cosim.registry import entry_points
    case = run.scene.get("case", "")
    found: dict[str, Any] = {}
    for point in entry_points(group="cosim.report_metrics"):
        if case and point.name == case:
            found.update(point.load()(run, reference))
    return found


def write_report(pairs: list[tuple[Run, Run]], out: str | Path, echo=print) -> dict[str, Any]:
    """Compare each (run, reference) pair; write report.json, report.txt and the PNGs."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [compare(run, ref) for run, ref in pairs]
    text = _table(rows)
    echo(text)
    (out / "report.txt").write_text(text + "\n")
    write_plots(pairs, rows, out)
    clean = [{k: v for k, v in row.items() if not k.startswith("_")} for row in rows]
    document = {"runs": clean}
    (out / "report.json").write_text(json.dumps(document, indent=2, default=float))
    return document


def _table(rows: list[dict[str, Any]]) -> str:
    head = (f"{'run':<16}{'reference':<12}{'T_switch':>9}{'monitor err':>12}{'e(t) mean':>11}{'iter ratio':>11}"
            f"{'sigma':>8}{'sigma rt':>9}{'speed-up':>9}{'bound':>7}{'wall s':>8}  model")
    lines = [head]
    notes: list[str] = []
    costs: list[str] = []
    for r in rows:
        solid = r.get("solid", {})
        model = r.get("model", {})
        desc = describe_parts(model) if model else "-"
        speedup = f"{'noise':>9}" if r.get("total_speedup_noise") else _num(r.get("total_speedup"), "9.2f")
        lines.append(
            f"{r['label']:<16}{r['reference_label']:<12}{_num(r['switch_time'], '9.1f')}"
            f"{r['monitor_error']:>12.2e}{_num(r.get('displacement_error', {}).get('mean'), '11.2e')}"
            f"{(r['iterations_ratio'] - 1) * 100:>+10.2f}%{_num(solid.get('speedup_compute'), '8.1f')}"
            f"{_num(solid.get('speedup_roundtrip'), '9.2f')}{speedup}"
            f"{_num(r.get('total_speedup_bound'), '7.2f')}{r['wall_seconds']:>8.2f}  {desc}")
        if solid:
            fom_q, rom_q = (np.array(solid[k]) * 1e6 for k in ("fom_cpu_quartiles_s", "rom_cpu_quartiles_s"))
            low, high = solid["speedup_compute_range"]
            costs.append(f"{r['label']}: CPU time per call, median [quartiles]: solid FOM {fom_q[1]:.1f} "
                         f"[{fom_q[0]:.1f}, {fom_q[2]:.1f}] us, ROM {rom_q[1]:.1f} [{rom_q[0]:.1f}, {rom_q[2]:.1f}] us; "
                         f"sigma {solid['speedup_compute']:.2f} [{low:.2f}, {high:.2f}]")
        if r.get("total_speedup_noise"):
            notes.append(f"{r['label']}: the wall times give {r['total_speedup']:.2f}, above the {r['total_speedup_bound']:.2f} "
                         "the ROM's cost allows at these iterations: the machine's load moved them; not a result")
        if solid and r.get("total_speedup_bound", 2.0) < 1.2:
            fom_us, rom_us = solid["fom_cpu_quartiles_s"][1] * 1e6, solid["rom_cpu_quartiles_s"][1] * 1e6
            notes.append(f"{r['label']}: the solid takes {fom_us:.0f} us of CPU per call and the ROM {rom_us:.0f} us: "
                         "replacing so cheap a solid saves no time, and this case shows the ROM's accuracy, not its cost")
    lines.append("monitor err: ||m_rom - m_fom|| / ||m_fom|| of the monitored value over t > T_switch; "
                 "e(t) = ||U - U_rom|| / mean_t ||U - U_rest||; iter ratio: accumulated coupling iterations vs the reference; "
                 "sigma: the solid FOM's median CPU time per call / the ROM's, each in its own process (rt: median round "
                 "trips as the coupler saw them)")
    lines.append("speed-up: the reference's wall time / the run's wall time, as measured; bound: the speed-up the ROM's "
                 "cost per call alone allows, (T_f + T_s) / (T_f + T_s,FOM + T_s,ROM / sigma) from the reference's CPU "
                 "times (T_f fluid, T_s solid; T_s,FOM before the switch, T_s,ROM after it) at the reference's "
                 "iterations; below 1 when a ROM call costs more than a solid call. A speed-up above its bound (and "
                 "the iterations saved) is the wall clock's noise, shown as such")
    lines += costs + [f"note: {note}" for note in notes]
    return "\n".join(lines)


def _num(value: Any, spec: str) -> str:
    width = int(spec.split(".")[0])
    return f"{value:{spec}}" if isinstance(value, (int, float)) and not (isinstance(value, float) and math.isnan(value)) \
        else f"{'-':>{width}}"
