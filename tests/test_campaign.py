"""``cosim campaign`` on the tube: FOM runs, training and ROM-FOM runs on a local Dask cluster, resumed."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.errors import SceneError
from workflow.campaign import load_plan

ROOT = Path(__file__).resolve().parents[1]

CAMPAIGN = """
scene = "{root}/scenes/tube_fom.toml"
rom_config = "{root}/rom_configs/tube_rom.toml"

[fom]
mu1 = ["time.end=8.0"]
stiff = ["time.end=8.0", "tube.stiffness_factor=1.2"]

[models]
a = {{ runs = ["mu1"], set = ["snapshots.t_max=6.0", "selection.table=false"] }}
ab = {{ runs = ["mu1", "stiff"], set = ["snapshots.t_max=6.0", "selection.choose='holdout'",
                                       "selection.force_modes=[2, 3]", "selection.disp_modes=[9]",
                                       "selection.split='windows'", "selection.compare_splits=true"] }}

[[predictions]]
model = "a"
reference = "mu1"
switch_time = 6.0

[[predictions]]
model = "ab"
reference = "stiff"
switch_time = 6.0

[[predictions]]
model = "a"
reference = "mu1"
switch_time = 6.0
fmu = true
set = ["time.end=7.0"]
"""


def campaign(path: Path, out: Path, *options: str, workers: int = 2) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cosim", "campaign", str(path), "--out", str(out),
                           "--workers", str(workers), *options], cwd=ROOT, capture_output=True, text=True, timeout=600)


def one_run_plan(end: float, predictions: str) -> str:
    """A campaign of one FOM run (``mu1``, to ``end``) and one model (``a``, on t <= 6), with ``predictions``."""
    return f"""
scene = "{ROOT}/scenes/tube_fom.toml"
rom_config = "{ROOT}/rom_configs/tube_rom.toml"
[fom]
mu1 = ["time.end={end}"]
[models]
a = {{ runs = ["mu1"], set = ["snapshots.t_max=6.0", "selection.table=false"] }}
{predictions}"""


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as stream:
        return list(csv.DictReader(stream))


def test_a_campaign_trains_on_its_fom_runs_predicts_reports_and_resumes(tmp_path):
    plan = tmp_path / "campaign.toml"
    plan.write_text(CAMPAIGN.format(root=ROOT))
    out = tmp_path / "out"
    done = campaign(plan, out)
    assert done.returncode == 0, done.stderr
    fom, rom = rows(out / "fom/sweep.csv"), rows(out / "rom/sweep.csv")
    assert len(fom) == 2 and len(rom) == 3
    assert all(row["failure"] == "" for row in fom + rom)
    assert sorted(row["windows_converged"] for row in fom + rom) == ["70", "80", "80", "80", "80"]   # the FMU's to 7 s
    # the model on two runs trained on both: twice the snapshots of one, windows labelled per run
    a = json.loads((out / "models/a.json").read_text())
    log = (out / "models/ab.log").read_text()
    assert "from 2 run(s)" in log and "split by windows" in log and "split by snapshots" in log
    assert len(a["sources"]) == 1
    for name in ("ab_singular_values.png", "ab_holdout.png"):
        assert (out / "models" / name).stat().st_size > 5_000
    report = json.loads((out / "report/report.json").read_text())["runs"]
    assert [Path(r["run"]).name for r in report] == [p.run.name for p in load_plan(plan, out).predictions if not p.fmu]
    # each ROM-FOM run is named by its prediction, also in the README summary
    names = json.loads((out / "rom/predictions.json").read_text())
    assert sorted(names[row["name"]] for row in rom) == sorted(p.name for p in load_plan(plan, out).predictions)
    summary = subprocess.run([sys.executable, "-m", "scripts.campaign_readme", str(out)], cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout
    assert "ROM-FOM a-mu1-fmu against mu1 from 6 s: 70 windows converged" in summary
    # the FMU of model a served the solid in the third run, bit for bit as the Python ROM in the first
    check = (out / "report/fmu_check.txt").read_text()
    assert check.startswith("a-mu1-fmu against a-mu1 over the first 70 windows (of 80)")
    assert check.strip().endswith(": bit-identical")
    assert (out / "models/a.fmu").stat().st_size > 10_000
    for row, bound in zip(report, (5e-3, 3e-2)):   # the second model serves two stiffnesses with 2-3 modes
        assert row["switch_time"] == 6.0 and row["predicted_windows"] == 20
        assert 0 < row["monitor_error"] < bound
    # a rerun has nothing left to run: same tables, models untouched
    stamp = (out / "models/a.npz").stat().st_mtime_ns
    again = campaign(plan, out)
    assert again.returncode == 0, again.stderr
    assert rows(out / "fom/sweep.csv") == fom and rows(out / "rom/sweep.csv") == rom
    assert (out / "models/a.npz").stat().st_mtime_ns == stamp
    # a changed model configuration retrains that model and reruns its prediction only
    plan.write_text(CAMPAIGN.format(root=ROOT).replace('"snapshots.t_max=6.0", "selection.table=false"',
                                                       '"snapshots.t_max=5.0", "selection.table=false"'))
    status = campaign(plan, out, "--status").stdout.splitlines()
    assert [line.split()[1] for line in status if "with an earlier model (a rerun runs it again" in line] == \
        ["a-mu1", "a-mu1-fmu"], status                                    # model a's two runs, not ab's
    third = campaign(plan, out)
    assert third.returncode == 0, third.stderr
    assert (out / "models/a.npz").stat().st_mtime_ns != stamp
    after = rows(out / "rom/sweep.csv")
    assert len(rows(out / "fom/sweep.csv")) == 2 and len(after) == 3
    before, now = {r["name"]: r for r in rom}, {r["name"]: r for r in after}
    predictions = load_plan(plan, out).predictions
    a_runs = {predictions[0].run.name, predictions[2].run.name}           # a's ROM and FMU predictions
    assert now.keys() == before.keys() and all(now[name] != before[name] for name in a_runs)   # ran again
    for name in a_runs:   # the runs of the former model are kept beside, not overwritten
        (kept,) = (out / "rom/runs").glob(f"{name}.stale-*")
        assert (kept / "results.h5").stat().st_size > 0
    assert all(now[name] == before[name] for name in now if name not in a_runs)               # b's did not
    assert (out / "models/a.fmu").stat().st_mtime_ns > (out / "models/a.npz").stat().st_mtime_ns   # exported again
    assert (out / "report/fmu_check.txt").read_text().strip().endswith(": bit-identical")
    # rows lost (the campaign stopped between a run's end and its row): finished runs are taken as they are,
    # except ROM-FOM runs older than their model, which run again
    def lose_rows():
        for table in ("fom/sweep.csv", "rom/sweep.csv"):
            (out / table).write_text((out / table).read_text().splitlines()[0] + "\n")

    stamps = {name: (out / "rom/runs" / name / "results.h5").stat().st_mtime_ns for name in now}
    lose_rows()
    fourth = campaign(plan, out)
    assert fourth.returncode == 0, fourth.stderr
    assert "fom mu1: had finished; its row is taken from its run" in fourth.stdout
    assert {r["name"]: r["windows_converged"] for r in rows(out / "rom/sweep.csv")} == \
        {name: row["windows_converged"] for name, row in now.items()}
    assert all((out / "rom/runs" / name / "results.h5").stat().st_mtime_ns == stamps[name] for name in now)
    newer = max(stamps.values()) + 1_000_000_000
    os.utime(out / "models/ab.npz", ns=(newer, newer))
    lose_rows()
    fifth = campaign(plan, out)
    assert fifth.returncode == 0, fifth.stderr
    assert [name for name in now if (out / "rom/runs" / name / "results.h5").stat().st_mtime_ns != stamps[name]] == \
        [predictions[1].run.name]                                            # ab's prediction ran again
    assert len(list((out / "rom/runs").glob(f"{predictions[1].run.name}.stale-*"))) == 1


@pytest.mark.parametrize("text, message", [
    ('scene = "x.toml"\nrom_config = "y.toml"\npredictions = []\n[fom]\na = []\n[models]\nm = { runs = ["b"] }',
     "models.m.runs names 'b', which is not in [fom]"),
    ('scene = "x.toml"\nrom_config = "y.toml"\n[fom]\na = []\n[models]\nm = { runs = ["a"] }\n'
     '[[predictions]]\nmodel = "n"\nreference = "a"\nswitch_time = 1.0', "predictions.0.model is 'n'"),
    ('scene = "x.toml"\nrom_config = "y.toml"\n[fom]\na = []\n[models]\nm = { runs = ["a"] }\n'
     '[[predictions]]\nmodel = "m"\nreference = "a"\nswitch_time = 1.0\n'
     '[[predictions]]\nmodel = "m"\nreference = "a"\nswitch_time = 2.0', "predictions.1 is named 'm-a' like an earlier one"),
    ('scene = "x.toml"\nrom_config = "y.toml"\npredictions = []\n[fom]\na = []\n[models]\nm = { runs = ["a"], recipe = "r" }',
     "models.m.recipe is 'r', which is not in [recipes]"),
    ('scene = "x.toml"\nrom_config = "y.toml"\npredictions = []\n[recipes]\nr = "a=1"\n[fom]\na = []\n[models]',
     "recipes.r must be a list of KEY=VALUE strings"),
])
def test_a_campaign_file_naming_unknown_runs_or_models_is_refused(tmp_path, text, message):
    plan = tmp_path / "c.toml"
    plan.write_text(text)
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_plan(plan, tmp_path)


def test_recipes_expand_to_the_overrides_they_name_before_a_table_s_own(tmp_path):
    """The paper's campaign file names its recipes once: ROM 1's model overrides are the cubic recipe's, then its own."""
    plan = load_plan(ROOT / "campaigns/double_flap_campaign.toml", tmp_path)
    assert plan.models["rom1"]["set"] == ["snapshots.t_max=3.0", "model.regressor.method='ridge'",
                                          "model.regressor.cross_modes=5", "model.regressor.cubic_modes=3",
                                          "selection.compare_splits=true"]
    assert plan.models["rom2_lasso"]["set"] == ["snapshots.t_max=3.0"]
    rom4 = next(p for p in plan.predictions if p.name == "rom4-re192")
    assert rom4.run.overrides[-2:] == ("components.solid.rom.transient_calls=2",
                                      "components.solid.rom.transient_margin=3.0")


def test_retry_failed_reruns_a_failed_prediction_and_keeps_the_failed_run_beside(tmp_path):
    plan = tmp_path / "campaign.toml"
    plan.write_text(one_run_plan(7.0, """
[[predictions]]
model = "a"
reference = "mu1"
switch_time = 6.0
set = ["components.solid.rom.on_out_of_range='fail'", "components.solid.rom.range_margin=0.0"]
"""))
    out = tmp_path / "out"
    assert campaign(plan, out).returncode == 0
    (first,) = rows(out / "rom/sweep.csv")
    assert first["failure"] == "component-error" and "outside the training range" in first["failure_message"]
    assert campaign(plan, out).returncode == 0 and rows(out / "rom/sweep.csv") == [first]   # a failure stays done
    retry = campaign(plan, out, "--retry-failed")
    assert retry.returncode == 0, retry.stderr
    (second,) = rows(out / "rom/sweep.csv")
    assert second["name"] == first["name"] and second["wall_seconds"] != first["wall_seconds"]   # it ran again
    kept = list((out / "rom/runs").glob(f"{first['name']}.failed-*"))
    assert len(kept) == 1 and (kept[0] / "results.h5").is_file()


def test_a_model_may_train_on_a_failed_run_only_up_to_its_training_end(tmp_path):
    from workflow.campaign import _end_time, _training_end
    config = tmp_path / "rom.toml"
    config.write_text("[snapshots]\nt_max = 1.0\n")
    assert _training_end(config, []) == 1.0
    assert _training_end(config, ["snapshots.t_max=3.0"]) == 3.0        # the model's own override wins
    assert _training_end(tmp_path / "rom.toml", ["model.encoder.modes=4"]) == 1.0
    assert _end_time(tmp_path / "no-run") == 0.0                        # a run without results holds no data


def task_order(plan: Path, out: Path) -> tuple[list[str], subprocess.CompletedProcess]:
    """The order in which a one-worker campaign ran its tasks ("fom NAME", "model NAME", "rom NAME")."""
    done = campaign(plan, out, workers=1)
    assert done.returncode == 0, done.stderr
    return [line.split(":")[0] for line in done.stdout.splitlines() if line.startswith(("fom ", "model ", "rom "))], done


def test_the_runs_a_model_trains_on_go_first_even_when_listed_last(tmp_path):
    plan = tmp_path / "campaign.toml"
    plan.write_text(f"""
scene = "{ROOT}/scenes/tube_fom.toml"
rom_config = "{ROOT}/rom_configs/tube_rom.toml"
[fom]
reference = ["time.end=3.0", "tube.stiffness_factor=1.1"]
training = ["time.end=3.0"]
[models]
a = {{ runs = ["training"], set = ["snapshots.t_max=2.0", "selection.table=false"] }}
[[predictions]]
model = "a"
reference = "reference"
switch_time = 2.0
""")
    order, done = task_order(plan, tmp_path / "out")
    # one worker: the training run, its model and the ROM-FOM run before the reference-only run
    assert order == ["fom training", "model a", "rom a-reference", "fom reference"], done.stdout
    # --status reads where everything stands; a run whose process is gone shows as stopped midway
    out = tmp_path / "out"
    rom_dir = next((out / "rom/runs").iterdir())
    (out / "rom/sweep.csv").write_text((out / "rom/sweep.csv").read_text().splitlines()[0] + "\n")
    (rom_dir / "status.json").write_text(json.dumps({"state": "running", "pid": 2 ** 22 + 7, "updated": 0,
                                                     "windows_total": 30, "windows_completed": 12, "time": 1.2}))
    status = campaign(plan, out, "--status")
    assert status.returncode == 0, status.stderr
    lines = status.stdout.splitlines()
    assert lines[0].startswith("FOM-FOM reference") and "finished, 30/30 windows converged" in lines[0]
    assert lines[2].split() == ["model", "a", "trained"]
    assert lines[3].startswith("ROM-FOM a-reference") and "stopped midway at 12/30 windows" in lines[3]
    # the report while runs are still going: only pairs whose run and reference have both finished
    from workflow.campaign import write_campaign_report
    loaded = load_plan(plan, out)
    fom_dir = {name: out / "fom/runs" / run.name for name, run in loaded.fom.items()}
    rom_dir = {p.name: out / "rom/runs" / p.run.name for p in loaded.predictions}
    (out / "report/tips_gone.png").write_bytes(b"a figure of a run no longer in the report")
    write_campaign_report(loaded, out, fom_dir, rom_dir, {}, lambda line: None, {"training", "a-reference"})
    assert not (out / "report/report.json").exists()        # its reference is not in: no table
    assert not (out / "report/tips_gone.png").exists()      # the report is written whole, nothing left from before
    assert not list(out.glob("report.partial-*"))
    write_campaign_report(loaded, out, fom_dir, rom_dir, {}, lambda line: None,
                          {"training", "reference", "a-reference"})
    assert [r["label"] for r in json.loads((out / "report/report.json").read_text())["runs"]] == ["a-reference"]
    # the run stopped midway runs again from its beginning; what it had computed is kept beside
    again = campaign(plan, out, workers=1)
    assert again.returncode == 0, again.stderr
    (kept,) = (out / "rom/runs").glob(f"{rom_dir['a-reference'].name}.stopped-*")
    assert json.loads((kept / "status.json").read_text())["windows_completed"] == 12
    assert json.loads((rom_dir["a-reference"] / "status.json").read_text())["state"] == "finished"


def test_a_failing_interim_report_does_not_stop_the_runs(tmp_path):
    """The first prediction ran another scene than its reference (the report refuses it): the campaign warns after
    that run, runs the next, and only then says the report failed."""
    plan = tmp_path / "campaign.toml"
    plan.write_text(one_run_plan(8.0, """
[[predictions]]
model = "a"
reference = "mu1"
switch_time = 6.0
set = ["coupling.max_iterations=40"]

[[predictions]]
model = "a"
reference = "mu1"
switch_time = 7.0
label = "later"
"""))
    out = tmp_path / "out"
    done = campaign(plan, out, workers=1)
    assert done.returncode == 2
    assert "warning: the interim report failed (the runs go on)" in done.stdout
    assert "coupling.max_iterations is 90 there and 40 here" in done.stderr
    rom = rows(out / "rom/sweep.csv")
    assert len(rom) == 2 and all(row["failure"] == "" and row["windows_converged"] == "80" for row in rom)


@pytest.mark.parametrize("state, kept_as", [("finished", "stale"), ("failed", "stale"), ("running", "stopped"),
                                            (None, "stopped")])
def test_a_run_that_runs_again_is_kept_beside_named_by_why(tmp_path, state, kept_as):
    from workflow.campaign import _set_aside, _why_again
    run = tmp_path / "run-1"
    run.mkdir()
    if state:
        (run / "status.json").write_text(json.dumps({"state": state}))
    _set_aside(run, _why_again(run))
    (kept,) = tmp_path.iterdir()
    assert not run.exists() and kept.name.startswith(f"run-1.{kept_as}-")
    _set_aside(run, "stale")        # nothing there: nothing to keep
    assert list(tmp_path.iterdir()) == [kept]


def test_rom_fom_runs_go_in_the_campaign_files_order_whatever_order_their_models_trained_in(tmp_path):
    plan = tmp_path / "campaign.toml"
    plan.write_text(f"""
scene = "{ROOT}/scenes/tube_fom.toml"
rom_config = "{ROOT}/rom_configs/tube_rom.toml"
[fom]
training = ["time.end=3.0"]
[models]
b = {{ runs = ["training"], set = ["snapshots.t_max=2.0", "selection.table=false"] }}
a = {{ runs = ["training"], set = ["snapshots.t_max=2.5", "selection.table=false"] }}
[[predictions]]
model = "a"
reference = "training"
switch_time = 2.5

[[predictions]]
model = "b"
reference = "training"
switch_time = 2.0
""")
    order, done = task_order(plan, tmp_path / "out")
    # one worker: model b trains first (listed first), but a's prediction is listed first, so it runs first
    assert order == ["fom training", "model b", "model a", "rom a-training", "rom b-training"], done.stdout


def test_a_second_campaign_into_a_directory_in_use_is_refused(tmp_path):
    from cosim.rundir import hold
    path = tmp_path / "campaign.toml"
    path.write_text(CAMPAIGN.format(root=ROOT))
    out = tmp_path / "out"
    lock = hold(out, "campaign")       # as a campaign in progress holds it
    try:
        done = campaign(path, out)
    finally:
        os.close(lock)
    assert done.returncode == 2
    assert done.stderr.strip() == (f"cosim campaign: error: '{out}' is in use by a campaign in progress "
                                   f"(pid {os.getpid()}); choose another --out")
    assert not (out / "fom").exists()


def test_a_campaign_stopped_midway_goes_on_from_its_runs_checkpoints(tmp_path):
    """Ctrl-C in the campaign's terminal (its process group): its FOM run loses at most checkpoint_every windows."""
    import signal

    from cosim.results import RunResults
    from tests.conftest import wait_for, windows_done
    plan = tmp_path / "campaign.toml"
    plan.write_text(f"""scene = "{ROOT}/scenes/tube_fom.toml"
rom_config = "{ROOT}/rom_configs/tube_rom.toml"
predictions = []
[fom]
mu1 = ["time.end=120.0", "output.checkpoint_every=10"]
[models]
""")
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "cosim", "campaign", str(plan), "--out", str(out), "--workers",
                                "1"], cwd=ROOT, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        run_dir = wait_for(lambda: next((out / "fom" / "runs").glob("run-*"), None) if (out / "fom" / "runs").is_dir()
                           else None, "the FOM run's directory")
        wait_for(lambda: windows_done(run_dir) >= 45 or process.poll() is not None, "45 windows of the FOM run")
        os.killpg(process.pid, signal.SIGINT)
        process.wait(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    from cosim.checkpoint import read
    from cosim.rundir import read_status
    # the Dask worker that ran it dies with the campaign, a moment later: until then it may still be writing
    wait_for(lambda: read_status(run_dir).get("state") not in ("starting", "running"), "the FOM run's process to end")
    with RunResults(run_dir) as cut:
        kept = len(cut.windows.iterations)
        walls = cut.windows.wall_seconds.copy()
    checkpointed = read(run_dir / "checkpoint.npz")[0]["windows"]
    assert 40 <= kept < 1200 and 0 <= kept - checkpointed <= 10      # it loses at most checkpoint_every windows
    done = campaign(plan, out, workers=1)
    assert done.returncode == 0, done.stderr
    with RunResults(run_dir) as whole:
        assert len(whole.windows.iterations) == 1200
        assert whole.windows.wall_seconds[:checkpointed].tobytes() == walls[:checkpointed].tobytes()   # kept
