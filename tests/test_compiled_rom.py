"""The ROM's online path run in-process by the FMU's C code (``arithmetic = "compiled"``)."""

from __future__ import annotations

import ctypes
import os
import time

import numpy as np
import pytest

from cosim.errors import ComponentError, CosimError
from cosim.launcher import Launcher
from cosim.proxy import ComponentProxy
from cosim.results import RunResults
from rom_component import model_file
from rom_component.native.build import library_path
from rom_component.static import compiled
from rom_component.static.component import RomSolid
from rom_component.static.load import load_rom
from tests.conftest import children_of
from tests.roms import solid_rom
from tests.test_flap_rom import calls  # noqa: F401  (the module's fixture)
from tests.test_fmu import models  # noqa: F401  (the module's fixture)
from tests.test_rom_integration import TRAIN_END, fom, model, rom_run  # noqa: F401  (fixtures)


def assert_same_calls(path, F):
    reference, fast = load_rom(path), load_rom(path, "compiled")
    for f in F:
        assert fast(f).tobytes() == reference(f).tobytes()
        assert fast.reduced.tobytes() == reference.reduced.tobytes()
        (e_ref, d_ref), (e, d) = reference.trust(), fast.trust()
        assert e == e_ref and d == pytest.approx(d_ref, rel=1e-12)


@pytest.mark.parametrize("name", ["rbf", "qm_poly", "qm_cubic"])
def test_compiled_calls_are_bit_identical_in_and_out_of_range(models, name):  # noqa: F811
    path, _, F = models[name]
    assert_same_calls(path, np.vstack([F[:40] * 1.003, F[:10] * 3.0 - 1.0]))   # the last ones far out of range


def flap_model(calls, folder):  # noqa: F811
    """A ROM of the double flap's sizes (r_f = 45: 11 groups of 4 encoder rows and one more; 530 outputs: 33
    blocks of 16 and 2 more), its path and the forces to call it with, the last ten beyond the training data."""
    F, U, _, _ = calls
    rom = solid_rom(45, 9, {"type": "poly", "quadratic_modes": 4, "term_scaling": "global"}, "quadratic")
    rom.fit(F[::2], U[::2])
    path = model_file.save(folder / "flap.npz", rom.online_arrays(), {"regressor": "poly", "params": rom.settings()})
    out_of_range = F[1:200:20] + 0.3 * (F[1:200:20] - F.mean(axis=0))
    return path, np.vstack([F[1:400:4], out_of_range])


def test_compiled_calls_are_bit_identical_on_the_double_flap(calls, tmp_path):  # noqa: F811
    assert_same_calls(*flap_model(calls, tmp_path))


def test_the_scalar_build_gives_the_vector_builds_bits(calls, tmp_path, monkeypatch):  # noqa: F811
    path, F = flap_model(calls, tmp_path)
    monkeypatch.setenv("COSIM_CACHE", str(tmp_path / "cache"))
    vector, reference = load_rom(path, "compiled"), load_rom(path)
    scalar = compiled.CompiledRom(*model_file.load_arrays(path), defines=("SOLID_ROM_SCALAR",))
    assert scalar._lib._name != vector._lib._name and len(list((tmp_path / "cache").iterdir())) == 2
    for f in F:
        assert scalar(f).tobytes() == vector(f).tobytes() == reference(f).tobytes()
        assert scalar.reduced.tobytes() == vector.reduced.tobytes()


def test_the_library_is_built_once_per_source_and_a_missing_compiler_is_named(models, tmp_path, monkeypatch):  # noqa: F811
    path, _, F = models["rbf"]
    monkeypatch.setenv("COSIM_CACHE", str(tmp_path / "cache"))
    first = library_path(compiled.SOURCE)
    built = first.stat().st_mtime_ns
    load_rom(path, "compiled")(F[0])
    assert library_path(compiled.SOURCE) == first and first.stat().st_mtime_ns == built
    assert list((tmp_path / "cache").iterdir()) == [first]       # no build leftovers
    monkeypatch.setenv("CC", "no-such-compiler")                  # another compiler: another library, not built
    with pytest.raises(CosimError, match="the compiled ROM .*no-such-compiler.*not found") as refused:
        load_rom(path, "compiled")
    assert "export-fmu" not in str(refused.value)


def test_the_in_process_library_needs_no_fmpy_and_has_no_fmi_entry_points(tmp_path):
    """The families' compiled paths build the ROM's C code with the runtime and the in-process entry points only:
    no FMI header (fmpy's) is needed, and the library has no FMI function."""
    import subprocess
    import sys
    code = ("import sys; sys.modules['fmpy'] = None; from rom_component.native.build import library_path; "
            "from rom_component.static.compiled import SOURCE as SOLID; "
            "from rom_component.dynamic.compiled import SOURCE as STEP_MAP; "
            "print(library_path(SOLID)); print(library_path(STEP_MAP))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          env={**os.environ, "COSIM_CACHE": str(tmp_path)})
    for library in done.stdout.split():
        lib = ctypes.CDLL(library)
        assert hasattr(lib, "rom_open") and not hasattr(lib, "fmi2Instantiate") and not hasattr(lib, "fmi2GetVersion")


def test_the_component_takes_compiled_arithmetic_and_names_a_wrong_one(models):  # noqa: F811
    path, _, F = models["qm_poly"]
    steps = []
    for arithmetic in ("reproducible", "compiled"):
        component = RomSolid()
        component.instantiate({"model": str(path), "arithmetic": arithmetic})
        steps.append([component.step(0.01 * k, 0.01, {"force": f}) for k, f in enumerate(F[:20])])
    for a, b in zip(*steps):
        assert a.keys() == b.keys()
        assert a["displacement"].tobytes() == b["displacement"].tobytes()
        assert a["rom_excess"][0] == b["rom_excess"][0]
    with pytest.raises(ComponentError, match="solid_rom.*'arithmetic' is 'quick'; allowed: reproducible, compiled, fast"):
        RomSolid().instantiate({"model": str(path), "arithmetic": "quick"})


def test_the_step_s_short_path_gives_the_checked_path_s_results_and_errors(models):  # noqa: F811
    path, _, F = models["qm_poly"]
    short, checked = RomSolid(), RomSolid()
    for component in (short, checked):
        component.instantiate({"model": str(path), "arithmetic": "compiled"})
    n = len(F[0])
    for k, f in enumerate(F[:5]):
        a = short.step(0.01 * k, 0.01, {"force": f})            # one float array of the input's shape
        b = checked.step(0.01 * k, 0.01, {"force": list(f)})     # a list: the checked path
        assert all(a[name].tobytes() == b[name].tobytes() for name in a)
    with pytest.raises(ComponentError, match=rf"input 'force' has shape \({n + 1},\), expected \({n},\)"):
        short.step(0.05, 0.01, {"force": np.zeros(n + 1)})
    with pytest.raises(ComponentError, match="'pressure' is not an input"):
        short.step(0.05, 0.01, {"force": F[0], "pressure": F[0]})
    np.testing.assert_array_equal(short.terminate()["full_field"], checked.terminate()["full_field"])


@pytest.mark.parametrize("name", ["rbf", "qm_cubic"])
def test_the_served_step_gives_the_step_s_results_with_one_c_call(models, name):  # noqa: F811
    path, _, F = models[name]
    settings = {"model": str(path), "arithmetic": "compiled", "on_out_of_range": "fallback", "range_margin": 0.05,
                "transient_calls": 1, "transient_margin": 0.5}
    stepped, served = RomSolid(), RomSolid()
    for component in (stepped, served):
        component.instantiate(settings)
    assert served._served is not None
    far = F[0] * 3.0 - 1.0                              # out of range: the fallback's windows are left out
    inputs = [F[0], F[1], far, far, F[2], F[3], F[3], far, F[4]]
    times = [0.0, 0.0, 0.01, 0.01, 0.02, 0.03, 0.03, 0.04, 0.05]
    name, output = served.input_name, served.output_name
    inputs += [F[5].astype(np.float32), F[5]]          # another dtype: the checked path; then a last window
    times += [0.06, 0.07]
    last_flag = {}                                      # of each window's last call
    for t, f in zip(times, inputs):
        a = stepped.step(t, 0.01, {name: f})
        b = served.served_step(t, 0.01, {name: f})
        assert a.keys() == b.keys()
        for key in a:
            assert a[key].tobytes() == b[key].tobytes(), key     # the distance too: both take IEEE roots
        last_flag[t] = b["rom_out_of_range"][0]
    assert last_flag[0.01] == 1.0 and last_flag[0.0] == 0.0   # a window's second far call answers to range_margin
    before = {key: value.copy() for key, value in b.items()}
    served.idle()                                           # keep_warm repeats the served call: the same bits
    assert served.keep_warm_calls == 1 and all(b[key].tobytes() == before[key].tobytes() for key in b)
    kept = b[output].copy()
    served.served_step(0.08, 0.01, {name: F[6]})
    assert b[output].tobytes() != kept.tobytes()          # the served arrays are the ROM's own buffers
    assert served.get_values([output])[output].tobytes() == stepped.step(0.08, 0.01, {name: F[6]})[output].tobytes()
    a, b = stepped.terminate(), served.terminate()
    np.testing.assert_array_equal(a["full_field"], b["full_field"])
    expected = [t + 0.01 for t, flag in last_flag.items() if flag == 0.0] + [0.09]
    np.testing.assert_allclose(b["time"], expected)     # the windows that fell back are left out


def test_a_tube_rom_fom_run_is_the_same_with_the_compiled_path(fom, model, tmp_path):  # noqa: F811
    rom_run(tmp_path / "reproducible", model, TRAIN_END)
    rom_run(tmp_path / "compiled", model, TRAIN_END, "components.solid.rom.arithmetic=compiled")
    assert children_of(os.getpid()) == []
    with RunResults(tmp_path / "reproducible") as a, RunResults(tmp_path / "compiled") as b:
        np.testing.assert_array_equal(a.windows.iterations, b.windows.iterations)
        for name in ("pressure", "section"):
            np.testing.assert_array_equal(a.fields()[name], b.fields()[name])


def test_a_window_s_first_calls_answer_to_the_transient_margin(models):  # noqa: F811
    path, _, F = models["qm_poly"]
    probe = RomSolid()
    probe.instantiate({"model": str(path), "arithmetic": "compiled"})
    far = F[0] * 3.0 - 1.0
    excess = probe.step(0.0, 0.01, {"force": far})["rom_excess"][0]
    assert excess > 1.0
    settings = {"model": str(path), "arithmetic": "compiled", "on_out_of_range": "fallback", "range_margin": 0.05,
                "transient_calls": 2}
    component = RomSolid()
    component.instantiate({**settings, "transient_margin": 2.0 * excess})
    flags = [component.step(t, 0.01, {"force": far})["rom_out_of_range"][0] for t in (0.0, 0.0, 0.0, 0.01, 0.01)]
    assert flags == [0.0, 0.0, 1.0, 0.0, 0.0]         # the third call of a window answers to range_margin
    strict = RomSolid()
    strict.instantiate({**settings, "transient_margin": 0.5 * excess})
    assert strict.step(0.0, 0.01, {"force": far})["rom_out_of_range"][0] == 1.0
    with pytest.raises(ComponentError, match="'transient_margin' is 0.01, below 'range_margin' 0.05"):
        RomSolid().instantiate({**settings, "transient_margin": 0.01})


def test_keep_warm_repeats_the_last_call_between_requests_and_changes_no_result(models, tmp_path):  # noqa: F811
    path, _, F = models["qm_poly"]
    settings = {"model": str(path), "arithmetic": "compiled"}
    plain, warm = RomSolid(), RomSolid()
    plain.instantiate(settings)
    warm.instantiate({**settings, "keep_warm": 0.001})
    assert plain.idle_interval is None and warm.idle_interval == 0.001
    warm.idle()                                     # before any call: nothing to repeat
    for k, f in enumerate(F[:6]):
        a = plain.step(0.01 * k, 0.01, {"force": f})
        warm.set_values({"force": F[-1 - k]})       # inputs set, not stepped: the repeat is of the last step (none at k = 0)
        warm.idle()
        b = warm.step(0.01 * k, 0.01, {"force": f})
        warm.idle()
        assert all(a[name].tobytes() == b[name].tobytes() for name in a)
        assert warm.get_values(["displacement"])["displacement"].tobytes() == a["displacement"].tobytes()
    np.testing.assert_array_equal(plain.terminate()["full_field"], (final := warm.terminate())["full_field"])
    assert final["keep_warm_calls"][0] == 11 and final["keep_warm_seconds"][0] > 0

    # served: the server calls idle() while no request comes, and the results stay the same
    launcher = Launcher(tmp_path / "logs")
    with launcher:
        process = launcher.spawn("rom", "tests.components:CountingRom")
        proxy = ComponentProxy("rom", launcher.handshake(process), process=process)
        proxy.instantiate({**settings, "keep_warm": 0.002})
        proxy.enter_initialization_mode(0.0, 1.0)
        proxy.exit_initialization_mode()
        first = proxy.step(0.0, 0.01, {"force": F[0]})
        deadline = time.monotonic() + 20.0
        while proxy.get_values(["keep_warm_calls"])["keep_warm_calls"][0] < 3:
            assert time.monotonic() < deadline, "no idle call within 20 s"
            time.sleep(0.01)
        again = proxy.step(0.01, 0.01, {"force": F[0]})
        assert first["displacement"].tobytes() == again["displacement"].tobytes() == \
            plain_step(settings, F[0])["displacement"].tobytes()
        proxy.shutdown()
        proxy.close()
    assert children_of(os.getpid()) == []


def plain_step(settings: dict, f: np.ndarray) -> dict:
    component = RomSolid()
    component.instantiate(settings)
    return component.step(0.0, 0.01, {"force": f})
