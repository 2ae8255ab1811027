"""Where a campaign stands (``cosim campaign FILE --out DIR --status``), read from its directory alone.

One line per FOM-FOM run, model and ROM-FOM run: finished (with its table row's figures) or failed, running
(windows done, simulated time, how long ago its ``status.json`` changed), stopped midway (its process is gone:
a rerun starts it again), or waiting, and for a model whether it is trained on its runs' present results; a
ROM-FOM run of an earlier model says so (a rerun runs it again and keeps it beside).
"""

from __future__ import annotations

import time
from pathlib import Path

from cosim.rundir import read_status
from workflow.campaign import load_plan, model_is_current, model_key, ran_after_model
from workflow.sweep import TABLE


def _table(path: Path) -> dict[str, dict[str, str]]:
    import csv
    if not path.is_file():
        return {}
    with open(path, newline="") as stream:
        return {row["name"]: row for row in csv.DictReader(stream)}


def run_state(run_dir: Path, row: dict[str, str] | None, now: float | None = None) -> str:
    """One run's state in words, from its table row if it has one, else from its ``status.json``."""
    if row is not None:
        figures = (f"{row['windows_converged']}/{row['windows_total']} windows converged, "
                   f"{float(row['mean_iterations']):.3f} iterations/window, {float(row['wall_seconds']) / 60:.0f} min")
        return f"failed ({row['failure']}), {figures}" if row["failure"] else f"finished, {figures}"
    status = read_status(run_dir)
    if not status:
        return "waiting"
    done = f"{status.get('windows_completed', 0)}/{status.get('windows_total', '?')} windows"
    if status.get("state") == "died":
        return f"stopped midway at {done} (its process is gone; a rerun starts it again)"
    if status.get("state") in ("starting", "running"):
        age = (now or time.time()) - float(status.get("updated", 0))
        where = f", t = {status['time']:g} s" if "time" in status else ""
        return f"running, {done}{where} (updated {age:.0f} s ago)"
    return f"{status.get('state')}, {done} (no row yet: a rerun takes it as it is)"


def campaign_status(campaign: str | Path, out: str | Path) -> list[str]:
    """Lines saying where each FOM-FOM run, model and ROM-FOM run of the campaign stands."""
    out = Path(out).resolve()
    plan = load_plan(campaign, out)
    fom_rows, rom_rows = _table(out / "fom" / TABLE), _table(out / "rom" / TABLE)
    fom_dir = {name: out / "fom" / "runs" / run.name for name, run in plan.fom.items()}
    lines = [f"FOM-FOM {name:<22}{run.name}  {run_state(fom_dir[name], fom_rows.get(run.name))}"
             for name, run in plan.fom.items()]
    current = set()
    for name, spec in plan.models.items():
        sources = [str(fom_dir[run] / "results.h5") for run in spec["runs"]]
        if model_is_current(spec["path"], model_key(sources, str(plan.rom_config), spec["set"])):
            state = "trained"
            current.add(name)
        elif spec["path"].is_file():
            state = "out of date (its configuration or runs changed): a rerun trains it again"
        else:
            waiting = [run for run in spec["runs"] if plan.fom[run].name not in fom_rows]
            state = f"waiting for {', '.join(waiting)}" if waiting else "not trained yet"
        lines.append(f"model   {name:<22}{state}")
    for p in plan.predictions:
        run_dir, model = out / "rom" / "runs" / p.run.name, plan.models[p.model]["path"]
        state = run_state(run_dir, rom_rows.get(p.run.name))
        older = (run_dir / "results.h5").is_file() and not ran_after_model(run_dir, model)
        if (p.model not in current or (older and p.run.name not in rom_rows)) and state != "waiting" \
                and not state.startswith("running"):
            state = f"{state.split(' (')[0]} with an earlier model (a rerun runs it again, keeping this run beside)"
        lines.append(f"ROM-FOM {p.name:<22}{p.run.name}  {state}")
    return lines
