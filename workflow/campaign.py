"""``cosim campaign``: a ROM evaluation protocol (FOM-FOM runs, ROM training, ROM-FOM runs, report) on Dask.

A campaign file names a scene, a ROM configuration and three tables:

- ``[fom]``: name -> the ``--set`` overrides of one FOM-FOM run;
- ``[recipes]`` (optional): name -> a list of overrides that models and predictions name by ``recipe`` instead of
  repeating them; a recipe's overrides go before the table's own ``set``;
- ``[models.<name>]``: the FOM runs it trains on (``runs``) and overrides of the ROM configuration (``recipe``,
  ``set``);
- ``[[predictions]]``: a ROM-FOM run: ``model``, ``reference`` (the FOM run whose scene it repeats and
  against which it is reported) and ``switch_time``; with ``fmu = true`` the model is exported as an FMU
  (``DIR/models/<model>.fmu``, through ``cosim export-fmu``) and the FMU serves the solid, and a prediction
  of the same model, reference and switch time is its twin: ``DIR/report/fmu_check.txt`` says whether the
  two runs are bit-identical.

Every run is the sweep's ``run_one`` (``workflow.sweep``) on a Dask worker, with the sweep's tables
``DIR/fom/sweep.csv`` and ``DIR/rom/sweep.csv`` and run directories named from the overrides, so that
``cosim sweep`` and ``cosim campaign`` share finished runs. A model trains as soon as its FOM runs have
finished (or failed after the model's ``snapshots.t_max``) and a ROM-FOM run starts as soon as its model
exists (and its reference has not failed): independent runs share the workers. A
rerun skips finished runs and models (a model is retrained when its configuration changed); a run that
was stopped midway starts again from its beginning. A run directory that is run again is kept beside, as
``<run>.failed-<time>`` (``--retry-failed``), ``<run>.stale-<time>`` (it ended, and its model changed since) or
``<run>.stopped-<time>``. The report of every prediction goes to
``DIR/report/``, the training logs (hold-out tables, timings) to ``DIR/models/<name>.log``.
Training, the FMU export and the report are the ROM's own functions (``rom_component.static.train``, ``.fmu.export``,
``.report.compare``), called directly: the campaign is a workflow above the coupler and the ROM.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import CosimError, SceneError
from cosim.scene import read_toml
from cosim.schema import AnyTable, Required, validate
from coupler.restart import resumable
from rom_component.fmu.export import export_fmu
from rom_component.report.compare import Run, write_report
from rom_component.static.train import load_config, train
from workflow.scheduler import Scheduler
from workflow.sweep import (
    TABLE,
    SweepRun,
    SweepTable,
    check_runs,
    finished_row,
    run_one,
    scene_fingerprint,
    setting_keys,
)

PLAN = {"scene": Required(str), "rom_config": Required(str), "fom": Required(dict), "recipes": AnyTable(),
        "models": Required(dict), "predictions": Required(list)}
MODEL = {"runs": Required(list), "recipe": "", "set": []}
PREDICTION = {"model": Required(str), "reference": Required(str), "switch_time": Required(float), "recipe": "",
              "set": [],
              "fmu": False,   # true: the model exported as an FMU serves the solid (checked against its ROM twin)
              "label": "",    # the run's name in the report (default <model>-<reference>[-fmu])
              "twin": ""}     # fmu: the prediction it must repeat (default: same model, reference, switch time)


@dataclass
class Prediction:
    name: str
    model: str
    reference: str
    run: SweepRun
    switch_time: float
    fmu: Path | None = None     # the exported FMU that serves the solid, if any
    twin: str = ""


@dataclass
class Plan:
    scene: Path
    rom_config: Path
    fom: dict[str, SweepRun]
    models: dict[str, dict[str, Any]]
    predictions: list[Prediction]


def load_plan(path: str | Path, out: Path) -> Plan:
    """Read and check a campaign file; model paths are placed in ``out/models``."""
    path = Path(path)
    raw = read_toml(path, "campaign")[1]
    plan = validate(raw, PLAN, source=str(path))
    base = path.parent
    fom = {name: SweepRun(tuple(overrides)) for name, overrides in plan["fom"].items()}
    recipes = plan["recipes"]
    for name, overrides in recipes.items():
        if not isinstance(overrides, list) or not all(isinstance(item, str) for item in overrides):
            raise SceneError(f"{path}: recipes.{name} must be a list of KEY=VALUE strings, got {overrides!r}")

    def expand(spec: dict[str, Any], where: str) -> dict[str, Any]:
        """``spec`` with its recipe's overrides put before its own ``set``."""
        if spec["recipe"] and spec["recipe"] not in recipes:
            raise SceneError(f"{path}: {where}.recipe is '{spec['recipe']}', which is not in [recipes] "
                             f"({', '.join(recipes) or 'none'})")
        return {**spec, "set": [*recipes.get(spec["recipe"], []), *spec["set"]]}

    models = {}
    for name, spec in plan["models"].items():
        spec = expand(validate(spec, MODEL, source=f"{path}: models.{name}"), f"models.{name}")
        unknown = [run for run in spec["runs"] if run not in fom]
        if unknown:
            raise SceneError(f"{path}: models.{name}.runs names '{unknown[0]}', which is not in [fom]")
        models[name] = {**spec, "path": (out / "models" / f"{name}.npz").resolve()}
    predictions: list[Prediction] = []
    for i, spec in enumerate(plan["predictions"]):
        spec = expand(validate(spec, PREDICTION, source=f"{path}: predictions.{i}"), f"predictions.{i}")
        if spec["model"] not in models:
            raise SceneError(f"{path}: predictions.{i}.model is '{spec['model']}', which is not in [models]")
        if spec["reference"] not in fom:
            raise SceneError(f"{path}: predictions.{i}.reference is '{spec['reference']}', which is not in [fom]")
        model_path = models[spec["model"]]["path"]
        fmu = model_path.with_suffix(".fmu") if spec["fmu"] else None
        backend, file = ("fmu", f"path={fmu}") if fmu else ("rom", f"model={model_path}")
        overrides = (*fom[spec["reference"]].overrides, f"components.solid.backend={backend}",
                     f"components.solid.{backend}.{file}",
                     f"components.solid.{backend}.switch_time={spec['switch_time']!r}", *spec["set"])
        name = spec["label"] or f"{spec['model']}-{spec['reference']}" + ("-fmu" if fmu else "")
        if name in {p.name for p in predictions}:
            raise SceneError(f"{path}: predictions.{i} is named '{name}' like an earlier one; give it a 'label'")
        predictions.append(Prediction(name, spec["model"], spec["reference"], SweepRun(overrides),
                                      spec["switch_time"], fmu, spec["twin"]))
    return Plan((base / plan["scene"]).resolve(), (base / plan["rom_config"]).resolve(), fom, models, predictions)


def _end_time(run_dir: Path) -> float:
    """The end of the last window a run recorded (0 without results)."""
    from cosim.results import RunResults
    if not (run_dir / "results.h5").is_file():
        return 0.0
    with RunResults(run_dir / "results.h5") as run:
        times = run.windows.time
    return float(times[-1]) if len(times) else 0.0


def _training_end(rom_config: Path, overrides: list[str]) -> float:
    """``snapshots.t_max`` of a model: a FOM run that failed after it still holds all its training data."""
    from cosim.scene import apply_override, parse_override
    raw = read_toml(rom_config, "ROM configuration")[1]
    for item in overrides:
        apply_override(raw, *parse_override(item))
    return float(raw.get("snapshots", {}).get("t_max", float("inf")))


def train_model(sources: list[str], config_path: str, overrides: list[str], out: str) -> dict:
    """Train one model on a worker (``cosim train``); writes the model, its log and a stamp of the
    configuration it was trained with."""
    out_path = Path(out)
    started = time.perf_counter()
    lines: list[str] = []
    metadata = train(sources, out, load_config(config_path, overrides), echo=lines.append)
    lines.append(f"training with cross-validation: {time.perf_counter() - started:.1f} s")
    out_path.with_suffix(".log").write_text("\n".join(lines) + "\n")
    _stamp(out_path).write_text(json.dumps(model_key(sources, config_path, overrides)))
    return {"seconds": time.perf_counter() - started, "cv_seconds": metadata.get("cv_seconds"),
            "fit_seconds": metadata["fit_seconds"], "modes": metadata["params"]["encoder"]["modes"]}


def _stamp(model: Path) -> Path:
    return model.with_suffix(".json")


def model_key(sources: list[str], config_path: str, overrides: list[str]) -> dict:
    """What a trained model was made from (its runs, the ROM configuration's text, the overrides), as its stamp
    holds it."""
    return {"sources": sources, "config": Path(config_path).read_text(), "overrides": list(overrides)}


def model_is_current(model: Path, key: dict) -> bool:
    """Whether ``model`` exists and was made from ``key`` (``model_key``), by its stamp."""
    try:
        return model.is_file() and json.loads(_stamp(model).read_text()) == key
    except (OSError, ValueError):
        return False


def run_campaign(campaign: str | Path, out: str | Path, workers: int = 2, scheduler: str | None = None,
                 echo: Callable[[str], None] = print, retry_failed: bool = False) -> Path:
    """Run what is missing of a campaign (with ``retry_failed``, the failed ROM-FOM runs too), then write the
    report; returns the report directory. ``out`` is held for the whole campaign: a second one into it is
    refused while this one runs."""
    from cosim.rundir import hold
    out = Path(out).resolve()
    plan = load_plan(campaign, out)
    lock = hold(out, "campaign")
    try:
        return _run_campaign(plan, out, workers, scheduler, echo, retry_failed)
    finally:
        os.close(lock)


def _run_campaign(plan: Plan, out: Path, workers: int, scheduler: str | None, echo: Callable[[str], None],
                  retry_failed: bool) -> Path:
    check_runs(str(plan.scene), [*plan.fom.values(), *(p.run for p in plan.predictions)])
    campaign = CampaignRun(plan, out, echo)
    started = time.perf_counter()
    from dask.distributed import Client, LocalCluster
    campaign.prepare(retry_failed)
    cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                  host="127.0.0.1", dashboard_address="127.0.0.1:0")
    try:
        with Client(scheduler or cluster) as client:
            campaign.run(client)
    finally:
        if cluster is not None:
            cluster.close()
    echo(f"campaign runs finished in {time.perf_counter() - started:.0f} s")
    return write_campaign_report(plan, out, campaign.fom_dir, campaign.rom_dir, campaign.failures(), echo)


class CampaignRun:
    """The state of one campaign run and a handler per task kind: FOM-FOM runs (``fom``), trainings (``model``)
    and ROM-FOM runs (``rom``).

    Priorities: models, then the FOM runs they train on, the ROM-FOM runs in the campaign file's order whenever
    their models trained, the other FOM runs.
    """

    def __init__(self, plan: Plan, out: Path, echo: Callable[[str], None]):
        self.plan, self.out, self.echo = plan, out, echo
        scene = scene_fingerprint(plan.scene)
        self.fom_table = SweepTable(out / "fom" / TABLE, setting_keys(list(plan.fom.values())), scene)
        self.rom_table = SweepTable(out / "rom" / TABLE, ["model", "reference", "switch_time"], scene)
        self.fom_dir = {name: out / "fom" / "runs" / run.name for name, run in plan.fom.items()}
        self.rom_dir = {p.name: out / "rom" / "runs" / p.run.name for p in plan.predictions}
        self.sources = {name: [str(self.fom_dir[run] / "results.h5") for run in spec["runs"]]
                        for name, spec in plan.models.items()}
        self.current = {name for name, spec in plan.models.items()      # models trained with today's configuration
                        if model_is_current(spec["path"], self._model_key(name))}
        self.failed_fom: set[str] = set()
        self.queued: set[str] = set()        # models and predictions queued (or given up on)
        self.report_due = False              # a ROM-FOM run finished since the last interim report
        self.scheduler: Scheduler | None = None

    def _model_key(self, name: str) -> dict:
        return model_key(self.sources[name], str(self.plan.rom_config), self.plan.models[name]["set"])

    def prepare(self, retry_failed: bool) -> None:
        """Name the runs, forget those of stale models (and, with ``retry_failed``, the failed ones, whose
        directories are kept beside as ``<run>.failed-<time>``), adopt runs that finished without a row."""
        plan, fom_table, rom_table = self.plan, self.fom_table, self.rom_table
        names = self.out / "rom" / "predictions.json"     # which prediction each run of the ROM table is
        known = json.loads(names.read_text()) if names.is_file() else {}
        names.write_text(json.dumps({**known, **{p.run.name: p.name for p in plan.predictions}}, indent=1) + "\n")
        rom_table.forget({p.run.name for p in plan.predictions if p.model not in self.current})   # retrained below
        if retry_failed:
            for table, named, folder in ((rom_table, {p.name: p.run for p in plan.predictions}, self.rom_dir),
                                         (fom_table, plan.fom, self.fom_dir)):
                failed_runs = {name: run for name, run in named.items()
                               if table.done.get(run.name, {}).get("failure")}
                for name in failed_runs:
                    _set_aside(folder[name], "failed")
                table.forget({run.name for run in failed_runs.values()})
        _adopt_finished(plan, fom_table, rom_table, self.fom_dir, self.rom_dir, self.current, self.echo)
        self.failed_fom = {name for name, run in plan.fom.items() if fom_table.done.get(run.name, {}).get("failure")}

    def run(self, client: Any) -> None:
        """Queue every task whose inputs exist, then run until every task has finished."""
        self.scheduler = Scheduler(client, {"fom": self.on_fom, "model": self.on_model, "rom": self.on_rom},
                                   self.on_error)
        self.queue_models()
        trained_on = {run for spec in self.plan.models.values() for run in spec["runs"]}
        for name, run in self.plan.fom.items():
            if run.name not in self.fom_table.done:
                if not resumable(self.fom_dir[name]):      # a run stopped after a checkpoint goes on from it
                    _set_aside(self.fom_dir[name], _why_again(self.fom_dir[name]))
                self.scheduler.submit("fom", name, run_one, str(self.plan.scene), list(run.overrides),
                                      str(self.fom_dir[name]), priority=2 if name in trained_on else 0)
        self.queue_predictions()
        if any(p.run.name in self.rom_table.done for p in self.plan.predictions):
            self.refresh_report()
        self.scheduler.run(after=self.refresh_report_if_due)

    def queue_models(self) -> None:
        """Queue every model whose FOM runs have finished (or give it up if one failed before its data ended)."""
        assert self.scheduler is not None
        for name, spec in self.plan.models.items():
            if name in self.current or name in self.queued:
                continue
            short = [run for run in spec["runs"] if run in self.failed_fom and
                     _end_time(self.fom_dir[run]) < _training_end(self.plan.rom_config, spec["set"])]
            if short:
                self.echo(f"model {name}: not trained, FOM run {short[0]} failed before the end of the training data")
                self.queued.add(name)
            elif all(self.plan.fom[run].name in self.fom_table.done for run in spec["runs"]):
                self.queued.add(name)
                self.scheduler.submit("model", name, train_model, self.sources[name], str(self.plan.rom_config),
                                      spec["set"], str(spec["path"]), priority=3)

    def queue_predictions(self) -> None:
        """Queue every ROM-FOM run whose model is current and whose reference has not failed."""
        assert self.scheduler is not None
        for i, p in enumerate(self.plan.predictions):
            if p.name in self.queued or p.run.name in self.rom_table.done or p.model not in self.current:
                continue
            self.queued.add(p.name)
            if p.reference in self.failed_fom:
                self.echo(f"rom {p.name}: not run, its reference {p.reference} failed")
                continue
            model = self.plan.models[p.model]["path"]
            if not (resumable(self.rom_dir[p.name]) and ran_after_model(self.rom_dir[p.name], model)):
                _set_aside(self.rom_dir[p.name], _why_again(self.rom_dir[p.name]))
            if p.fmu and (not p.fmu.is_file() or p.fmu.stat().st_mtime_ns < model.stat().st_mtime_ns):
                self.echo(f"wrote {export_fmu(model, p.fmu)}")
            self.scheduler.submit("rom", p.name, run_one, str(self.plan.scene), list(p.run.overrides),
                                  str(self.rom_dir[p.name]), priority=1, order=i)   # in the campaign file's order

    def on_fom(self, name: str, result: dict) -> None:
        self.fom_table.add(self.plan.fom[name], result)
        if result["failure"]:
            self.failed_fom.add(name)
        self.queue_models()
        self._echo_run("fom", name, result)

    def on_model(self, name: str, result: dict) -> None:
        self.current.add(name)
        self.echo(f"model {name}: trained in {result['seconds']:.1f} s (cross-validation {result['cv_seconds']:.1f} "
                  f"s, fit {result['fit_seconds']:.2f} s), r_f = {result['modes']}")
        self.queue_predictions()

    def on_rom(self, name: str, result: dict) -> None:
        p = next(p for p in self.plan.predictions if p.name == name)
        self.rom_table.add(p.run, {"model": p.model, "reference": p.reference, "switch_time": p.switch_time,
                                   **result})
        self._echo_run("rom", name, result)
        self.report_due = True

    def on_error(self, kind: str, name: str, error: BaseException) -> None:
        self.echo(f"{kind} {name}: failed: {error}")

    def _echo_run(self, kind: str, name: str, result: dict) -> None:
        self.echo(f"{kind} {name}: {result['failure'] or 'converged'}, {result['windows_converged']} windows, "
                  f"{result['mean_iterations']:.3f} iterations per window, {result['wall_seconds']:.0f} s")

    def failures(self) -> dict[str, str]:
        return _failures(self.plan, self.fom_table, self.rom_table)

    def refresh_report_if_due(self) -> None:
        if self.report_due:
            self.report_due = False
            self.refresh_report()

    def refresh_report(self) -> None:
        """The report so far, over the ROM-FOM runs and references finished: a side product, the runs go on
        whatever it says."""
        done = {name for name, run in self.plan.fom.items() if run.name in self.fom_table.done} | \
               {p.name for p in self.plan.predictions if p.run.name in self.rom_table.done}
        try:
            write_campaign_report(self.plan, self.out, self.fom_dir, self.rom_dir, self.failures(), lambda line: None,
                                  done)
        except (CosimError, OSError) as exc:    # the file system's no included, as the command line had it
            self.echo(f"warning: the interim report failed (the runs go on): {exc}")


def ran_after_model(run_dir: Path, model: Path) -> bool:
    """Whether the ROM-FOM run in ``run_dir`` has results newer than its model file."""
    results = run_dir / "results.h5"
    return results.is_file() and model.is_file() and results.stat().st_mtime_ns >= model.stat().st_mtime_ns


def _why_again(run_dir: Path) -> str:
    """Why a run directory that exists is run again: it ended (finished or failed) with a model since changed, or
    it stopped midway."""
    try:
        state = json.loads((run_dir / "status.json").read_text()).get("state")
    except (OSError, ValueError):
        state = None
    return "stale" if state in ("finished", "failed") else "stopped"


def _set_aside(run_dir: Path, reason: str) -> None:
    """Keep a run that is about to run again beside, as ``<run>.<reason>-<time>``: no run overwrites another."""
    if run_dir.is_dir():
        run_dir.rename(run_dir.with_name(f"{run_dir.name}.{reason}-{time.time_ns()}"))


def _failures(plan: Plan, fom_table: SweepTable, rom_table: SweepTable) -> dict[str, str]:
    """The failed runs (FOM-FOM by name, ROM-FOM by prediction) and their messages."""
    failed = {p.name: rom_table.done[p.run.name]["failure_message"] for p in plan.predictions
              if rom_table.done.get(p.run.name, {}).get("failure")}
    failed.update({name: fom_table.done[run.name]["failure_message"] for name, run in plan.fom.items()
                   if fom_table.done.get(run.name, {}).get("failure")})
    return failed


def _adopt_finished(plan: Plan, fom_table: SweepTable, rom_table: SweepTable, fom_dir: dict[str, Path],
                    rom_dir: dict[str, Path], current: set[str], echo: Callable[[str], None]) -> None:
    """Rows for runs that finished but whose rows were never written (the campaign stopped between the two);
    a ROM-FOM run only if it is newer than its model, which is current."""
    for name, run in plan.fom.items():
        row = None if run.name in fom_table.done else finished_row(fom_dir[name])
        if row is not None:
            fom_table.add(run, row)
            echo(f"fom {name}: had finished; its row is taken from its run")
    for p in plan.predictions:
        if p.run.name in rom_table.done or p.model not in current or \
                not ran_after_model(rom_dir[p.name], plan.models[p.model]["path"]):
            continue
        row = finished_row(rom_dir[p.name])
        if row is not None:
            rom_table.add(p.run, {"model": p.model, "reference": p.reference, "switch_time": p.switch_time, **row})
            echo(f"rom {p.name}: had finished; its row is taken from its run")


def fmu_check(fmu: Prediction, twin: Prediction, rom_dir: dict[str, Path]) -> str:
    """One line: does the FMU's run repeat its ROM twin bit for bit (iterations, fields, residuals) over the
    FMU run's windows (it may end earlier)?"""
    from cosim.results import RunResults
    paths = [rom_dir[p.name] / "results.h5" for p in (fmu, twin)]
    if not all(path.is_file() for path in paths):
        return ""
    with RunResults(paths[0]) as a, RunResults(paths[1]) as b:
        its_a, its_b = a.windows.iterations, b.windows.iterations
        n = len(its_a)
        fields_a, fields_b = a.fields(), b.fields()
        diffs = {name: float(np.max(np.abs(fields_a[name] - fields_b[name][:n]), initial=0.0))
                 if len(fields_b[name]) >= n else float("inf") for name in sorted(fields_a) if name in fields_b}
        (window_a, res_a), (window_b, res_b) = a.residuals(), b.residuals()
        k = len(res_a)   # the twin's first k residuals belong to the same windows if the runs agree
        same_residuals = (len(res_b) >= k and bool(np.array_equal(window_a, window_b[:k]))
                          and bool(np.array_equal(res_a, res_b[:k])))
    same_iterations = len(its_b) >= n and bool(np.array_equal(its_a, its_b[:n]))
    identical = same_iterations and same_residuals and all(d == 0.0 for d in diffs.values())
    return (f"{fmu.name} against {twin.name} over the first {n} windows (of {len(its_b)}): {int(its_a.sum())} "
            f"coupling iterations, {'the same' if same_iterations else 'NOT the same'} per window; largest field "
            f"difference " + ", ".join(f"{name} {d:.3g}" for name, d in diffs.items())
            + f"; residuals {'equal' if same_residuals else 'differ'}: "
            + ("bit-identical" if identical else "NOT bit-identical"))


def write_campaign_report(plan: Plan, out: Path, fom_dir: dict[str, Path], rom_dir: dict[str, Path],
                          failed: dict[str, str], echo: Callable[[str], None] = print,
                          finished: set[str] | None = None) -> Path:
    """``cosim report`` over every ROM prediction whose run and reference finished (the failed ones are listed
    in ``report/failed.txt``), and the FMU runs checked against their twins (``report/fmu_check.txt``);
    ``finished``: the names of the runs (FOM and prediction) that have finished, if not all have."""
    pairs: list[tuple[Run, Run]] = []
    notes: list[str] = []
    for p in plan.predictions:
        if p.fmu:
            continue   # checked against its twin below (fmu_check.txt), which the report carries
        if finished is not None and not {p.name, p.reference} <= finished:
            continue   # still to run, or running
        run, reference = rom_dir[p.name] / "results.h5", fom_dir[p.reference] / "results.h5"
        for name in (p.name, p.reference):
            if name in failed:
                notes.append(f"{p.name}: left out, run '{name}' failed: {failed[name]}")
        if notes and notes[-1].startswith(f"{p.name}:"):
            continue
        if run.is_file() and reference.is_file():
            pair = (Run.read(rom_dir[p.name]), Run.read(fom_dir[p.reference]))
            pair[0].label, pair[1].label = p.name, p.reference
            pairs.append(pair)
        else:
            notes.append(f"{p.name}: left out ({'its run' if not run.is_file() else 'its reference'} has no results)")
    # written whole into a fresh directory, which then replaces the last report: no figure of a run that is no
    # longer in it (run again with a changed model, say) stays behind; the runs themselves are all kept
    report = out / f"report.partial-{time.time_ns()}"
    report.mkdir(parents=True)
    for note in notes:
        echo(note)
    (report / "failed.txt").write_text("".join(f"{note}\n" for note in notes))
    checks = [fmu_check(p, twin, rom_dir) for p in plan.predictions if p.fmu
              and (finished is None or p.name in finished)
              for twin in plan.predictions if not twin.fmu and (finished is None or twin.name in finished)
              and (twin.name == p.twin if p.twin else
                   (twin.model, twin.reference, twin.switch_time) == (p.model, p.reference, p.switch_time))]
    checks = [line for line in checks if line]
    for line in checks:
        echo(line)
    (report / "fmu_check.txt").write_text("".join(f"{line}\n" for line in checks))
    if pairs:
        write_report(pairs, report, echo=echo)
    final = out / "report"
    if final.is_dir():
        shutil.rmtree(final)
    report.rename(final)
    return final
