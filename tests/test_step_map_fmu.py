"""The step-map ROM's three arithmetics and its FMU, on a model fitted to the Newmark chain of test_step_map: the
component's NumPy path in the C code's order, the C code in-process and the exported FMU give the same bits,
through repeated windows and a take-over; fmpy, an independent importer, validates the FMU, repeats windows with
fmi2GetFMUstate / fmi2SetFMUstate and goes on from a serialised state."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from benchmarks.newmark_chain import newmark_calls
from rom_component.dynamic.model import StepMapRom

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")
N = 12


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A step-map model file and its FMU (probe 'tip': the chain's last mass, x and y as its two values)."""
    from rom_component import model_file
    from rom_component.dynamic.train import model_contents
    from rom_component.fmu.export import export_fmu
    data = newmark_calls()
    # a two-valued field per node so that a probe is a node: the chain's displacement and zero
    data.U = np.stack([data.U, np.zeros_like(data.U)], axis=2).reshape(len(data.U), -1)
    fitted = StepMapRom(force_modes=8, disp_modes=6, history=3, ridge=1e-10).fit(data, 120)
    arrays, metadata = model_contents(fitted, data, 120, np.arange(2 * N), {"tip": np.array([2 * N - 2, 2 * N - 1])},
                                  0.1, "force", "displacement")
    metadata["variables"] = [{"name": "force", "mesh": "", "components": 1},
                             {"name": "displacement", "mesh": "", "components": 2}]
    folder = tmp_path_factory.mktemp("step-map")
    model_file.save(folder / "model.npz", arrays, metadata)
    export_fmu(folder / "model.npz", folder / "model.fmu")
    return folder / "model.npz", folder / "model.fmu", data


def calls(data, windows: int = 30, per_window: int = 3) -> list[tuple[float, np.ndarray]]:
    """(window start, force) of several calls per window, forces off the training data's."""
    rng = np.random.default_rng(5)
    return [(0.1 * w, data.F[w] * 1.01 + 0.02 * rng.standard_normal(N)) for w in range(windows)
            for _ in range(per_window)]


def test_numpy_compiled_and_fmu_give_the_same_bits(model):
    from fmu_component.component import FmuComponent
    from rom_component.dynamic.component import StepMapRomSolid
    path, fmu_path, data = model
    components = []
    for arithmetic in ("reproducible", "compiled"):
        component = StepMapRomSolid()
        component.instantiate({"model": str(path), "arithmetic": arithmetic})
        components.append(component)
    fmu = FmuComponent()
    fmu.instantiate({"path": str(fmu_path)})
    fmu.enter_initialization_mode(0.0, 3.0)
    fmu.exit_initialization_mode()
    components.append(fmu)
    assert fmu.repeats_steps and fmu.history_windows == 3
    assert [v.name for v in fmu.variables() if v.causality == "local"] == ["tip"]
    history = {"force": data.F[40:43], "displacement": data.U[40:43].reshape(3, N, 2)}
    for component in components:
        component.take_over(history, history)
    for t, f in calls(data):
        answers = [component.step(t, 0.1, {"force": f}) for component in components]
        for answer in answers[1:]:
            assert answer["displacement"].tobytes() == answers[0]["displacement"].tobytes()
            assert answer["tip"].tobytes() == answers[0]["tip"].tobytes()
    fast = StepMapRomSolid()
    fast.instantiate({"model": str(path), "arithmetic": "fast"})
    fast.take_over(history, history)
    for t, f in calls(data):
        last = fast.step(t, 0.1, {"force": f})
    np.testing.assert_allclose(last["displacement"], answers[0]["displacement"], rtol=0,
                               atol=1e-12 * np.abs(answers[0]["displacement"]).max())
    for component in components:
        component.terminate()


def test_fmpy_repeats_windows_by_the_fmu_state_and_resumes_from_its_serialisation(model):
    """fmpy drives the FMU as FMI 2.0 says: fmi2GetFMUstate at a window's start, fmi2SetFMUstate before each
    repeat; its answers are the component's. Serialised after window 10 and read into a new instance, the FMU goes
    on with the same bits."""
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.validation import validate_fmu

    from rom_component.dynamic.component import StepMapRomSolid
    from tests.conftest import fmpy_slave
    path, fmu_path, data = model
    assert validate_fmu(str(fmu_path)) == []
    md = read_model_description(str(fmu_path))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    inputs = [refs[f"force[{i + 1}]"] for i in range(N)]
    outputs = [refs[f"displacement[{i + 1}].{axis}"] for i in range(N) for axis in "xy"]

    def start() -> FMU2Slave:
        return fmpy_slave(fmu_path, "step_map")[0]

    component = StepMapRomSolid()
    component.instantiate({"model": str(path)})
    slave, serialised = start(), None
    window_start, t_open = None, None
    for t, f in calls(data):
        if t != t_open:
            if t_open is not None and abs(t_open - 1.0) < 1e-9:      # after window 10: move to a new instance
                state = slave.getFMUState()
                serialised = slave.serializeFMUstate(state)
                slave.freeFMUState(state)
                slave.terminate()
                slave.freeInstance()                    # with it every state it handed out
                window_start = None
                slave = start()
                restored = slave.deSerializeFMUstate(serialised)
                slave.setFMUState(restored)
                slave.freeFMUState(restored)
            if window_start is not None:
                slave.freeFMUState(window_start)
            window_start, t_open = slave.getFMUState(), t
        else:
            slave.setFMUState(window_start)
        slave.setReal(inputs, list(f))
        slave.doStep(currentCommunicationPoint=t, communicationStepSize=0.1)
        theirs = np.array(slave.getReal(outputs))
        ours = component.step(t, 0.1, {"force": f})["displacement"].ravel()
        assert theirs.tobytes() == ours.tobytes(), t
    assert serialised is not None
    slave.freeFMUState(window_start)
    slave.terminate()
    slave.freeInstance()
    component.terminate()


def test_a_static_model_is_refused_by_the_step_map_component(tmp_path):
    from cosim.errors import ComponentError
    from rom_component import model_file
    from rom_component.dynamic.component import StepMapRomSolid
    from tests.roms import solid_rom
    rng = np.random.default_rng(0)
    F, U = rng.standard_normal((30, 5)), rng.standard_normal((30, 4))
    rom = solid_rom(3, 3, "rbf", "linear").fit(F, U)
    model_file.save(tmp_path / "static.npz", rom.online_arrays(), {"regressor": "rbf"})
    with pytest.raises(ComponentError, match="not a step map"):
        StepMapRomSolid().instantiate({"model": str(tmp_path / "static.npz")})


def test_a_call_beyond_the_training_range_warns_or_fails(model):
    """Trust as for the static ROM: the window's reduced force against the training envelope, in every arithmetic;
    a warning the coupler folds into one line per window, or an error that says how far."""
    from cosim.errors import ComponentError
    from rom_component.dynamic.component import StepMapRomSolid
    path, _, data = model
    far = data.F[50] * 40.0
    for arithmetic in ("reproducible", "compiled"):
        warned = StepMapRomSolid()
        warned.instantiate({"model": str(path), "arithmetic": arithmetic})
        inside = warned.served_step(0.0, 0.1, {"force": data.F[0]})
        assert inside["rom_out_of_range"][0] == 0.0 and warned.take_warnings() == []
        out = dict(warned.served_step(0.1, 0.1, {"force": far}))
        assert out["rom_out_of_range"][0] == 1.0 and out["rom_excess"][0] > 1.0
        assert warned.take_warnings() == ["input outside the training range (a reduced force mode beyond the training "
                                          "data by more than 0.05 of its range)"]
        failing = StepMapRomSolid()
        failing.instantiate({"model": str(path), "arithmetic": arithmetic, "on_out_of_range": "fail"})
        with pytest.raises(ComponentError, match=r"at t = 0.1 s: [0-9.e+]+ of its range"):
            failing.served_step(0.0, 0.1, {"force": data.F[0]})
            failing.served_step(0.1, 0.1, {"force": far})


def test_a_serialised_state_is_refused_by_another_model_and_when_damaged_and_an_error_is_left_by_set_state(
        model, tmp_path):
    """The state carries its model's GUID and only finite values; fmi2SetFMUstate to a state saved before an error
    leaves the error state, as FMI 2.0 allows."""
    from fmpy.fmi1 import FMICallException

    from rom_component import model_file
    from rom_component.fmu.export import export_fmu
    from tests.conftest import fmpy_slave
    path, fmu_path, data = model
    arrays, metadata = model_file.load_arrays(path)
    other = {**arrays, "c": arrays["c"] + 1e-3}              # another model of the same sizes
    model_file.save(tmp_path / "other.npz", other, metadata)
    export_fmu(tmp_path / "other.npz", tmp_path / "other.fmu")

    mine, refs = fmpy_slave(fmu_path, "step_map")
    theirs, _ = fmpy_slave(tmp_path / "other.fmu", "step_map")
    inputs = [refs[f"force[{i + 1}]"] for i in range(N)]
    mine.setReal(inputs, list(data.F[5]))
    mine.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.1)
    state = mine.getFMUState()
    serialised = bytes(mine.serializeFMUstate(state))
    with pytest.raises(FMICallException):                     # the other model's FMU refuses it
        theirs.deSerializeFMUstate(serialised)
    values = np.frombuffer(serialised[8 + 40 + 16:], dtype=np.float64)
    for damage in (np.nan, np.inf):
        broken = values.copy()
        broken[0] = damage
        with pytest.raises(FMICallException):
            mine.deSerializeFMUstate(serialised[:8 + 40 + 16] + broken.tobytes())
    outputs = [refs[f"displacement[{i + 1}].{axis}"] for i in range(N) for axis in "xy"]
    for size in (1e300, 1.7e308):              # finite values that are no state: never a NaN output with fmi2OK
        restored = mine.deSerializeFMUstate(serialised[:8 + 40 + 16] + np.full_like(values, size).tobytes())
        mine.setFMUState(restored)
        try:
            mine.doStep(currentCommunicationPoint=0.1, communicationStepSize=0.1)
        except FMICallException:
            continue
        assert size < 1e308 and np.isfinite(mine.getReal(outputs)).all()
    with pytest.raises(FMICallException):      # the last one overflows: the step says so
        mine.doStep(currentCommunicationPoint=0.1, communicationStepSize=0.1)
    mine.setFMUState(state)                                   # back to the state saved before the error
    mine.setReal(inputs, list(data.F[6]))
    mine.doStep(currentCommunicationPoint=0.1, communicationStepSize=0.1)
    assert np.isfinite(mine.getReal([refs["displacement[1].x"]])).all()
    mine.terminate()
    mine.freeInstance()
    theirs.freeInstance()            # left in the error state by the refused state


def test_a_step_map_model_with_a_bad_window_or_a_grown_history_matrix_is_refused(model, tmp_path, capsys):
    from cosim.cli import main
    from rom_component import model_file
    path, _, _ = model
    arrays, metadata = model_file.load_arrays(path)
    with pytest.raises(model_file.ModelFileError, match="its metadata's 'dt'"):
        model_file.save(tmp_path / "nan.npz", arrays, {**metadata, "dt": float("nan")})
    bad = tmp_path / "grown.npz"
    np.savez(bad, **{**arrays, "W_z": arrays["W_z"] * 1e6},
             metadata_json=np.frombuffer(__import__("json").dumps({"format": model_file.FORMAT, **metadata}).encode(),
                                         dtype=np.uint8))
    assert main(["export-fmu", str(bad), "--out", str(tmp_path / "grown.fmu")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "its history matrix W_z has spectral radius" in err, err
    assert not (tmp_path / "grown.fmu").exists()
