"""What a run tells as it goes: the coupler's logs (coupler.log, and the iterations and convergence tables in the
manner of preCICE's), the component's log named by its error, ``cosim status`` and ``cosim plot --convergence``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from cosim.cli import main
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.monitor import convergence_figure, plot_convergence, status_lines
from coupler.run import run_scene
from coupler.run_log import read_table
from tests.conftest import ROOT, TUBE_SCENE, wait_for, windows_done


def test_the_logs_hold_every_window_and_iteration_as_results_h5_does(tmp_path):
    run_scene(load_scene(TUBE_SCENE, ["time.end=2.0"]), tmp_path / "run", progress=False)
    logs = tmp_path / "run" / "logs"
    columns, windows = read_table(logs / "iterations.log")
    assert columns == ["TimeWindow", "Time", "Iterations", "TotalIterations", "Converged", "relative(pressure)",
                       "relative(section)"]
    header, iterations = read_table(logs / "convergence.log")
    assert header == ["TimeWindow", "Iteration", "relative(pressure)", "relative(section)", "ResidualNorm"]
    with RunResults(tmp_path / "run") as run:
        counts = run.windows.iterations
        import h5py
        with h5py.File(tmp_path / "run" / "results.h5", "r") as f:
            residuals = f["residuals/norm"][()]
    table, rows = np.array(windows), np.array(iterations)
    assert table[:, 0].tolist() == list(range(1, 21)) and table[:, 2].tolist() == counts.tolist()
    assert table[:, 3].tolist() == np.cumsum(counts).tolist() and table[:, 4].all()
    assert len(rows) == counts.sum()
    np.testing.assert_allclose(rows[:, -1], residuals, rtol=1e-6)        # the log prints 7 digits
    last = rows[np.r_[np.flatnonzero(np.diff(rows[:, 0])), len(rows) - 1]]   # each window's last iteration
    np.testing.assert_array_equal(last[:, 2:4], table[:, 5:7])
    assert (last[:, 3] < 1e-4).all() and (rows[:, 1] >= 1).all()
    events = (logs / "coupler.log").read_text().splitlines()
    assert "started: scene" in events[0] and "20 windows of 0.1 s" in events[0]
    assert any("component 'solid': solid_component.tube:TubeSolid, pid" in line for line in events)
    assert events[-1].endswith(f"finished: 20 windows, {counts.sum()} coupling iterations "
                               f"(mean {counts.mean():.3f} per window)")


def test_a_resumed_run_s_tables_hold_each_window_once(tmp_path):
    from tests.test_restart import stopped_at
    overrides = ["time.end=1.0", "output.checkpoint_every=2"]
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(5, patch)
        run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "run", progress=False)
    logs = tmp_path / "run" / "logs"
    with open(logs / "iterations.log", "a") as stream:        # a window after the checkpoint, lost at the stop
        stream.write("6 0.6 3 30 1 1e-5 1e-5\n")
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "run", progress=False, resume=True)
    _, windows = read_table(logs / "iterations.log")
    assert [int(row[0]) for row in windows] == list(range(1, 11))
    _, iterations = read_table(logs / "convergence.log")
    with RunResults(tmp_path / "run") as run:
        assert len(iterations) == run.windows.iterations.sum()
    assert "resumed after window 5" in (logs / "coupler.log").read_text()


def test_a_component_s_error_names_its_log_which_holds_the_traceback(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", "--set", "time.end=1",
                 "--set", "components.solid.entry=tests.components:RaisingSolid"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err, err
    assert f"'step' failed: ZeroDivisionError: a bug in the solid (its log: {out / 'logs' / 'solid.log'})" in err
    log = (out / "logs" / "solid.log").read_text()
    assert "Traceback" in log and "ZeroDivisionError: a bug in the solid" in log
    assert "failed after 3 windows: " in (out / "logs" / "coupler.log").read_text()


def test_status_and_the_convergence_plot_of_a_running_and_a_finished_run(tmp_path, capsys):
    out = tmp_path / "run"
    process = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(out), "--quiet",
                                "--set", "time.end=60"], cwd=ROOT, stderr=subprocess.PIPE)
    try:
        wait_for(lambda: windows_done(out) >= 20 or process.poll() is not None, "20 windows")
        lines = status_lines(out)
        assert lines[0].startswith(f"{out}: running, ") and "of 600 windows" in lines[0], lines
        assert lines[1].startswith("rate ") and "s left (done near" in lines[1], lines
        assert lines[3].startswith("last measures: relative(pressure) "), lines
        picture = plot_convergence(out)          # while the run writes its logs
        assert picture.stat().st_size > 10_000
    finally:
        process.wait(timeout=120)
    assert process.returncode == 0
    assert main(["status", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == f"{out}: finished, 600 of 600 windows (100 %), t = 60"
    with RunResults(out) as run:
        assert printed[2] == (f"coupling iterations: {run.windows.iterations.sum()}, mean "
                              f"{run.windows.iterations.mean():.3f} per window")
    assert main(["plot", str(out), "--convergence", "--out", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").stat().st_size > 10_000
    assert main(["status", str(tmp_path / "none")]) == 2


def test_a_log_that_cannot_be_written_stops_being_written_never_the_run(tmp_path):
    import errno

    from coupler.run_log import RunLog

    class FullDisk:
        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

        def flush(self):
            pass

        def close(self):
            raise OSError(errno.ENOSPC, "No space left on device")

    with RunLog(tmp_path / "logs") as log:
        log.events = FullDisk()
        log.event("a line the disk has no room for")
        assert log.broken
        log.event("and no more tries")


def test_the_convergence_plot_reads_damaged_or_unfinished_logs_and_never_writes_over_the_run(tmp_path, capsys):
    """A log cut mid-line (as a run writes it), garbage or invalid UTF-8 lines are passed over, an empty log is no
    iteration yet, and --out cannot name results.h5, run.png or a file that is no PNG: one line each, exit 2."""
    logs = tmp_path / "run" / "logs"
    logs.mkdir(parents=True)
    header = "TimeWindow Iteration relative(section) ResidualNorm\n"
    rows = "1 1 1.0e+00 2.0e-01\n1 2 1.0e-05 3.0e-06\n2 1 9.0e-01 1.0e-01\n"
    (logs / "convergence.log").write_bytes((header + rows + "2 2 4.0e-0").encode() + b"\nxyz \xff\xfe 1\n")
    (logs / "iterations.log").write_text("TimeWindow Time Iterations TotalIterations Converged relative(section)\n"
                                         "1 0.1 2 2 1 1.0e-05\n2 0.2")
    picture = plot_convergence(tmp_path / "run")
    assert picture.stat().st_size > 5_000
    from coupler.run_log import read_table
    assert read_table(logs / "convergence.log")[1] == [[1, 1, 1.0, 0.2], [1, 2, 1e-5, 3e-6], [2, 1, 0.9, 0.1]]
    (tmp_path / "link.png").symlink_to(tmp_path / "run" / "run.png")     # a link into the run: refused the same
    for target, message in ((tmp_path / "run" / "results.h5", "not over a .h5"),
                            (tmp_path / "run" / "run.png", "not over a file of the run"),
                            (tmp_path / "link.png", "not over a file of the run")):
        assert main(["plot", str(tmp_path / "run"), "--convergence", "--out", str(target)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and message in err, err
    (logs / "convergence.log").write_text("")
    assert main(["plot", str(tmp_path / "run"), "--convergence"]) == 2
    assert "holds no iteration yet" in capsys.readouterr().err


def test_the_convergence_plot_draws_each_measure_against_its_limit_and_breaks_between_windows(tmp_path):
    """Measures on a log axis with their limits dashed in their colour, the residual on an axis of its own, no line
    joining a window's last iteration to the next one's first, and every axis labelled."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import same_color

    run_scene(load_scene(TUBE_SCENE, ["time.end=0.5", "coupling.convergence=[{data=\"pressure\", type=\"relative\", "
                                      "limit=1e-4}, {data=\"section\", type=\"absolute\", limit=2e-7}, "
                                      "{data=\"section\", type=\"min-iterations\", iterations=2}, "
                                      "{data=\"pressure\", type=\"any-of\", measures=[{type=\"relative\", "
                                      "limit=1e-3}, {type=\"absolute\", limit=1e-6}]}]"]),
              tmp_path / "run", progress=False)
    assert json.loads((tmp_path / "run" / "logs" / "measures.json").read_text()) == {
        "relative(pressure)": 1e-4, "absolute(section)": 2e-7, "min-iterations(section)": None,
        "any-of(pressure)": None}
    figure = convergence_figure(tmp_path / "run")
    measures, residual, iterations = figure.axes
    assert [a.get_yscale() for a in figure.axes] == ["log", "log", "linear"]
    assert all(a.get_xlabel() and a.get_ylabel() for a in figure.axes)
    drawn = {line.get_label(): line for line in measures.get_lines()}
    assert set(drawn) == {"relative(pressure)", "absolute(section)", "any-of(pressure)",   # no limit line for any-of
                          "relative(pressure) limit 0.0001", "absolute(section) limit 2e-07"}
    for name, limit in (("relative(pressure)", 1e-4), ("absolute(section)", 2e-7)):
        dashed = drawn[f"{name} limit {limit:g}"]
        assert dashed.get_linestyle() == "--" and list(dashed.get_ydata()) == [limit, limit]
        assert same_color(dashed.get_color(), drawn[name].get_color())
    with RunResults(tmp_path / "run") as run:
        windows, total = len(run.windows), int(run.windows.iterations.sum())
    for line in (drawn["relative(pressure)"], residual.get_lines()[0]):
        x = np.asarray(line.get_xdata(), dtype=float)
        assert np.isnan(x).sum() == windows - 1 and len(x) == total + windows - 1     # one gap between windows
    plt.close(figure)


def test_one_definition_of_each_time_and_rate_in_the_summary_the_status_and_the_results(tmp_path, capsys):
    """Elapsed (start-up included) and coupling (first window's start to last window's end) times, and the rate as
    the windows over the coupling time, agree between ``cosim run``'s summary, ``cosim status`` and results.h5."""
    import re

    from cosim.rundir import read_status
    assert main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "run"), "--quiet", "--set", "time.end=2"]) == 0
    summary = capsys.readouterr().out.strip().splitlines()[-1]
    coupling, rate, elapsed = map(float, re.search(
        r"; coupling ([\d.]+) s \(([\d.]+) windows/s\), elapsed ([\d.]+) s;", summary).groups())
    status = read_status(tmp_path / "run")
    with RunResults(tmp_path / "run") as run:
        attributes = run.attributes
    assert attributes["coupling_seconds"] == status["coupling_seconds"] < attributes["wall_seconds"]
    assert attributes["wall_seconds"] == status["wall_seconds"]
    assert (coupling, elapsed) == (round(status["coupling_seconds"], 2), round(status["wall_seconds"], 2))
    assert rate == float(f"{20 / status['coupling_seconds']:.3g}")                # printed to 3 digits
    assert attributes["coupling_seconds"] == pytest.approx(attributes["last_window_ended"]
                                                           - attributes["first_window_started"], abs=0.05)
    assert main(["status", str(tmp_path / "run")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == f"rate {20 / status['coupling_seconds']:.3g} windows/s over the coupling's {coupling:.2f} s"
    assert lines[-1] == f"elapsed {elapsed:.2f} s (start-up and close included)"
