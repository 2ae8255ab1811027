"""Faults named where they happen; runs that never overwrite each other; unconverged windows counted."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys

import numpy as np
import pytest

from cosim.cli import main
from cosim.errors import DivergenceError, NonFiniteOutput
from cosim.results import RunResults
from cosim.rundir import read_status
from cosim.scene import load_scene
from coupler.run import run_scene
from tests.conftest import ROOT, TUBE_SCENE, alive_with, children_of, cmdline, wait_for, windows_done


def run(out, *overrides, **kwargs):
    return run_scene(load_scene(TUBE_SCENE, list(overrides)), out, progress=False, **kwargs)


def test_nan_from_the_solid_names_the_solid_variable_window_time_and_iteration(tmp_path):
    with pytest.raises(NonFiniteOutput) as error:
        run(tmp_path / "nan", "time.end=1", "components.solid.entry=tests.components:NanSolid")
    assert str(error.value) == ("component 'solid' in window 3 (t = 0.2 to 0.3), iteration 1: output 'section' "
                                "is not finite: nan at index 5 (1 of 101 values)")
    with RunResults(tmp_path / "nan") as results:
        assert len(results.windows) == 2
    assert read_status(tmp_path / "nan")["state"] == "failed"


def test_accepted_windows_are_counted(tmp_path, capsys):
    code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "accept"), "--quiet", "--set", "time.end=1",
                 "--set", "coupling.max_iterations=2", "--set", "coupling.on_max_iterations=\"accept\""])
    out, err = capsys.readouterr()
    assert code == 0
    with RunResults(tmp_path / "accept") as results:
        unconverged = int((~results.windows.converged).sum())
        assert results.attributes["windows_unconverged"] == unconverged > 0
    assert f"10 windows ({unconverged} did not converge)" in out
    assert err.count("did not converge in 2 iterations") == unconverged


def test_numpys_warnings_are_not_printed_above_the_error_line(tmp_path):
    """The coupler's norm of sections of 1e160 overflows (NumPy's RuntimeWarning); the run's failure is still the
    one line on stderr."""
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(tmp_path / "huge"),
                           "--quiet", "--set", "time.end=1", "--set",
                           "components.solid.entry=tests.components:OverflowingSolid"],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith("cosim run: error: component 'fluid' in window 1")


def test_a_growing_residual_stops_an_accepting_run_as_diverged(tmp_path):
    with pytest.raises(DivergenceError, match=r"window 1 \(t = 0 to 0.1\): diverged: the coupling residual grew from "
                                              r"[\d.e+-]+ to [\d.e+-]+ in 6 iterations"):
        run(tmp_path / "div", "time.end=1", "components.solid.entry=tests.components:DivergingSolid",
            "coupling.max_iterations=6", "coupling.on_max_iterations=\"accept\"")


def test_newton_stalling_at_round_off_is_not_a_failure(tmp_path):
    """inlet.h = 24: window 1's Newton iterations stall at a relative residual of 1.2e-10 (tolerance 1e-10)."""
    summary = run(tmp_path / "h24", "time.end=0.5", "inlet.h=24")
    assert summary.windows == 5


def test_a_finished_run_is_never_overwritten_without_overwrite(tmp_path, capsys):
    out = tmp_path / "run"
    run(out, "time.end=0.3")
    before = (out / "results.h5").read_bytes()
    code = main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=0.5"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert err == (f"cosim run: error: '{out}' already holds a run (finished, 3 windows); choose another --out "
                   "or pass --overwrite to replace it")
    assert (out / "results.h5").read_bytes() == before
    assert main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--overwrite", "--set", "time.end=0.5"]) == 0
    with RunResults(out) as results:
        assert len(results.windows) == 5


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_run_in_progress_is_never_touched(tmp_path, overwrite):
    out = tmp_path / "busy"
    # long enough (6000 windows) to be still running whatever the load; it is terminated below
    first = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                              "--set", "time.end=600"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    try:
        wait_for(lambda: windows_done(out) >= 3, "the first run's third window")
        second = subprocess.run([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out),
                                 "--quiet", "--set", "time.end=60"] + (["--overwrite"] if overwrite else []),
                                cwd=ROOT, capture_output=True, text=True, timeout=60)
        assert second.returncode == 2
        assert second.stderr.strip() == (f"cosim run: error: '{out}' is in use by a run in progress "
                                         f"(pid {first.pid}); choose another --out")
        assert first.poll() is None
    finally:
        first.terminate()
        first.communicate(timeout=30)
    with RunResults(out) as results:      # the first run's file is intact and readable
        windows = len(results.windows)
        assert windows >= 3 and results.fields()["pressure"].shape == (windows, 101)
    assert children_of(os.getpid()) == []


def test_a_run_with_no_finished_window_has_empty_window_datasets(tmp_path):
    with pytest.raises(NonFiniteOutput):
        run(tmp_path / "empty", "time.end=1", "components.solid.entry=tests.components:NanSolid",
            "time.start=0.2", "time.end=1.2")
    with RunResults(tmp_path / "empty") as results:
        windows = results.windows
        for column in (windows.time, windows.iterations, windows.converged, windows.wall_seconds):
            assert column.shape == (0,)
        assert results.attributes["windows_completed"] == 0
    np.testing.assert_equal(read_status(tmp_path / "empty")["windows_completed"], 0)


def test_an_unreachable_tolerance_stops_as_stalled_not_a_crash(tmp_path):
    """Limits of 1e-16 make IQN-ILS meet exactly repeated and zero columns (filtered, never solved); the residual
    stops at round-off, and the failure says so: stalled, not merely out of iterations. Whether the tube's own
    solvers stall there or land on exact fixed points (every window then meets 1e-16) is the BLAS kernel's rounding
    (OpenBLAS's Sandybridge kernel lands on them for 5 s, SkylakeX's stalls in window 22): either way, no crash. A
    solid whose answers jitter by 1e-12 (a solver's unresolved digits) stalls on any machine."""
    from cosim.errors import StalledError
    stalled = (r"^window \d+ \(t = [\d.]+ to [\d.]+\): stalled: the coupling residual stopped decreasing at "
               r"[\d.e+-]+ .* in 90 iterations; .*pressure relative")
    tight = ["coupling.convergence.0.limit=1e-16", "coupling.convergence.1.limit=1e-16", "time.end=5"]
    try:
        run(tmp_path / "tight", *tight)
    except StalledError as error:
        assert re.search(stalled, str(error)), error
    else:
        with RunResults(tmp_path / "tight") as results:
            assert len(results.windows) == 50 and results.windows.converged.all()
    with pytest.raises(StalledError, match=stalled):
        run(tmp_path / "jitter", *tight, "components.solid.entry=tests.components:JitterSolid")


def test_component_warnings_reach_the_run_output_with_their_window(tmp_path, capsys):
    code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "warn"), "--quiet", "--set", "time.end=0.3",
                 "--set", "components.solid.entry=tests.components:WarningSolid"])
    _, err = capsys.readouterr()
    assert code == 0
    lines = [line for line in err.splitlines() if line.startswith("warning:")]
    with RunResults(tmp_path / "warn") as results:
        calls = int(results.windows.iterations[1])
        assert results.attributes["component_warnings"] == calls > 1
    assert lines == [f"warning: component 'solid' in window 2 (t = 0.1 to 0.2): "
                     f"Newton hit its iteration cap (25) ({calls} calls)"]


def test_a_limit_below_the_datas_precision_is_flagged_at_start(tmp_path, capsys):
    """The tube's fluid solves to 1e-10 (relative): a relative limit of 1e-12 on its pressure is flagged before window 1."""
    code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "tight"), "--quiet", "--set", "time.end=0.2",
                 "--set", "coupling.convergence.0.limit=1e-12"])
    err = capsys.readouterr().err
    assert code == 0
    assert ("warning: 'coupling.convergence.0' asks for a relative change below 1e-12, but 'pressure' is computed "
            "to 1e-10 only") in err
    code = main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "fine"), "--quiet", "--set", "time.end=0.2"])
    assert code == 0 and "asks for a relative change" not in capsys.readouterr().err


def test_failing_idle_work_is_stopped_and_the_component_still_serves(tmp_path):
    from cosim.launcher import Launcher
    from cosim.proxy import ComponentProxy
    with Launcher(tmp_path) as launcher:
        process = launcher.spawn("solid", "tests.components:FailingIdleSolid")
        proxy = ComponentProxy("solid", launcher.handshake(process), process=process)
        proxy.instantiate({})
        wait_for(lambda: "idle work failed, stopped: idle work broke" in (tmp_path / "solid.log").read_text(),
                 "the server's message about the failed idle work")
        proxy.enter_initialization_mode(0.0, 1.0)
        proxy.exit_initialization_mode()
        out = proxy.step(0.0, 0.1, {"pressure": np.zeros(101)})
        assert out["section"].shape == (101,) and np.all(np.isfinite(out["section"]))
        log = (tmp_path / "solid.log").read_text()
        assert log.count("idle work failed") == 1       # stopped after the first failure
        proxy.shutdown()
        proxy.close()
    assert children_of(os.getpid()) == []


def test_a_run_keeps_its_directory_locked_while_it_draws_its_plots(tmp_path, monkeypatch):
    """The results writer draws run.png once the file is closed; until it is drawn, another run taking the
    directory over (--overwrite) is refused."""
    from cosim.results_writer import ResultsWriter
    from cosim.rundir import RunDirectory, RunDirectoryError
    refused = []
    wait_closed = ResultsWriter.wait_closed

    def try_to_take_the_directory_first(self):
        with pytest.raises(RunDirectoryError, match="is in use by a run in progress") as error:
            with RunDirectory(tmp_path / "plot", overwrite=True):
                pass
        refused.append(str(error.value))
        wait_closed(self)
        assert (tmp_path / "plot" / "run.png").stat().st_size > 10_000

    monkeypatch.setattr(ResultsWriter, "wait_closed", try_to_take_the_directory_first)
    run(tmp_path / "plot", "time.end=0.3")
    assert len(refused) == 1
    with RunResults(tmp_path / "plot") as results:
        assert len(results.windows) == 3


def test_a_full_disk_stops_the_run_with_every_dataset_at_the_same_window(tmp_path, capsys):
    """A 1 MB file system as --out: the run stops before the window it has no room for, in one line, exit 2."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)], capture_output=True)
    if mounted.returncode != 0:
        pytest.skip("needs a small tmpfs (mount as root)")
    try:
        out = disk / "run"
        code = main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=600",
                     "--set", "components.solid.record=true"])
        err = capsys.readouterr().err.strip()
        assert code == 2 and "\n" not in err and "Traceback" not in err, err
        assert "no room for window" in err and "bytes free" in err
        status = read_status(out)
        assert status["state"] == "failed" and "no room for window" in status["error"]
        with RunResults(out) as results:
            windows = len(results.windows)
            assert windows > 10 and results.attributes["windows_completed"] == windows == status["windows_completed"]
            assert results.fields()["pressure"].shape == (windows, 101)
            calls = results.calls("solid")
            assert calls.window.max() == windows and len(calls) == results.windows.iterations.sum()
        # the disk full from the start: one line, exit 2, and no half-made results file left behind
        with open(disk / "filler", "wb", buffering=0) as filler:       # unbuffered: closing writes nothing more
            try:
                while True:
                    filler.write(b"\0" * 65536)
            except OSError:
                pass
        code = main(["run", str(TUBE_SCENE), "--out", str(disk / "second"), "--quiet", "--set", "time.end=1"])
        err = capsys.readouterr().err.strip()
        assert code == 2 and "\n" not in err and "No space left on device" in err, err
        assert err.startswith(f"cosim run: error: cannot use '{disk / 'second'}' as the run's directory")
        assert not (disk / "second" / "results.h5").exists()
    finally:
        subprocess.run(["umount", str(disk)], check=True)


def test_a_killed_coupler_leaves_a_status_that_says_so_and_the_windows_it_stored(tmp_path):
    out = tmp_path / "killed"
    coupler = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                                "--set", "time.end=600"], cwd=ROOT, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: windows_done(out) >= 5, "five windows")
    finally:
        coupler.kill()
        coupler.wait(timeout=30)
    wait_for(lambda: not alive_with(str(out)), "the killed run's components to exit on their own")
    status = read_status(out)
    assert status["state"] == "died" and status["pid"] == coupler.pid
    # the file itself cannot say so (its writer was killed), as the docs say; cosim status does
    import json
    assert json.loads((out / "status.json").read_text())["state"] == "running"
    from coupler.monitor import status_lines
    assert status_lines(out)[0].startswith(f"{out}: died, ") and "is gone without saying why" in status_lines(out)[0]
    with RunResults(out) as results:
        assert results.attributes["windows_completed"] == len(results.windows) >= 5
    code = subprocess.run([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet"],
                          cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert code.returncode == 2
    assert f"its process (pid {coupler.pid}) died after" in code.stderr


def test_a_refused_directory_says_what_its_run_came_to(tmp_path, capsys):
    out = tmp_path / "failed"
    assert main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=1",
                 "--set", "components.solid.entry=tests.components:NanSolid"]) == 2
    capsys.readouterr()
    assert main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=1"]) == 2
    err = capsys.readouterr().err
    assert (f"'{out}' already holds a run (failed after 2 of 10 windows: component 'solid' in window 3 "
            "(t = 0.2 to 0.3), iteration 1: output 'section' is not finite") in err


def test_ctrl_c_before_the_first_window_leaves_a_readable_run_and_exit_code_130(tmp_path):
    """SIGINT in the first window (the solid hangs in it) and while the coupler imports its modules."""
    import signal
    out = tmp_path / "early"
    coupler = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                                "--set", "components.solid.entry=tests.components:HangingSolid",
                                "--set", "time.start=0.2"], cwd=ROOT,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wait_for(lambda: "HangingSolid" in " ".join(map(cmdline, children_of(coupler.pid))), "the solid to start")
    coupler.send_signal(signal.SIGINT)
    _, err = coupler.communicate(timeout=60)
    assert coupler.returncode == 130 and err.strip() == "cosim run: interrupted; components stopped"
    assert read_status(out)["state"] == "interrupted"
    with RunResults(out) as results:
        assert len(results.windows) == 0 and results.fields() == {} and results.initial() == {}
    # while Python imports the commands (its first extension modules are mapped): still 130, never a signal death
    for library in ("_multiarray_umath", "_zmq", "_flapack"):      # SciPy's LAPACK: loaded while components start
        early = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out",
                                  str(tmp_path / library), "--quiet"], cwd=ROOT,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for(lambda library=library, pid=early.pid: library in mapped(pid), f"the coupler to load {library}",
                 poll=0.001)
        early.send_signal(signal.SIGINT)
        assert early.wait(timeout=60) == 130
    assert children_of(os.getpid()) == []


def test_the_resolved_scene_is_the_same_in_every_process(tmp_path):
    """Its key order must not come from a set: Python's string hashes differ from process to process."""
    code = ("import json, sys; from cosim.scene import load_scene; "
            "print(json.dumps(load_scene(sys.argv[1]).data))")
    texts = {subprocess.run([sys.executable, "-c", code, str(TUBE_SCENE)], cwd=ROOT, capture_output=True, text=True,
                            env={**os.environ, "PYTHONHASHSEED": str(seed)}, check=True).stdout for seed in range(6)}
    assert len(texts) == 1


def mapped(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/maps") as maps:
            return maps.read()
    except OSError:
        return ""


def results_windows_on_disk(path) -> int:
    """Windows in a results file that its writer still holds open (read without HDF5's lock, as a crash would
    leave it); -1 while a write is under way."""
    import h5py

    from cosim.results import Layout
    try:
        with h5py.File(path, "r", locking=False) as results:
            rows = len(results[Layout.window("time")])
            return rows if int(results.attrs["windows_completed"]) == rows else -1
    except (OSError, KeyError):
        return -1


def test_every_finished_window_is_flushed_while_the_run_goes_on_and_kept_when_its_coupler_is_killed(tmp_path):
    """The solid hangs in window 41: the results file on disk holds the forty windows before it while the coupler
    waits, and exactly those after the coupler is killed (its writer reads the pipe to the end and closes)."""
    out = tmp_path / "hung"
    coupler = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                                "--set", "components.solid.entry=tests.components:LateHangingSolid",
                                "--set", "time.end=10"], cwd=ROOT, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: results_windows_on_disk(out / "results.h5") == 40, "forty windows flushed to disk", timeout=15)
        components = [pid for pid in children_of(coupler.pid) if "LateHangingSolid" in cmdline(pid)]
    finally:
        coupler.kill()
        coupler.wait(timeout=30)
    wait_for(lambda: not alive_with(str(out)), "the killed run's writer and components to exit on their own")
    # the solid, stuck in its step, sees its coupler gone from a thread of its own, and exits
    assert components
    wait_for(lambda: all(cmdline(pid) == "" for pid in components), "the hung solid to exit", timeout=10)
    with RunResults(out) as results:
        assert len(results.windows) == results.attributes["windows_completed"] == 40
        assert results.fields()["section"].shape == (40, 101)
        assert results.windows.time[-1] == pytest.approx(4.0)


def test_a_killed_results_writer_stops_the_run_naming_it(tmp_path, capsys):
    """The writer process dies mid-run: the run stops at its next window with one line naming the writer, its exit
    and its log, exit 2, and no process left."""
    import signal
    import threading
    out = tmp_path / "writerless"

    def kill_the_writer() -> None:
        writer = wait_for(lambda: next((pid for pid in children_of(os.getpid())
                                        if "cosim.results_writer" in cmdline(pid)), None), "the results writer")
        wait_for(lambda: windows_done(out) >= 5, "five windows")
        os.kill(writer, signal.SIGKILL)

    killer = threading.Thread(target=kill_the_writer)
    killer.start()
    code = main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=600"])
    killer.join()
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert "the results file's writer (pid" in err and "exited with code -9" in err and "results.log" in err, err
    assert read_status(out)["state"] == "failed"
    assert children_of(os.getpid()) == []


def test_a_run_read_at_once_after_its_coupler_was_killed_waits_for_its_writer(tmp_path):
    """The writer of a killed coupler still holds the directory while it writes the windows it was handed: a reader
    waits for it (seconds at most) instead of failing on a file in use."""
    import threading

    from cosim.rundir import settling
    out = tmp_path / "killed"
    coupler = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                                "--set", "components.solid.entry=tests.components:LateHangingSolid",
                                "--set", "time.end=10"], cwd=ROOT, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    writer = wait_for(lambda: next((pid for pid in children_of(coupler.pid)
                                    if "cosim.results_writer" in cmdline(pid)), None), "the results writer")
    wait_for(lambda: results_windows_on_disk(out / "results.h5") == 40, "forty windows flushed to disk")
    os.kill(writer, signal.SIGSTOP)          # the writer is slow to finish: it holds the directory meanwhile
    coupler.kill()
    coupler.wait(timeout=30)
    resume = threading.Timer(0.5, os.kill, (writer, signal.SIGCONT))
    resume.start()
    try:
        assert settling(out)
        with RunResults(out) as results:      # waits for the writer to finish
            assert len(results.windows) == 40
    finally:
        resume.join()
    wait_for(lambda: not settling(out), "the writer to let the directory go")


def test_a_new_run_waits_for_a_dead_runs_writer_and_not_for_a_live_run(tmp_path):
    """The directory's lock held under a dead process's pid (a dead coupler's writer finishing) is waited for; held
    by a live one, refused at once."""
    from cosim.rundir import RunDirectory, RunDirectoryError
    holder = ("import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT); "
              "fcntl.flock(fd, fcntl.LOCK_EX); os.pwrite(fd, sys.argv[2].encode(), 0); print('held', flush=True); "
              "time.sleep(float(sys.argv[3]))")
    out = tmp_path / "run"
    out.mkdir()
    for pid, seconds in ((2**22 + 12345, 1.0), (os.getpid(), 30.0)):     # a pid above pid_max: never alive
        process = subprocess.Popen([sys.executable, "-c", holder, str(out / ".lock"), str(pid), str(seconds)],
                                   stdout=subprocess.PIPE, text=True)
        assert process.stdout is not None and process.stdout.readline().strip() == "held"
        try:
            if pid == os.getpid():
                with pytest.raises(RunDirectoryError, match="in use by a run in progress"):
                    with RunDirectory(out):
                        pass
            else:
                with RunDirectory(out):
                    assert process.poll() is not None     # taken once the holder let go
        finally:
            process.kill()
            process.wait()
