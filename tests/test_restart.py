"""Checkpoints and ``cosim run --resume``: a resumed run is the uninterrupted one, bit for bit."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import zipfile
from collections import deque
from pathlib import Path

import numpy as np
import pytest

from cosim import stop
from cosim.checkpoint import CheckpointError, object_state, pack, read, restore_object, unpack
from cosim.cli import main
from cosim.results import RunResults
from cosim.results_writer import ResultsWriter
from cosim.scene import load_scene
from coupler.run import run_scene
from tests.conftest import ROOT, TUBE_SCENE, wait_for, windows_done
from tests.test_rom_integration import END, TRAIN_END, fom, model  # noqa: F401  (the module's fixtures)

LONG = ["time.end=30.0", "output.checkpoint_every=10"]     # 300 windows, about 2 s


def identical(a: Path, b: Path) -> None:
    """Two runs' results files hold the same datasets with the same bits (windows, fields, residuals, recorded
    calls, what components handed back), timings apart."""
    import h5py

    def datasets(path: Path) -> dict[str, bytes]:
        found: dict[str, bytes] = {}
        with h5py.File(path / "results.h5", "r") as f:
            f.visititems(lambda name, item: found.__setitem__(name, item[()].tobytes())
                         if isinstance(item, h5py.Dataset) and "seconds" not in name else None)
        return found

    x, y = datasets(a), datasets(b)
    assert sorted(x) == sorted(y)
    assert [name for name in x if x[name] != y[name]] == []
    with RunResults(a / "results.h5") as run:
        assert len(run.windows.iterations) > 0


def test_state_trees_round_trip_through_json_and_arrays():
    tree = {"x": np.arange(5.0), "n": 3, "f": 0.1 + 0.2, "nan": float("nan"), "s": "text", "none": None,
            "t": (np.ones(2), 2), "d": deque([np.zeros(1)], maxlen=3), "set": {0.5, 0.25}, "flag": np.bool_(True),
            "nested": {"__odd__": [np.int64(7), np.float64(1e-300)]}, "i": np.arange(3, dtype=np.int32)}
    document, arrays = pack(tree)
    import json
    back = unpack(json.loads(json.dumps(document)), arrays)
    assert back["x"].tobytes() == tree["x"].tobytes() and back["i"].dtype == np.int32
    assert back["f"] == tree["f"] and np.isnan(back["nan"]) and back["s"] == "text" and back["none"] is None
    assert isinstance(back["t"], tuple) and back["t"][1] == 2 and isinstance(back["d"], deque) and back["d"].maxlen == 3
    assert back["set"] == {0.5, 0.25} and back["flag"] is True and back["nested"] == {"__odd__": [7, 1e-300]}
    with pytest.raises(CheckpointError, match="state 'state.bad' is of type object, which a checkpoint cannot hold"):
        pack({"bad": object()})
    with pytest.raises(CheckpointError, match="array of Python objects"):
        pack({"o": np.array([None], dtype=object)})

    class Inner:
        def __init__(self):
            self.values = [np.ones(2)]

    class Outer:
        def __init__(self):
            self.inner, self.members, self.k = Inner(), [Inner(), Inner()], 1

    source, target = Outer(), Outer()
    source.inner.values, source.members[1].values, source.k = [np.full(2, 3.0)], [np.zeros(3)], 5
    restore_object(target, unpack(*pack(object_state(source))))
    assert target.k == 5 and target.inner.values[0][0] == 3.0 and target.members[1].values[0].shape == (3,)


def test_a_run_killed_in_a_window_resumes_from_its_checkpoint_bit_for_bit(tmp_path):
    """SIGKILL of the coupler in the middle of a window, then ``cosim run --resume``."""
    run_scene(load_scene(TUBE_SCENE, LONG), tmp_path / "whole", progress=False)
    command = [sys.executable, "-m", "cosim", "run", str(TUBE_SCENE), "--out", str(tmp_path / "cut"), "--quiet",
               *[arg for item in LONG for arg in ("--set", item)]]
    process = subprocess.Popen(command, cwd=ROOT)
    try:
        wait_for(lambda: windows_done(tmp_path / "cut") >= 45 or process.poll() is not None, "45 windows")
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == -signal.SIGKILL
    with RunResults(tmp_path / "cut" / "results.h5") as cut:
        assert 40 <= len(cut.windows.iterations) < 300     # killed midway, after a checkpoint
    done = subprocess.run([*command, "--resume"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    identical(tmp_path / "whole", tmp_path / "cut")
    with RunResults(tmp_path / "cut" / "results.h5") as resumed:
        assert resumed.attributes["checkpoints_written"] >= 1 and resumed.attributes["checkpoint_bytes"] > 0


def stopped_at(window: int, monkeypatch) -> None:
    """Ask the run to stop (as Ctrl-C does) once it has written ``window`` windows."""
    append = ResultsWriter.append_window

    def append_then_stop(self, *args, **kwargs):
        append(self, *args, **kwargs)
        if self.windows == window:
            stop._requested = signal.SIGINT
    monkeypatch.setattr(ResultsWriter, "append_window", append_then_stop)


@pytest.mark.parametrize("backend, stop_window", [("rom", 58), ("rom", 66), ("fmu", 66)])
def test_a_rom_fom_run_stopped_before_or_after_its_switch_resumes_bit_for_bit(model, tmp_path, monkeypatch,  # noqa: F811
                                                                             backend, stop_window):
    """Ctrl-C writes a checkpoint after the window in flight; the ROM (or its FMU) serves from 6 s on."""
    served = {"rom": f"components.solid.rom.model={model}"}
    if backend == "fmu":
        fmu = tmp_path / "solid_rom.fmu"
        assert main(["export-fmu", str(model), "--out", str(fmu)]) == 0
        served = {"fmu": f"components.solid.fmu.path={fmu}"}
    overrides = [f"time.end={END}", f"components.solid.backend={backend}", served[backend],
                 f"components.solid.{backend}.switch_time={TRAIN_END}", "output.checkpoint_every=7"]
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(stop_window, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False)
    with RunResults(tmp_path / "cut" / "results.h5") as cut:
        assert len(cut.windows.iterations) == stop_window
    assert read(tmp_path / "cut" / "checkpoint.npz")[0]["windows"] == stop_window    # the stop's own checkpoint
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False, resume=True)
    identical(tmp_path / "whole", tmp_path / "cut")


def test_resume_refuses_another_scene_and_a_run_without_a_checkpoint(tmp_path, capsys):
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(4, patch)
        run_scene(load_scene(TUBE_SCENE, ["time.end=1.0", "output.checkpoint_every=2"]), tmp_path / "cut",
                  progress=False)
    shutil.copytree(tmp_path / "cut", tmp_path / "plain")
    (tmp_path / "plain" / "checkpoint.npz").unlink()
    assert main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "plain"), "--quiet", "--set", "time.end=1.0",
                 "--set", "output.checkpoint_every=2", "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no checkpoint" in err and "output.checkpoint_every" in err, err
    assert main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "cut"), "--quiet", "--set", "time.end=1.0",
                 "--set", "output.checkpoint_every=2", "--set", "inlet.h=5", "--resume"]) == 2
    assert "was run with another scene" in capsys.readouterr().err
    assert main(["run", str(TUBE_SCENE), "--out", str(tmp_path / "none"), "--quiet", "--resume"]) == 2
    assert "holds no run to resume" in capsys.readouterr().err


def test_a_sweep_s_run_stopped_midway_goes_on_from_its_checkpoint(tmp_path, monkeypatch):
    from workflow.sweep import run_one
    overrides = ["time.end=3.0", "output.checkpoint_every=4"]
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "whole", progress=False)
    with pytest.raises(KeyboardInterrupt), monkeypatch.context() as patch:
        stopped_at(10, patch)
        run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False)
    with RunResults(tmp_path / "cut") as cut:
        first_walls = cut.windows.wall_seconds[:10].copy()
    row = run_one(str(TUBE_SCENE), overrides, str(tmp_path / "cut"))
    assert row["failure"] == "" and row["windows_converged"] == 30
    identical(tmp_path / "whole", tmp_path / "cut")
    with RunResults(tmp_path / "cut") as resumed:      # the first 10 windows were kept, not run again
        assert resumed.windows.wall_seconds[:10].tobytes() == first_walls.tobytes()


def test_checkpoints_asked_of_a_component_that_cannot_give_one_are_refused_before_the_first_window(tmp_path, capsys):
    scene = ROOT / "examples" / "spring_wall" / "scene.toml"
    assert main(["run", str(scene), "--out", str(tmp_path / "run"), "--quiet", "--set", "output.checkpoint_every=5"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'output.checkpoint_every' is 5, but component 'solid'" in err, err
    assert "cannot checkpoint its state" in err


def test_a_run_without_periodic_checkpoints_still_checkpoints_when_stopped(tmp_path, monkeypatch):
    overrides = ["time.end=3.0"]
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "whole", progress=False)
    with pytest.raises(KeyboardInterrupt), monkeypatch.context() as patch:
        stopped_at(12, patch)
        run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False)
    assert read(tmp_path / "cut" / "checkpoint.npz")[0]["windows"] == 12
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False, resume=True)
    identical(tmp_path / "whole", tmp_path / "cut")


@pytest.mark.parametrize("stop_window", [9, 23, 26])
def test_a_run_with_the_online_surrogate_resumes_bit_for_bit(tmp_path, monkeypatch, stop_window):
    """Stopped before the surrogate starts, with a training pending (started at window 22, in use at 24), and
    after it: the resumed run refits the model in use from the checkpointed calls and starts the pending training
    again, so it is the uninterrupted run, bit for bit."""
    overrides = ["time.end=4", "tube.cells=40", "coupling.surrogate.start_window=12", "coupling.surrogate.retrain_every=6",
                 "coupling.surrogate.training_windows=8", "output.checkpoint_every=5"]
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(stop_window, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False)
    run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False, resume=True)
    identical(tmp_path / "whole", tmp_path / "cut")
    with RunResults(tmp_path / "whole" / "results.h5") as run:
        assert run.attributes["surrogate_trainings"] >= 4 and run.attributes["surrogate_updates"] > 0


# --- what a resume refuses, before it touches anything --------------------------------------------------------

SHORT = ["time.end=1.0", "output.checkpoint_every=2"]      # 10 windows, a checkpoint every 2


def run_files(out: Path) -> dict[str, bytes]:
    """The bytes of every file of a run directory (its lock aside)."""
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.is_file() and p.name != ".lock"}


@pytest.fixture
def stopped(tmp_path) -> Path:
    """A tube run stopped after window 5 (as Ctrl-C stops it), its last checkpoint after window 4... and 5."""
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(5, patch)
        run_scene(load_scene(TUBE_SCENE, SHORT), tmp_path / "cut", progress=False)
    return tmp_path / "cut"


def resume(out: Path, overrides: list[str] = SHORT, *extra: str) -> list[str]:
    return ["run", str(TUBE_SCENE), "--out", str(out), "--quiet", *[a for item in overrides for a in ("--set", item)],
            "--resume", *extra]


def refused(capsys, argv: list[str], out: Path, message: str) -> str:
    """``argv`` exits 2 with one line that says ``message``, and every file of ``out`` is as it was."""
    before = run_files(out)
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert message in err, err
    assert run_files(out) == before
    return err


def test_resume_of_a_finished_run_says_so_and_touches_nothing(tmp_path, capsys):
    run_scene(load_scene(TUBE_SCENE, SHORT), tmp_path / "done", progress=False)
    refused(capsys, resume(tmp_path / "done"), tmp_path / "done", "holds a run that finished (finished, 10 windows)")
    refused(capsys, resume(tmp_path / "done", SHORT, "--overwrite"), tmp_path / "done", "give one")


def rewrite_document(out: Path, change) -> None:
    """The checkpoint of ``out`` with its document changed by ``change(document)`` (its arrays as they were)."""
    from cosim.checkpoint import read, write
    document, arrays = read(out / "checkpoint.npz")
    change(document)
    write(out / "checkpoint.npz", {k: v for k, v in document.items() if k != "format"}, arrays)


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("results"), "'results' is null"),
    (lambda d: d.pop("windows"), "'windows' is null; expected an integer from 1 to 9"),
    (lambda d: d.pop("components"), "'components' is null"),
    (lambda d: d.update(scheme=None), "'scheme' is null"),
    (lambda d: d.update(scheme={}), "'scheme' is {}"),
    (lambda d: d.update(windows="4"), "'windows' is \"4\""),
    (lambda d: d.update(windows=-5), "'windows' is -5; expected an integer from 1 to 9"),
    (lambda d: d.update(windows=10**6), "'windows' is 1000000"),
    (lambda d: d["results"].update({next(iter(d["results"])): -3}), "'results' is"),
    (lambda d: d.update(run={"scene_sha256": "0" * 64, **{k: v for k, v in d["run"].items() if k != "scene_sha256"}}),
     "was run with another scene"),
])
def test_a_damaged_checkpoint_document_is_refused_by_its_key(stopped, capsys, change, message):
    rewrite_document(stopped, change)
    refused(capsys, resume(stopped), stopped, message)


def test_a_damaged_component_state_in_a_checkpoint_is_refused_by_its_digest(stopped, capsys):
    """One byte of a component's state changed (a solver's restart blob damaged on disk): refused naming the
    component, before any solver reads it."""
    from cosim.checkpoint import read, write
    document, arrays = read(stopped / "checkpoint.npz")
    name = next(key for key in arrays if key.startswith("component:solid/") and arrays[key].size)
    damaged = np.array(arrays[name], copy=True)
    damaged.reshape(-1).view(np.uint8)[0] ^= 1
    write(stopped / "checkpoint.npz", {k: v for k, v in document.items() if k != "format"}, {**arrays, name: damaged})
    refused(capsys, resume(stopped), stopped, "the state of component 'solid' is damaged (its digest differs")


def test_arrays_a_checkpoint_does_not_name_are_refused_unread(stopped, capsys):
    import io
    original = (stopped / "checkpoint.npz").read_bytes()
    with zipfile.ZipFile(stopped / "checkpoint.npz", "a", compression=zipfile.ZIP_DEFLATED) as archive:
        with archive.open("scheme/extra.npy", "w", force_zip64=True) as member:   # 256 MB of zeros, deflated
            np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False,
                                                          "shape": (1 << 25,)})
            block = bytes(1 << 20)
            for _ in range(256):
                member.write(block)
    assert (stopped / "checkpoint.npz").stat().st_size < 8 << 20
    refused(capsys, resume(stopped), stopped, "member 'scheme/extra.npy' is not an uncompressed .npy array")
    (stopped / "checkpoint.npz").write_bytes(original)
    with zipfile.ZipFile(stopped / "checkpoint.npz", "a") as archive:
        array = io.BytesIO()
        np.save(array, np.zeros(3))
        archive.writestr("component:other/x.npy", array.getvalue())
    refused(capsys, resume(stopped), stopped, "holds an array 'component:other/x' that belongs to no part of this run")


@pytest.mark.parametrize("other", ["inlet.h=4", "tube.cells=50"])
def test_a_checkpoint_of_another_run_is_refused_before_results_are_cut(tmp_path, capsys, other):
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(7, patch)
        run_scene(load_scene(TUBE_SCENE, SHORT), tmp_path / "mine", progress=False)
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(3, patch)
        run_scene(load_scene(TUBE_SCENE, [*SHORT, other]), tmp_path / "theirs", progress=False)
    shutil.copy(tmp_path / "theirs" / "checkpoint.npz", tmp_path / "mine" / "checkpoint.npz")
    refused(capsys, resume(tmp_path / "mine"), tmp_path / "mine", "was run with another scene")


def test_an_input_file_changed_since_the_stop_is_refused(tmp_path, capsys):
    table = tmp_path / "inlet.csv"
    shutil.copy(ROOT / "scenes" / "inlet" / "tube-inlet-mu1.csv", table)
    overrides = [*SHORT, f"inlet.table={table}"]
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(5, patch)
        run_scene(load_scene(TUBE_SCENE, overrides), tmp_path / "cut", progress=False)
    lines = table.read_text().splitlines()
    table.write_text("\n".join([*lines[:3], lines[3].replace(",", ",1", 1), *lines[4:]]) + "\n")
    refused(capsys, resume(tmp_path / "cut", overrides), tmp_path / "cut",
            f"'inlet.table' ({table}) is not the file the run started with")


def test_the_order_of_set_items_and_20_against_20_0_do_not_make_another_scene(tmp_path):
    given = ["time.end=1", "output.checkpoint_every=2", "inlet.h=6"]
    with pytest.raises(KeyboardInterrupt), pytest.MonkeyPatch.context() as patch:
        stopped_at(5, patch)
        run_scene(load_scene(TUBE_SCENE, given), tmp_path / "cut", progress=False)
    assert main(resume(tmp_path / "cut", ["inlet.h=6.0", "output.checkpoint_every=2", "time.end=1.0"])) == 0
    run_scene(load_scene(TUBE_SCENE, given), tmp_path / "whole", progress=False)
    identical(tmp_path / "whole", tmp_path / "cut")


def test_a_failed_checkpoint_write_fails_the_run_in_one_line_and_leaves_no_partial_file(tmp_path, capsys, monkeypatch):
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(np, "savez", full)
    out = tmp_path / "run"
    assert main(["run", str(TUBE_SCENE), "--out", str(out), "--quiet", *[a for i in SHORT for a in ("--set", i)]]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert f"cannot write the checkpoint '{out / 'checkpoint.npz'}': No space left on device; the 2 windows" in err
    assert json.loads((out / "status.json").read_text())["state"] == "failed"
    assert not list(out.glob("*.partial"))
    with RunResults(out) as run:
        assert len(run.windows.iterations) == 2
