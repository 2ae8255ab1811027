"""Sweeps on Dask: run lists, the table, resuming, failure classes, a scheduler and workers as processes."""

import csv
import json
import os
import subprocess
import sys
import time

import pytest

from cosim.cli import main
from cosim.errors import SceneError
from tests.conftest import ROOT, TUBE_SCENE, wait_for
from workflow.sweep import SweepRun, SweepTable, file_runs, grid_runs, run_sweep, scene_fingerprint

SHORT = ["time.end=0.5"]


def rows(directory):
    with open(directory / "sweep.csv", newline="") as stream:
        return {row["name"]: row for row in csv.DictReader(stream)}


def test_grid_runs_are_the_cartesian_product_with_stable_names(tmp_path):
    runs = grid_runs(["inlet.h=4,6", 'coupling.acceleration={type="aitken", data=["section"]},{type="none"}'],
                     ["time.end=1"])
    assert [r.overrides for r in runs] == [
        ("time.end=1", "inlet.h=4", 'coupling.acceleration={type="aitken", data=["section"]}'),
        ("time.end=1", "inlet.h=4", 'coupling.acceleration={type="none"}'),
        ("time.end=1", "inlet.h=6", 'coupling.acceleration={type="aitken", data=["section"]}'),
        ("time.end=1", "inlet.h=6", 'coupling.acceleration={type="none"}')]
    assert runs[0].name == SweepRun(runs[0].overrides).name != runs[1].name
    listing = tmp_path / "runs.txt"
    listing.write_text("# two runs\ninlet.h=4 inlet.f=2\n\ninlet.h=6 'inlet.table=a b.csv'\n")
    assert [r.overrides for r in file_runs(listing)] == [("inlet.h=4", "inlet.f=2"), ("inlet.h=6", "inlet.table=a b.csv")]
    with pytest.raises(SceneError, match="--grid 'inlet.h' is not of the form key=v1,v2"):
        grid_runs(["inlet.h"])
    listing.write_text("inlet.h=4 oops\n")
    with pytest.raises(SceneError, match=r"runs.txt:1: 'oops' is not of the form key=value"):
        file_runs(listing)


def test_bad_variants_stop_the_sweep_before_anything_runs(tmp_path, capsys):
    code = main(["sweep", str(TUBE_SCENE), "--grid", 'coupling.acceleration={type="aitken"},{type="magic"}',
                 "--out", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err
    assert "(coupling.acceleration={type=\"magic\"}): " in err and "'coupling.acceleration.type' is 'magic'" in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "sweep.csv").exists()


def test_a_local_sweep_fills_its_table_classifies_failures_and_resumes(tmp_path):
    grid = ["coupling.max_iterations=2,90", "inlet.h=4,6"]
    seen = []
    run_sweep(str(TUBE_SCENE), grid_runs(grid, SHORT), tmp_path, workers=2, progress=False,
              on_row=lambda run, row: seen.append(run.name))
    table = rows(tmp_path)
    assert len(table) == 4 == len(seen)
    for row in table.values():
        if row["coupling.max_iterations"] == "90":
            assert row["failure"] == "" and row["windows_converged"] == row["windows_total"] == "5"
            assert 1.0 < float(row["mean_iterations"]) <= int(row["max_iterations"]) < 90
        else:
            assert row["failure"] == "max-iterations" and "did not converge in 2 iterations" in row["failure_message"]
            assert row["windows_converged"] == "0"
        assert (tmp_path / "runs" / row["name"] / "results.h5").is_file()
    # a rerun with more values skips the four finished runs and runs only the new two
    seen.clear()
    run_sweep(str(TUBE_SCENE), grid_runs(["coupling.max_iterations=2,90", "inlet.h=4,6,8"], SHORT), tmp_path,
              workers=2, progress=False, on_row=lambda run, row: seen.append(run.name))
    assert len(seen) == 2 and len(rows(tmp_path)) == 6
    assert all(table[name] == rows(tmp_path)[name] for name in table)


def test_a_sweep_on_a_scheduler_and_workers_started_by_hand_gives_the_local_table(tmp_path):
    runs = grid_runs(["inlet.h=4,6"], SHORT)
    run_sweep(str(TUBE_SCENE), runs, tmp_path / "local", workers=2, progress=False)
    scheduler_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    processes = [subprocess.Popen([*dask, "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                   "--scheduler-file", str(scheduler_file)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)]
    try:
        wait_for(scheduler_file.exists, "the scheduler file", timeout=60)
        for _ in range(2):
            processes.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", "--nthreads", "1", "--no-dashboard",
                 "--host", "127.0.0.1", "--scheduler-file", str(scheduler_file)],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT,
                env={**os.environ, "PYTHONPATH": str(ROOT)}))
        import json
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        run_sweep(str(TUBE_SCENE), runs, tmp_path / "remote", scheduler=address, progress=False)
    finally:
        for process in processes[::-1]:
            process.terminate()
        deadline = time.monotonic() + 20
        for process in processes:
            process.wait(timeout=max(1.0, deadline - time.monotonic()))
    local, remote = rows(tmp_path / "local"), rows(tmp_path / "remote")
    assert local.keys() == remote.keys()
    for name in local:
        for column in ("windows_converged", "windows_total", "mean_iterations", "max_iterations", "failure"):
            assert local[name][column] == remote[name][column]


def test_an_interrupted_sweep_resumes_without_redoing_finished_runs(tmp_path):
    """Kill `cosim sweep` once a run has finished; the rerun adds only the missing rows and leaves finished runs alone."""
    import signal
    out = tmp_path / "sweep"
    command = [sys.executable, "-m", "cosim", "sweep", str(TUBE_SCENE), "--grid", "inlet.h=4,5,6,7", "--set", "time.end=8",
               "--workers", "1", "--out", str(out), "--quiet"]
    first = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
    try:
        wait_for(lambda: (out / "sweep.csv").exists() and len(rows(out)) >= 1, "a finished run in the table", timeout=120)
    finally:
        os.killpg(first.pid, signal.SIGKILL)   # the sweep, its Dask cluster and the run in flight
        first.wait(timeout=30)
    done = rows(out)
    assert 1 <= len(done) < 4
    stamps = {name: (out / "runs" / name / "results.h5").stat().st_mtime_ns for name in done}
    assert subprocess.run(command, cwd=ROOT, capture_output=True, timeout=300).returncode == 0
    after = rows(out)
    assert len(after) == 4 and all(after[name] == done[name] for name in done)
    assert all((out / "runs" / name / "results.h5").stat().st_mtime_ns == stamps[name] for name in done)


def test_a_sweep_directory_refuses_runs_of_a_changed_scene_but_not_of_a_recommented_one(tmp_path, capsys):
    scene = tmp_path / "tube.toml"
    text = TUBE_SCENE.read_text()
    scene.write_text(text)
    out = tmp_path / "sweep"
    table = SweepTable(out / "sweep.csv", ["inlet.h"], scene_fingerprint(scene))
    table.add(SweepRun(("inlet.h=4",)), {"windows_converged": 5, "failure": ""})
    scene.write_text("# a new comment, and the same data laid out again\n" + text + "\n\n")
    assert scene_fingerprint(scene) == scene_fingerprint(TUBE_SCENE)
    assert "run-" in next(iter(SweepTable(out / "sweep.csv", ["inlet.h"], scene_fingerprint(scene)).done))
    scene.write_text(text.replace("max_iterations = ", "max_iterations = 1", 1))
    assert scene_fingerprint(scene) != scene_fingerprint(TUBE_SCENE)
    code = main(["sweep", str(scene), "--grid", "inlet.h=4,6", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "holds runs made with other scene data" in err and str(out) in err
    assert len(rows(out)) == 1 and not (out / "runs").exists()


def test_a_run_that_finished_without_its_row_is_taken_as_it_is_and_a_stopped_one_runs_again(tmp_path):
    # the sweep stopped after one run had finished but before its row was written, and midway through another
    out = tmp_path / "sweep"
    runs = grid_runs(["inlet.h=4,6"], SHORT)
    run_sweep(str(TUBE_SCENE), runs, out, workers=1, progress=False)
    table = rows(out)
    finished, stopped = (out / "runs" / run.name for run in runs)
    stamp = (finished / "results.h5").stat().st_mtime_ns
    header = (out / "sweep.csv").read_text().splitlines()[0]
    (out / "sweep.csv").write_text(header + "\n")                           # both rows lost
    status = json.loads((stopped / "status.json").read_text())
    (stopped / "status.json").write_text(json.dumps({**status, "state": "running"}))
    stopped_stamp = (stopped / "results.h5").stat().st_mtime_ns
    run_sweep(str(TUBE_SCENE), runs, out, workers=1, progress=False)
    again = rows(out)
    same = [key for key in table[runs[0].name] if key != "wall_seconds"]   # the run's own wall, not the task's
    assert [again[runs[0].name][k] for k in same] == [table[runs[0].name][k] for k in same]   # not run again
    assert (finished / "results.h5").stat().st_mtime_ns == stamp
    assert (stopped / "results.h5").stat().st_mtime_ns != stopped_stamp    # run again from its beginning
    assert again[runs[1].name]["windows_converged"] == table[runs[1].name]["windows_converged"] == "5"


def test_a_key_only_a_component_checks_stops_the_sweep_before_anything_runs(tmp_path, capsys):
    code = main(["sweep", str(TUBE_SCENE), "--grid", "inlet.hh=4,6", "--set", "time.end=0.3", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert "unknown key 'inlet.hh'" in err and "did you mean 'inlet.h'?" in err
    assert not (tmp_path / "runs").exists()


def test_failed_runs_set_the_exit_code_and_the_sweeps_set_values_are_in_its_table_and_fingerprint(tmp_path, capsys):
    out = tmp_path / "sweep"
    code = main(["sweep", str(TUBE_SCENE), "--grid", "coupling.max_iterations=2,90", "--set", "time.end=0.3",
                 "--out", str(out), "--quiet"])
    assert code == 1
    assert capsys.readouterr().out.strip() == f"2 runs, 1 failed (max-iterations 1); table in {out / 'sweep.csv'}"
    table = rows(out)
    assert sorted(row["time.end"] for row in table.values()) == ["0.3", "0.3"]
    code = main(["sweep", str(TUBE_SCENE), "--grid", "coupling.max_iterations=2,90", "--set", "time.end=0.5",
                 "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "holds runs made with other scene data" in err
    assert rows(out) == table


def test_a_second_sweep_into_a_directory_in_use_is_refused(tmp_path):
    from cosim.rundir import RunDirectoryError, hold
    lock = hold(tmp_path, "sweep")      # as a sweep in progress holds it
    try:
        with pytest.raises(RunDirectoryError, match=f"'{tmp_path}' is in use by a sweep in progress \\(pid "):
            run_sweep(str(TUBE_SCENE), grid_runs(["inlet.h=4"], SHORT), tmp_path, workers=1, progress=False)
    finally:
        os.close(lock)
    assert not (tmp_path / "sweep.csv").exists()


@pytest.mark.parametrize("address, refused", [
    ("tcp://10.1.2.3:8786", "neither encrypted nor authenticated"),
    ("tcp://scheduler.example:8786", "neither encrypted nor authenticated"),
    ("http://127.0.0.1:8786", "is not of the form tls://HOST:PORT or tcp://HOST:PORT"),
])
def test_a_scheduler_off_this_host_needs_tls_or_an_explicit_insecure_flag(tmp_path, capsys, address, refused):
    code = main(["sweep", str(TUBE_SCENE), "--grid", "inlet.h=4", "--out", str(tmp_path), "--scheduler", address])
    err = capsys.readouterr().err.strip()
    assert code == 2 and refused in err and "\n" not in err
    from workflow.sweep import check_scheduler
    for fine in ("tls://10.1.2.3:8786", "tcp://127.0.0.1:8786", "tcp://localhost:8786", "tcp://[::1]:8786"):
        check_scheduler(fine)
    if "not of the form" not in refused:
        check_scheduler(address, insecure=True)
