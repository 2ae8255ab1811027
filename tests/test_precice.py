"""preCICE cases under cosim: unmodified participants (v3 and v2 APIs) against the native scene bit for bit, the
configuration read or refused line by line, the API's misuses named, subcycling, and the swap of a participant."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim import protocol
from cosim.cli import main
from cosim.errors import CosimError, SceneError
from cosim.results import RunResults
from cosim.rundir import alive, read_status
from cosim.scene import load_scene
from coupler.run import run_scene
from precice_compat.config import read_config
from tests.conftest import ROOT, TUBE_SCENE, children_of, participant_module, wait_for

EXAMPLE = ROOT / "examples" / "precice_tube"
SHIM = ROOT / "precice_compat" / "participant"
NAMES = {"pressure": "Pressure", "section": "CrossSectionLength"}
END = 2.0


def native(out: Path, *overrides: str) -> Path:
    """The native tube with IQN-ILS as the example's configuration has it, preCICE's: no window reused (the example's
    120 s do not converge under preCICE nor cosim with 8 reused and no stale columns dropped), reused columns kept
    whatever the residual does, the windows reused those that hold columns."""
    run_scene(load_scene(TUBE_SCENE, [f"time.end={END:g}", "coupling.acceleration.reused_time_windows=0",
                                      "coupling.acceleration.stale_step_ratio=0",
                                      "coupling.acceleration.count_emptied_windows=false", *overrides]),
              out, progress=False)   # later --set wins
    return out


def case(out: Path, case_file: Path = EXAMPLE / "case.toml", *overrides: str, fluid: str = "FluidSolver.py",
         config: str = "../precice-config.xml") -> Path:
    run_scene(load_scene(case_file, [f"time.end={END:g}",
                                     f"participants.Fluid.command=python3 {fluid} {config} {END:g}", *overrides]),
              out, progress=False)
    return out


def same_run(native_out: Path, case_out: Path) -> None:
    """Every window's iterations, every exchanged field and every coupling residual, bit for bit."""
    with RunResults(native_out) as a, RunResults(case_out) as b:
        assert np.array_equal(a.windows.iterations, b.windows.iterations)
        assert np.array_equal(a.windows.time, b.windows.time)
        fields_a, fields_b = a.fields(), b.fields()
        for ours, theirs in NAMES.items():
            assert fields_a[ours].tobytes() == fields_b[theirs].tobytes(), ours
        assert a.residuals()[1].tobytes() == b.residuals()[1].tobytes()


@pytest.fixture(scope="module")
def native_run(tmp_path_factory) -> Path:
    return native(tmp_path_factory.mktemp("native") / "run")


def test_tube_participants_on_the_v3_api_give_the_native_run_bit_for_bit(native_run, tmp_path):
    out = case(tmp_path / "v3")
    same_run(native_run, out)
    with RunResults(out) as results:
        calls = results.calls("Solid")
        assert len(calls) == results.windows.iterations.sum()          # every sub-iteration recorded
        assert set(calls.inputs) == {"Pressure"} and set(calls.outputs) == {"CrossSectionLength"}
        assert results.component("Fluid").meshes["Fluid-Nodes"].shape == (101, 2)
    assert children_of(os.getpid()) == []


def test_tube_participants_on_the_v2_api_give_the_native_run_bit_for_bit(native_run, tmp_path):
    out = case(tmp_path / "v2", EXAMPLE / "case-v2.toml", fluid="FluidSolverV2.py", config="../precice-config-v2.xml")
    same_run(native_run, out)


SWAPPED_SOLID = """[precice]
config = "{example}/precice-config.xml"
[participants.Fluid]
command = "python3 FluidSolver.py ../precice-config.xml"
cwd = "{example}/fluid-python"
[participants.Solid]        # the native tube solid in the participant's place, under the configuration's names
backend = "component"
entry = "solid_component.tube:TubeSolid"
parameters = {{ E_small = 12500.0, E_large = 2500.0, s0 = 20.0, eps0 = 2e-3, tube = {{ length = 10.0, cells = 100, a0 = 1.0 }} }}
names = {{ Pressure = "pressure", CrossSectionLength = "section" }}
"""


def test_the_fluid_participant_with_the_native_solid_swapped_in_by_names_gives_the_native_run(native_run, tmp_path):
    """The Solid participant swapped for solid_component.tube:TubeSolid by four lines: the configuration's data
    named onto the component's variables, its 1-D axis on the configuration's 2-D mesh. Bit for bit the native run
    (the exchanges under the configuration's names, the mapping between coinciding meshes the identity)."""
    case_file = tmp_path / "case.toml"
    case_file.write_text(SWAPPED_SOLID.format(example=EXAMPLE))
    out = case(tmp_path / "swapped", case_file)
    same_run(native_run, out)
    with RunResults(out) as results:
        assert set(results.calls("Solid").inputs) == {"Pressure"}
        assert results.component("Solid").meshes["axis"].shape == (101, 2)


def test_a_swapped_component_whose_names_miss_is_named_by_cosim_check(tmp_path, capsys):
    """cosim check starts the swapped component as a run would: a data name it does not rename is refused."""
    case_file = tmp_path / "case.toml"
    case_file.write_text(SWAPPED_SOLID.format(example=EXAMPLE).replace(', CrossSectionLength = "section"', ""))
    assert main(["check", str(case_file)]) == 2
    err = capsys.readouterr().err
    assert "'CrossSectionLength'" in err and "component 'Solid'" in err, err


RANKS = """\"\"\"Start N ranks of a participant as mpirun would (RANK and SIZE in each one's environment); the first
that fails stops the others and gives its exit code.\"\"\"
import os
import subprocess
import sys
import time

size, command = int(sys.argv[1]), sys.argv[2:]
ranks = [subprocess.Popen([sys.executable, *command], env={**os.environ, "RANK": str(r), "SIZE": str(size)})
         for r in range(size)]
while True:
    codes = [rank.poll() for rank in ranks]
    failed = [code for code in codes if code not in (None, 0)]
    if failed or all(code == 0 for code in codes):
        for rank in ranks:
            if rank.poll() is None:
                rank.kill()
                rank.wait()
        sys.exit(failed[0] if failed else 0)
    time.sleep(0.01)
"""
SOLID_RANKS = """\"\"\"The tube's wall as a parallel preCICE participant: rank RANK of SIZE owns a slice of the nodes.\"\"\"
import os
import sys

import numpy as np
import precice

from solid_component.tube import TubeSolid

rank, size = int(os.environ["RANK"]), int(os.environ["SIZE"])
solid = TubeSolid()
solid.instantiate({"tube": {"length": 10.0, "cells": 100, "a0": 1.0}, "E_small": 12500.0, "E_large": 2500.0,
                   "s0": 20.0, "eps0": 2e-3})
participant = precice.Participant("Solid", sys.argv[1], rank, size)
axis = solid.meshes()["axis"][:, 0]
mine = np.array_split(np.arange(len(axis)), size)[rank]
ids = participant.set_mesh_vertices("Solid-Nodes", np.column_stack([axis[mine], np.zeros(len(mine))]))
if participant.requires_initial_data():
    participant.write_data("Solid-Nodes", "CrossSectionLength", ids, solid.get_values(["section"])["section"][mine])
participant.initialize()
window = 0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    pressure = np.zeros(len(axis))
    pressure[mine] = participant.read_data("Solid-Nodes", "Pressure", ids, dt)
    solid.set_values({"pressure": pressure})
    solid.do_step(window * dt, dt)
    participant.write_data("Solid-Nodes", "CrossSectionLength", ids, solid.get_values(["section"])["section"][mine])
    participant.advance(dt)
    if not participant.requires_reading_checkpoint():
        window += 1
    if window == int(os.environ.get("DIE_AT_WINDOW", -1)) and rank == size - 1:
        os._exit(3)
participant.finalize()
"""


def ranks_case(folder: Path, size: int) -> Path:
    """The tube example with its Solid as ``size`` ranks, each owning a slice of the wall's nodes."""
    (folder / "solid").mkdir(parents=True, exist_ok=True)
    (folder / "solid" / "ranks.py").write_text(RANKS)
    (folder / "solid" / "solid_ranks.py").write_text(SOLID_RANKS)
    case_file = folder / "case.toml"
    case_file.write_text(f'[precice]\nconfig = "{EXAMPLE}/precice-config.xml"\n[participants.Fluid]\n'
                         f'command = "python3 FluidSolver.py ../precice-config.xml"\ncwd = "{EXAMPLE}/fluid-python"\n'
                         f'[participants.Solid]\ncommand = "python3 ranks.py {size} solid_ranks.py '
                         f'{EXAMPLE}/precice-config.xml"\ncwd = "solid"\n')
    return case_file


@pytest.mark.parametrize("size", [2, 3])
def test_a_participant_in_ranks_gives_the_serial_runs_iterations_and_fields(native_run, tmp_path, size):
    """The Solid started as 2 and 3 ranks (Participant(name, config, rank, size) in each), each with its slice of
    the vertices: the coupler joins them, and the run is the serial one's, bit for bit (the native run's)."""
    out = case(tmp_path / "out", ranks_case(tmp_path, size))
    same_run(native_run, out)
    with RunResults(out) as results:
        assert results.component("Solid").meshes["Solid-Nodes"].shape == (101, 2)
    assert children_of(os.getpid()) == []


def mpi_launcher() -> Path | None:
    """The MPI launcher beside this Python (the `mpi` extra: mpi4py and the mpich wheel), if mpi4py imports."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return None
    launcher = Path(sys.executable).parent / "mpiexec"
    return launcher if launcher.exists() else None


@pytest.mark.parametrize("size", [2, 3])
def test_a_participant_under_mpiexec_with_mpi4py_gives_the_serial_runs_iterations_and_fields(native_run, tmp_path,
                                                                                              size):
    """The Solid as an MPI program: mpiexec -n 2 and 3 (MPICH, from the registry), each rank's Participant(name,
    config, comm.rank, comm.size) from mpi4py: the run is the serial one's, bit for bit."""
    launcher = mpi_launcher()
    if launcher is None:
        pytest.skip("needs mpi4py and an mpiexec beside this Python (pip install '.[mpi]')")
    case_file = ranks_case(tmp_path, size)
    (tmp_path / "solid" / "solid_ranks.py").write_text(SOLID_RANKS.replace(
        'rank, size = int(os.environ["RANK"]), int(os.environ["SIZE"])',
        'from mpi4py import MPI\nrank, size = MPI.COMM_WORLD.rank, MPI.COMM_WORLD.size'))
    case_file.write_text(case_file.read_text().replace(f"python3 ranks.py {size} solid_ranks.py",
                                                       f"{launcher} -n {size} {sys.executable} solid_ranks.py"))
    assert "mpiexec" in case_file.read_text() and "mpi4py" in (tmp_path / "solid" / "solid_ranks.py").read_text()
    out = case(tmp_path / "out", case_file)
    same_run(native_run, out)
    assert children_of(os.getpid()) == []


def test_a_rank_that_dies_stops_the_run_naming_it(tmp_path, monkeypatch):
    monkeypatch.setenv("DIE_AT_WINDOW", "3")
    # the launcher stops the other ranks when one fails (as mpirun does): the ranks found gone include the one that died
    with pytest.raises(CosimError, match=r"component 'Solid' in window 4 .*: its ranks? (\d and )*2 \(pids? [\d, ]+\) "
                                         r"(is|are) gone while"):
        case(tmp_path / "out", ranks_case(tmp_path, 3))
    assert children_of(os.getpid()) == []


def test_direct_access_from_a_parallel_participant_is_refused_in_one_line(tmp_path):
    """A parallel participant's ranks would each write on the whole received mesh: refused, naming the call."""
    accessor = DIRECT_ACCESSOR.replace('precice.Participant("Accessor", "../config.xml", 0, 1)',
                                       'precice.Participant("Accessor", "../config.xml", int(os.environ["RANK"]), '
                                       'int(os.environ["SIZE"]))').replace("import json", "import json, os")
    case_file = write_case(tmp_path, {"Provider": DIRECT_PROVIDER, "Accessor": accessor}, DIRECT_CONFIG)
    (tmp_path / "Accessor" / "ranks.py").write_text(RANKS)
    case_file.write_text(case_file.read_text().replace('command = "python3 participant.py"\ncwd = "Accessor"',
                                                       'command = "python3 ranks.py 2 participant.py"\ncwd = "Accessor"'))
    with pytest.raises(CosimError, match=re.escape("direct access from a parallel participant (2 ranks) is not "
                                                   "supported by cosim")):
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert children_of(os.getpid()) == []


def test_a_participant_wire_message_is_cosims_both_ways():
    """The participant package's own codec and cosim.protocol read each other's messages."""
    _wire = participant_module("_wire")
    arrays = {"data:P": np.linspace(0.0, 1.0, 7), "mesh:M": np.arange(12.0).reshape(6, 2)}
    header, decoded = protocol.decode(_wire.encode({"op": "advance", "id": 3, "args": {"dt": 0.1}}, arrays))
    assert header["op"] == "advance" and header["args"] == {"dt": 0.1}
    assert all(np.array_equal(decoded[k], v) for k, v in arrays.items())
    frames = [bytes(memoryview(f)) for f in protocol.encode({"id": 3, "ok": True, "result": {"x": 1}}, arrays)]
    header, decoded = _wire.decode(frames)
    assert header["result"] == {"x": 1} and all(np.array_equal(decoded[k], v) for k, v in arrays.items())
    decoded["data:P"][0] = 5.0        # the participant's copy is its own


def test_cosim_check_prints_the_scene_a_case_becomes_and_what_set_overrides(capsys):
    assert main(["check", str(EXAMPLE / "case.toml"), "--set", "time.end=1",
                 "--set", "coupling.max_iterations=40", "--print"]) == 0
    out, err = capsys.readouterr()
    assert '"scheme": "serial-implicit"' in out and '"reused_time_windows": 0' in out
    assert "'coupling.max_iterations' comes from --set, which wins" in err
    assert "<log> (line 4) is output only" in err
    assert "valid" in err.splitlines()[0]                      # the verdict first


def test_resuming_a_case_with_participants_is_refused_in_one_line(tmp_path, capsys):
    assert main(["run", str(EXAMPLE / "case.toml"), "--out", str(tmp_path / "r"), "--quiet", "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--resume is refused: a preCICE participant keeps its state to itself, and Fluid, " \
                                "Solid are" in err
    assert main(["run", str(EXAMPLE / "case.toml"), "--out", str(tmp_path / "r"), "--quiet", "--resume",
                 "--set", "participants.Solid.backend=rom"]) == 2
    assert "and Fluid is one" in capsys.readouterr().err


# --- configurations cosim refuses, each in one line naming the file and the line ---------------------------------
TUBE_CONFIG = (EXAMPLE / "precice-config.xml").read_text()
BAD_CONFIGS = [
    ("an unknown element", ("<m2n:sockets", "<foo-bar/>\n  <m2n:sockets"), "<foo-bar>: this element is not supported"),
    ("an unknown attribute", ('<data:scalar name="Pressure" />', '<data:scalar name="Pressure" colour="red" />'),
     "the attribute 'colour' is not supported"),
    ("a data name no mesh uses", ('<write-data name="Pressure" mesh="Fluid-Nodes" />',
                                  '<write-data name="Velocity" mesh="Fluid-Nodes" />'), "no data 'Velocity'"),
    ("a mapping between unknown meshes", ('from="Solid-Nodes" to="Fluid-Nodes"', 'from="Beam-Nodes" to="Fluid-Nodes"'),
     "no mesh 'Beam-Nodes' is defined"),
    ("an RBF mapping without its basis", ("<mapping:nearest-neighbor direction=\"read\" from=\"Solid-Nodes\"",
                                          "<mapping:rbf direction=\"read\" from=\"Solid-Nodes\""),
     "an RBF mapping holds one"),
    ("a window size the first participant chooses", ('<time-window-size value="0.1" />',
                                                      '<time-window-size method="first-participant" />'),
     "a window size the first participant chooses is not supported"),
    ("an unknown coupling scheme", ("coupling-scheme:serial-implicit>", "coupling-scheme:staggered>"),
     "the coupling scheme 'staggered' is not supported"),
    ("a multi-coupling given two participants as a pair", ("coupling-scheme:serial-implicit>",
                                                          "coupling-scheme:multi>"),
     "<participants>: this element of a coupling scheme is not supported"),
    ("the QR3 filter", ('<filter type="QR2"', '<filter type="QR3"'), "the filter 'QR3' is not supported"),
    ("a waveform degree of 4", ('<data:scalar name="Pressure" />', '<data:scalar name="Pressure" waveform-degree="4" />'),
     "'waveform-degree' is 4; allowed: 0 to 3"),
    ("no window size", ('<time-window-size value="0.1" />', ''), "<time-window-size value=\"...\"/> is required"),
    ("a window size that is no number", ('<time-window-size value="0.1" />', '<time-window-size value="fast" />'),
     "'value' is 'fast', not a number"),
    ("an exchange of data its sender does not write", ('data="Pressure" mesh="Fluid-Nodes" from="Fluid" to="Solid"',
                                                       'data="Pressure" mesh="Fluid-Nodes" from="Solid" to="Fluid"'),
     "participant 'Solid' does not write 'Pressure'"),
    ("an undefined participant", ('<participants first="Fluid" second="Solid" />',
                                  '<participants first="Fluid" second="Structure" />'),
     "participant 'Structure' is not defined"),
    ("a geometric multiscale mapping", ("mapping:nearest-neighbor direction=\"read\" from=\"Solid-Nodes\"",
                                        "mapping:axial-geometric-multiscale direction=\"read\" from=\"Solid-Nodes\""),
     "the mapping 'axial-geometric-multiscale' is not supported"),
    ("an action", ('<write-data name="Pressure" mesh="Fluid-Nodes" />',
                   '<write-data name="Pressure" mesh="Fluid-Nodes" />\n    <action:multiply-by-area timing="write-mapping-post" mesh="Fluid-Nodes"/>'),
     "actions are not supported"),
    ("not XML", ("</precice-configuration>", "</precice-configuratio>"), "not XML: mismatched tag"),
    ("a missing mapping", ('    <mapping:nearest-neighbor direction="read" from="Solid-Nodes" to="Fluid-Nodes" '
                           'constraint="consistent" />\n', ''), "no <mapping:...> maps 'Solid-Nodes' to 'Fluid-Nodes'"),
    ("a watch point named as a path", ('<write-data name="Pressure" mesh="Fluid-Nodes" />',
                                       '<write-data name="Pressure" mesh="Fluid-Nodes" />\n    <watch-point '
                                       'mesh="Fluid-Nodes" name="../../x" coordinate="0.0;0.0" />'),
     "the watch point's name '../../x' must be a plain name"),
    ("min-iterations above max-iterations", ('<max-iterations value="90" />',
                                             '<max-iterations value="5" /><min-iterations value="6" />'),
     '<min-iterations value="6"/> is above <max-iterations value="5"/>'),
    ("a window of 0 s", ('<time-window-size value="0.1" />', '<time-window-size value="0" />'),
     "line 40: <time-window-size>: 'value' is 0; allowed: above 0"),
    ("a max-time of 0 s", ('<max-time value="120" />', '<max-time value="0" />'), "<max-time>: 'value' is 0; allowed: above 0"),
    ("a filter limit of 0", ('<filter type="QR2" limit="1e-3" />', '<filter type="QR2" limit="0" />'),
     "<filter>: 'limit' is 0; allowed: above 0 and below 1"),
    ("an initial relaxation of 2", ('<initial-relaxation value="0.01" />', '<initial-relaxation value="2" />'),
     "<initial-relaxation>: 'value' is 2; allowed: above 0 and at most 1"),
    ("a measure's limit of 0", ('data="Pressure" mesh="Fluid-Nodes" limit="1e-4"', 'data="Pressure" mesh="Fluid-Nodes" limit="0"'),
     "<relative-convergence-measure>: 'limit' is 0; allowed: above 0"),
    ("a scaled-consistent constraint", ('to="Fluid-Nodes" constraint="consistent"',
                                        'to="Fluid-Nodes" constraint="scaled-consistent-surface"'),
     "cosim maps 'consistent' or 'conservative' data"),
]


@pytest.mark.parametrize("what, change, message", BAD_CONFIGS, ids=[b[0] for b in BAD_CONFIGS])
def test_a_bad_configuration_is_one_line_with_its_file_and_line(tmp_path, capsys, what, change, message):
    old, new = change
    assert old in TUBE_CONFIG, what
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu"))
    (tmp_path / "case" / "precice-config.xml").write_text(TUBE_CONFIG.replace(old, new))
    code = main(["run", str(tmp_path / "case" / "case.toml"), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert message in err and "precice-config.xml" in err, err
    assert not (tmp_path / "out" / "results.h5").exists()


RBF_READ = '<mapping:nearest-neighbor direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" />'


def rbf_config(tmp_path: Path, mapping: str) -> Path:
    path = tmp_path / "precice-config.xml"
    path.write_text(TUBE_CONFIG.replace(RBF_READ, mapping))
    return path


@pytest.mark.parametrize(("mapping", "settings"), [
    ('<mapping:rbf direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent">'
     '<basis-function:thin-plate-splines /></mapping:rbf>',
     {"basis": "thin-plate-splines", "polynomial": "separate"}),
    ('<mapping:rbf-global-direct direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" '
     'polynomial="off" y-dead="true"><basis-function:gaussian shape-parameter="4.5" /></mapping:rbf-global-direct>',
     {"basis": "gaussian", "shape_parameter": 4.5, "polynomial": "off", "dead_axes": "y"}),
    ('<mapping:rbf-pum-direct direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" '
     'vertices-per-cluster="20"><basis-function:compact-tps-c2 support-radius="0.2" /></mapping:rbf-pum-direct>',
     {"basis": "compact-tps-c2", "support_radius": 0.2, "polynomial": "separate"}),
    ('<mapping:rbf-multiquadrics direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" '
     'shape-parameter="0.5" polynomial="on" />', {"basis": "multiquadrics", "shape_parameter": 0.5, "polynomial": "on"}),
])
def test_each_rbf_form_of_a_configuration_becomes_cosims_rbf_mapping(tmp_path, mapping, settings):
    """preCICE's v3 RBF mappings (the alias, global-direct, partition of unity) and v2's rbf-<basis>, with their
    basis, its parameter, the polynomial and dead axes, read into the rbf mapping's settings."""
    read = next(m for m in read_config(rbf_config(tmp_path, mapping)).participants["Fluid"].mappings
                if m.direction == "read")
    assert read.kind == "rbf" and read.settings == {"constraint": "consistent", **settings}


@pytest.mark.parametrize(("mapping", "message"), [
    ('<mapping:rbf-global-direct direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" '
     'polynomial="on"><basis-function:compact-polynomial-c6 support-radius="1" /></mapping:rbf-global-direct>',
     'polynomial="on" is not supported for the compact-polynomial-c6 basis'),
    ('<mapping:rbf direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent">'
     '<basis-function:compact-polynomial-c2 /></mapping:rbf>', "the compact-polynomial-c2 basis needs a support-radius"),
    ('<mapping:rbf direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent">'
     '<basis-function:gaussian shape-parameter="1" support-radius="1" /></mapping:rbf>',
     "the gaussian basis needs a shape-parameter or a support-radius"),
    ('<mapping:rbf direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent">'
     '<basis-function:cubic /></mapping:rbf>', "unknown basis function 'cubic'"),
    ('<mapping:rbf direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" polynomial="on">'
     '<basis-function:thin-plate-splines /></mapping:rbf>', "<mapping:rbf> takes no 'polynomial'"),
    ('<mapping:rbf-global-direct direction="read" from="Solid-Nodes" to="Fluid-Nodes" constraint="consistent" '
     'x-dead="maybe"><basis-function:thin-plate-splines /></mapping:rbf-global-direct>', "'x-dead' is 'maybe'"),
])
def test_an_rbf_mapping_preCICE_would_refuse_is_refused_in_one_line(tmp_path, mapping, message):
    with pytest.raises(SceneError, match=re.escape(message)) as refused:
        read_config(rbf_config(tmp_path, mapping))
    assert "precice-config.xml" in str(refused.value) and "\n" not in str(refused.value)


# --- participants that misuse the API, or fail -----------------------------------------------------------------
MISUSES = [
    ("a checkpoint never asked for", "    if participant.requires_writing_checkpoint():\n        state = fluid.save_state()\n",
     "", "Participant.advance: the iteration checkpoint was not written: the implicit coupling asks for one here, and "
         "requires_writing_checkpoint() was not called since the last advance"),
    ("a repeated window not asked about", "    if participant.requires_reading_checkpoint():\n        fluid.restore_state(state)\n    else:\n        window += 1\n",
     "    window += 1\n", "Participant.advance: the iteration checkpoint was not read"),
    ("an unknown mesh", 'participant.set_mesh_vertices("Fluid-Nodes", coords)',
     'participant.set_mesh_vertices("Fluid-Mesh", coords)', "Participant.set_mesh_vertices: participant 'Fluid' "
                                                            "uses no mesh 'Fluid-Mesh'"),
    ("an unknown data name", 'participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, dt)',
     'participant.read_data("Fluid-Nodes", "Area", vertex_ids, dt)', "Participant.read_data: participant 'Fluid' reads "
                                                                    "no data 'Area'"),
    ("a wrong size", 'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)',
     'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure[:50])',
     "Participant.write_data: values of shape (50,) for 101 vertices"),
    ("advance before initialize", "participant.initialize()", "participant.advance(0.1)",
     "Participant.advance: advance before initialize"),
    ("a rank beyond the size", 'precice.Participant("Fluid", config, 0, 1)', 'precice.Participant("Fluid", config, 2, 2)',
     "rank 2 of size 2: the rank goes from 0 to size - 1"),
    ("a step beyond the window", "participant.advance(dt)", "participant.advance(2 * dt)",
     "Participant.advance: the step 0.2 is longer than what is left of the window, 0.1"),
    ("a step a hair beyond the window", "participant.advance(dt)", "participant.advance(dt * (1 + 3e-9))",
     "Participant.advance: the step 0.1000000003"),
    ("an error of megabytes on one line", "participant.initialize()",
     "participant.initialize()\nraise RuntimeError('line one\\nline two ' + 'x' * 2_000_000)",
     "it said: line two " + "x" * 300),
    ("a vertex id off the mesh", 'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)',
     'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids + 5, pressure)',
     "Participant.write_data: vertex id 101 is not on mesh 'Fluid-Nodes'"),
    ("data written it does not write", 'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)',
     'participant.write_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, pressure)',
     "Participant.write_data: participant 'Fluid' writes no data 'CrossSectionLength'"),
    ("a read beyond the step", 'participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, dt)',
     'participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, 1.5 * dt)',
     "Participant.read_data: relative_read_time 0.15 is outside the step (0 to 0.1, what is left of the window)"),
    ("a read at a NaN time", 'participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, dt)',
     'participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, float("nan"))',
     "Participant.read_data: relative_read_time nan is outside the step (0 to 0.1, what is left of the window)"),
    ("a NaN written", 'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)',
     'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure * float("nan"))',
     "Participant.write_data: values of 'Pressure' are not finite"),
    ("never calling initialize", "participant.initialize()", "raise SystemExit(0)",
     "component 'Fluid' in start-up: exited (code 0) while the coupler waited for initialize"),
    ("dying mid-window", "participant.advance(dt)", "os._exit(9) if window == 3 else participant.advance(dt)",
     "component 'Fluid' in window 4 (t = 0.3 to 0.4), iteration 1: process exited with code 9"),
    ("finalizing in the middle", "participant.advance(dt)", "participant.finalize()",
     "Participant.finalize: finalize while the coupling goes on"),
    ("remeshing", "    participant.advance(dt)\n", "    participant.advance(dt)\n    participant.reset_mesh('Fluid-Nodes')\n",
     "Participant.reset_mesh: remeshing is not supported by cosim: mesh 'Fluid-Nodes' keeps the vertices it had"),
    ("a name the run does not have", 'precice.Participant("Fluid", config, 0, 1)',
     'precice.Participant("Fluids", config, 0, 1)',
     "started as participant 'Fluid' and says hello as 'Fluids' (the run's participants: Fluid, Solid)"),
]
PARTICIPANT = '''
import os, sys
import numpy as np
import precice
from fluid_component.tube import TubeFluid

config = sys.argv[1]
fluid = TubeFluid()
fluid.instantiate({"tube": {"length": 10.0, "cells": 100, "a0": 1.0}, "inlet": {"f": 2.0, "h": 6.0, "table": ""},
                   "rho": 1.0, "v_ref": 6.0, "newton_tolerance": 1e-10})
participant = precice.Participant("Fluid", config, 0, 1)
coords = np.column_stack([np.linspace(0, 10, 101), np.zeros(101)])
vertex_ids = participant.set_mesh_vertices("Fluid-Nodes", coords)
fluid.enter_initialization_mode(0.0, 2.0)
fluid.exit_initialization_mode()
participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, fluid.get_values(["pressure"])["pressure"])
participant.initialize()
window = 0
state = None
while participant.is_coupling_ongoing():
    if participant.requires_writing_checkpoint():
        state = fluid.save_state()
    dt = participant.get_max_time_step_size()
    section = participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, dt)
    fluid.set_values({"section": section})
    fluid.do_step(window * dt, dt)
    pressure = fluid.get_values(["pressure"])["pressure"]
    participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)
    participant.advance(dt)
    if participant.requires_reading_checkpoint():
        fluid.restore_state(state)
    else:
        window += 1
participant.finalize()
'''


@pytest.mark.parametrize("what, old, new, message", MISUSES, ids=[m[0] for m in MISUSES])
def test_a_participant_misusing_the_api_stops_the_run_in_one_line_naming_the_call(tmp_path, capsys, what, old, new,
                                                                                  message):
    assert old in PARTICIPANT, what
    folder = tmp_path / "fluid"
    folder.mkdir()
    (folder / "Fluid.py").write_text(PARTICIPANT.replace(old, new, 1))
    code = main(["run", str(EXAMPLE / "case.toml"), "--out", str(tmp_path / "out"), "--quiet", "--set", "time.end=1",
                 "--set", f"participants.Fluid.command=python3 Fluid.py {EXAMPLE / 'precice-config.xml'}",
                 "--set", f"participants.Fluid.cwd={folder}", "--set", "participants.Fluid.startup_timeout=20"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err and len(err) < 2000, err[-300:]
    assert message in err, err[-300:]
    assert children_of(os.getpid()) == []


def test_a_participant_that_hangs_is_named_and_stopped(tmp_path, capsys):
    folder = tmp_path / "fluid"
    folder.mkdir()
    (folder / "Fluid.py").write_text(PARTICIPANT.replace("participant.advance(dt)",
                                                         "__import__('time').sleep(600)"))
    code = main(["run", str(EXAMPLE / "case.toml"), "--out", str(tmp_path / "out"), "--quiet", "--set", "time.end=1",
                 "--set", f"participants.Fluid.command={sys.executable} Fluid.py {EXAMPLE / 'precice-config.xml'}",
                 "--set", f"participants.Fluid.cwd={folder}", "--set", "participants.Fluid.timeout=2"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "component 'Fluid' in window 1" in err and "did not call advance within 2 s" in err, err
    assert children_of(os.getpid()) == []


SUBCYCLING = '''
import json, sys
import numpy as np
import precice

participant = precice.Participant("A", "../config.xml", 0, 1)
ids = participant.set_mesh_vertices("A-Mesh", [[0.0, 0.0], [1.0, 0.0]])
x = np.array([1.0, 2.0])
seen = []
participant.initialize()
while participant.is_coupling_ongoing():
    if participant.requires_writing_checkpoint():
        saved = x.copy()
    for step in range(4):
        dt = participant.get_max_time_step_size() / (4 - step)
        b = participant.read_data("A-Mesh", "B", ids, dt)
        seen.append(b.tolist())
        x = x + dt * (b - x)              # an explicit Euler step towards B's value
        participant.write_data("A-Mesh", "X", ids, x)
        participant.advance(dt)
    if participant.requires_reading_checkpoint():
        x = saved
participant.finalize()
json.dump(seen, open("seen.json", "w"))
'''
PARTNER = '''
import numpy as np
import precice

participant = precice.Participant("B", "../config.xml", 0, 1)
ids = participant.set_mesh_vertices("B-Mesh", [[0.0, 0.0], [1.0, 0.0]])
participant.initialize()
t = 0.0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    x = participant.read_data("B-Mesh", "X", ids, dt)
    participant.write_data("B-Mesh", "B", ids, 0.5 * x + np.sin(t + dt))
    participant.advance(dt)
    participant.requires_reading_checkpoint()
    t += dt
participant.finalize()
'''
SUBCYCLING_CONFIG = '''<?xml version="1.0"?>
<precice-configuration>
  <data:scalar name="X" waveform-degree="0"/>
  <data:scalar name="B" waveform-degree="0"/>
  <mesh name="A-Mesh" dimensions="2"><use-data name="X"/><use-data name="B"/></mesh>
  <mesh name="B-Mesh" dimensions="2"><use-data name="X"/><use-data name="B"/></mesh>
  <participant name="A">
    <provide-mesh name="A-Mesh"/><receive-mesh name="B-Mesh" from="B"/>
    <write-data name="X" mesh="A-Mesh"/><read-data name="B" mesh="A-Mesh"/>
    <mapping:nearest-neighbor direction="read" from="B-Mesh" to="A-Mesh" constraint="consistent"/>
  </participant>
  <participant name="B">
    <provide-mesh name="B-Mesh"/><receive-mesh name="A-Mesh" from="A"/>
    <write-data name="B" mesh="B-Mesh"/><read-data name="X" mesh="B-Mesh"/>
    <mapping:nearest-neighbor direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent"/>
  </participant>
  <m2n:sockets acceptor="A" connector="B" exchange-directory=".."/>
  <coupling-scheme:serial-implicit>
    <participants first="A" second="B"/>
    <max-time-windows value="10"/>
    <time-window-size value="0.1"/>
    <max-iterations value="30"/>
    <exchange data="X" mesh="A-Mesh" from="A" to="B" substeps="false"/>
    <exchange data="B" mesh="B-Mesh" from="B" to="A" substeps="false"/>
    <relative-convergence-measure data="B" mesh="B-Mesh" limit="1e-12"/>
    <acceleration:IQN-ILS>
      <data name="B" mesh="B-Mesh"/><initial-relaxation value="0.5"/>
    </acceleration:IQN-ILS>
  </coupling-scheme:serial-implicit>
</precice-configuration>
'''


def test_a_subcycling_participant_reads_the_window_end_value_at_every_step_at_degree_0(tmp_path):
    """A takes four steps a window; every read gives the window's end value (degree 0), and A's recorded outputs are
    those of the same solver run by hand on the recorded window inputs."""
    for name, text in (("A/A.py", SUBCYCLING), ("B/B.py", PARTNER), ("config.xml", SUBCYCLING_CONFIG),
                       ("case.toml", '[precice]\nconfig = "config.xml"\n[participants.A]\ncommand = "python3 A.py"\n'
                                     'cwd = "A"\n[participants.B]\ncommand = "python3 B.py"\ncwd = "B"\n')):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    run_scene(load_scene(tmp_path / "case.toml"), tmp_path / "out", progress=False)
    import json
    seen = np.array(json.loads((tmp_path / "A" / "seen.json").read_text()))
    with RunResults(tmp_path / "out") as results:
        calls = results.calls("A")
    inputs, outputs = calls.inputs["B"], calls.outputs["X"]
    assert len(seen) == 4 * len(calls)
    assert np.array_equal(seen, np.repeat(inputs, 4, axis=0))      # the window's value at each of its four steps
    x = np.array([1.0, 2.0])
    for window in range(1, 11):      # by hand: each window from the last converged state, on its recorded input
        mine = np.flatnonzero(calls.window == window)
        start = x
        for call in mine:
            x, elapsed = start.copy(), 0.0
            for step in range(4):           # the steps A takes: what is left of the window over the steps left
                dt = max(0.1 - elapsed, 0.0) / (4 - step)
                x = x + dt * (inputs[call] - x)
                elapsed += dt
            assert np.array_equal(x, outputs[call])


FIELD_SOURCE = '''
import json
import numpy as np
import precice
participant = precice.Participant("Source", "../config.xml", 0, 1)
x, y = np.meshgrid(np.linspace(0.0, 1.0, 5), np.linspace(0.0, 1.0, 4))
grid = np.column_stack([x.ravel(), y.ravel()])
ids = participant.set_mesh_vertices("Source-Mesh", grid)
CONNECT
participant.initialize()
t = 0.0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    t += dt
    participant.write_data("Source-Mesh", "T", ids, t + 2.0 * grid[:, 0] + 3.0 * grid[:, 1] ** 2)
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
'''
FIELD_TARGET = '''
import json
import numpy as np
import precice
participant = precice.Participant("Target", "../config.xml", 0, 1)
points = np.array([[0.1, 0.1], [0.55, 0.4], [0.9, 0.95], [1.2, 0.45]])
ids = participant.set_mesh_vertices("Target-Mesh", points)
participant.initialize()
seen = []
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    seen.append(participant.read_data("Target-Mesh", "T", ids, dt).tolist())
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump(seen, open("seen.json", "w"))
'''
FIELD_CONFIG = '''<?xml version="1.0"?>
<precice-configuration>
  <data:scalar name="T"/>
  <mesh name="Source-Mesh" dimensions="2"><use-data name="T"/></mesh>
  <mesh name="Target-Mesh" dimensions="2"><use-data name="T"/></mesh>
  <participant name="Source"><provide-mesh name="Source-Mesh"/><write-data name="T" mesh="Source-Mesh"/></participant>
  <participant name="Target">
    <provide-mesh name="Target-Mesh"/><receive-mesh name="Source-Mesh" from="Source"/>
    <read-data name="T" mesh="Target-Mesh"/>
    <mapping:MAPPING direction="read" from="Source-Mesh" to="Target-Mesh" constraint="consistent"/>
  </participant>
  <m2n:sockets acceptor="Source" connector="Target" exchange-directory=".."/>
  <coupling-scheme:serial-explicit>
    <participants first="Source" second="Target"/>
    <max-time-windows value="2"/>
    <time-window-size value="1.0"/>
    <exchange data="T" mesh="Source-Mesh" from="Source" to="Target"/>
  </coupling-scheme:serial-explicit>
</precice-configuration>
'''
QUADS = """if participant.requires_mesh_connectivity_for("Source-Mesh"):
    corner = np.arange(20).reshape(4, 5)[:-1, :-1].ravel()
    participant.set_mesh_quads("Source-Mesh", np.column_stack([corner, corner + 1, corner + 6, corner + 5]))"""
EDGES = """if participant.requires_mesh_connectivity_for("Source-Mesh"):
    top = np.arange(15, 20)
    participant.set_mesh_edges("Source-Mesh", np.column_stack([top[:-1], top[1:]]))"""


@pytest.mark.parametrize("ending", ["finishes", "crashes"])
def test_what_a_participant_started_is_stopped_with_it(tmp_path, ending):
    """A participant that starts a child (a `sleep 300`) and then finishes, or crashes: the child does not
    outlive the run (its process group is signalled, though the participant itself is gone)."""
    source = FIELD_SOURCE.replace("CONNECT", "import subprocess\nchild = subprocess.Popen(['sleep', '300'])\n"
                                             "open('child.pid', 'w').write(str(child.pid))")
    if ending == "crashes":
        source = source.replace("participant.finalize()", "raise SystemExit(3)")
    case_file = write_case(tmp_path, {"Source": source, "Target": FIELD_TARGET},
                           FIELD_CONFIG.replace("MAPPING", "nearest-neighbor"))
    try:
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    except CosimError:
        assert ending == "crashes"
    child = int((tmp_path / "Source" / "child.pid").read_text())
    wait_for(lambda: not alive(child), "the participant's child to stop with the run", timeout=10.0)


def test_a_launched_participant_cannot_say_hello_as_another(tmp_path):
    """The process started for Source says hello as Target: refused, and the run stops naming Source (it blamed
    the real Target, which then found its name taken)."""
    case_file = write_case(tmp_path, {"Source": FIELD_SOURCE.replace('Participant("Source"', 'Participant("Target"')
                                      .replace("CONNECT", ""), "Target": FIELD_TARGET},
                           FIELD_CONFIG.replace("MAPPING", "nearest-neighbor"))
    with pytest.raises(CosimError, match="component 'Source'.*this process was started as participant 'Source' and "
                                         "says hello as 'Target'"):
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert children_of(os.getpid()) == []


def exact_field(points: np.ndarray, t: float) -> np.ndarray:
    return t + 2.0 * points[:, 0] + 3.0 * points[:, 1] ** 2


@pytest.mark.parametrize(("mapping", "connect"), [("linear-cell-interpolation", QUADS),
                                                  ("nearest-projection", EDGES), ("linear-cell-interpolation", "")])
def test_element_mappings_take_the_connectivity_participants_give(tmp_path, mapping, connect):
    """A participant that asks requires_mesh_connectivity_for and gives quads (split into triangles) or edges: a
    linear-cell-interpolation reads, inside the cells, the barycentric interpolation of its grid's values (exact in
    x, linear in y between rows); outside, the projection on the boundary edges; a nearest-projection onto the grid's
    top edges interpolates along them (beyond their ends, the nearest vertex); with no connectivity, the nearest
    vertex, as preCICE falls back."""
    for name, text in (("Source/source.py", FIELD_SOURCE.replace("CONNECT", connect)),
                       ("Target/target.py", FIELD_TARGET), ("config.xml", FIELD_CONFIG.replace("MAPPING", mapping)),
                       ("case.toml", '[precice]\nconfig = "config.xml"\n[participants.Source]\ncommand = '
                                     '"python3 source.py"\ncwd = "Source"\n[participants.Target]\ncommand = '
                                     '"python3 target.py"\ncwd = "Target"\n')):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    run_scene(load_scene(tmp_path / "case.toml"), tmp_path / "out", progress=False)
    seen = np.array(json.loads((tmp_path / "Target" / "seen.json").read_text()))
    points = np.array([[0.1, 0.1], [0.55, 0.4], [0.9, 0.95], [1.2, 0.45]])
    rows = np.linspace(0.0, 1.0, 4)
    if mapping == "linear-cell-interpolation" and connect:
        # piecewise linear in y between the grid's rows; the last point, beyond x = 1, on the right edge
        y = points[:, 1]
        below = np.clip(np.searchsorted(rows, y) - 1, 0, 2)
        square = 3.0 * (rows[below] ** 2 + (y - rows[below]) * (rows[below] + rows[below + 1]))
        expected = 2.0 * np.minimum(points[:, 0], 1.0) + square
    elif mapping == "nearest-projection":
        expected = 2.0 * points[:, 0] + 3.0           # projected onto the top edges, y = 1 ...
        expected[3] = 2.0 + 3.0 * rows[1] ** 2        # ... but beyond their end: the nearest vertex, (1, 1/3)
    else:
        x, y = np.meshgrid(np.linspace(0.0, 1.0, 5), rows)
        grid = np.column_stack([x.ravel(), y.ravel()])
        nearest = grid[np.argmin(np.linalg.norm(points[:, None] - grid[None], axis=2), axis=1)]
        expected = 2.0 * nearest[:, 0] + 3.0 * nearest[:, 1] ** 2
    for window, values in enumerate(seen, start=1):
        np.testing.assert_allclose(values, expected + window, atol=1e-12)


DIRECT_PROVIDER = '''
import json
import numpy as np
import precice
participant = precice.Participant("Provider", "../config.xml", 0, 1)
points = np.column_stack([np.linspace(0.0, 1.0, 11), np.zeros(11)])
ids = participant.set_mesh_vertices("Provider-Mesh", points)
participant.initialize()
seen = []
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    seen.append(participant.read_data("Provider-Mesh", "D", ids, dt).tolist())
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump(seen, open("seen.json", "w"))
'''
DIRECT_ACCESSOR = '''
import json
import numpy as np
import precice
participant = precice.Participant("Accessor", "../config.xml", 0, 1)
participant.set_mesh_vertices("Accessor-Mesh", np.zeros((1, 2)))
participant.set_mesh_access_region("Provider-Mesh", [0.25, 0.75, -1.0, 1.0])
participant.initialize()
ids, coordinates = participant.get_mesh_vertex_ids_and_coordinates("Provider-Mesh")
size = participant.get_mesh_vertex_size("Provider-Mesh")
t = 0.0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    t += dt
    participant.write_data("Provider-Mesh", "D", ids, t + coordinates[:, 0] ** 2)
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump({"ids": ids.tolist(), "size": size}, open("region.json", "w"))
'''
DIRECT_CONFIG = '''<?xml version="1.0"?>
<precice-configuration experimental="true">
  <data:scalar name="D"/>
  <mesh name="Provider-Mesh" dimensions="2"><use-data name="D"/></mesh>
  <mesh name="Accessor-Mesh" dimensions="2"><use-data name="D"/></mesh>
  <participant name="Accessor">
    <provide-mesh name="Accessor-Mesh"/><receive-mesh name="Provider-Mesh" from="Provider" api-access="true"/>
    <write-data name="D" mesh="Provider-Mesh"/>
  </participant>
  <participant name="Provider"><provide-mesh name="Provider-Mesh"/><read-data name="D" mesh="Provider-Mesh"/></participant>
  <m2n:sockets acceptor="Accessor" connector="Provider" exchange-directory=".."/>
  <coupling-scheme:serial-explicit>
    <participants first="Accessor" second="Provider"/>
    <max-time-windows value="2"/>
    <time-window-size value="1.0"/>
    <exchange data="D" mesh="Provider-Mesh" from="Accessor" to="Provider"/>
  </coupling-scheme:serial-explicit>
</precice-configuration>
'''


JIT_PROVIDER = '''
import json
import numpy as np
import precice
participant = precice.Participant("A", "../config.xml", 0, 1)
grid = np.column_stack([np.linspace(0, 1, 6), np.zeros(6)])
ids = participant.set_mesh_vertices("A-Mesh", grid)
participant.initialize()
seen, t = [], 0.0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    t += dt
    participant.write_data("A-Mesh", "V", ids, 10 * t + grid[:, 0])
    seen.append(participant.read_data("A-Mesh", "F", ids, dt).tolist())
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump(seen, open("seen.json", "w"))
'''
JIT_PARTICLES = '''
import json
import numpy as np
import precice
participant = precice.Participant("B", "../config.xml", 0, 1)
participant.set_mesh_access_region("A-Mesh", [-1, 2, -1, 1])
participant.initialize()
points, reads = np.array([[0.12, 0.0], [0.5, 0.1], [0.93, 0.0]]), []
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    reads.append(participant.map_and_read_data("A-Mesh", "V", points, dt).tolist())
    participant.write_and_map_data("A-Mesh", "F", points, np.array([1.0, 2.0, 3.0]))
    participant.write_and_map_data("A-Mesh", "F", points[:1], np.array([5.0]))
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump(reads, open("reads.json", "w"))
'''
JIT_CONFIG = '''<?xml version="1.0" encoding="UTF-8" ?>
<precice-configuration experimental="true">
  <data:scalar name="V" /><data:scalar name="F" />
  <mesh name="A-Mesh" dimensions="2"><use-data name="V" /><use-data name="F" /></mesh>
  <participant name="A"><provide-mesh name="A-Mesh" /><write-data name="V" mesh="A-Mesh" />
    <read-data name="F" mesh="A-Mesh" /></participant>
  <participant name="B"><receive-mesh name="A-Mesh" from="A" api-access="true" />
    <read-data name="V" mesh="A-Mesh" /><write-data name="F" mesh="A-Mesh" />
    <mapping:nearest-neighbor direction="read" from="A-Mesh" constraint="consistent" />
    <mapping:nearest-neighbor direction="write" to="A-Mesh" constraint="conservative" />
  </participant>
  <m2n:sockets acceptor="A" connector="B" exchange-directory="." />
  <coupling-scheme:serial-explicit>
    <participants first="A" second="B" /><max-time-windows value="3" /><time-window-size value="1.0" />
    <exchange data="V" mesh="A-Mesh" from="A" to="B" />
    <exchange data="F" mesh="A-Mesh" from="B" to="A" />
  </coupling-scheme:serial-explicit>
</precice-configuration>
'''


def test_just_in_time_mapping_reads_and_writes_at_coordinates_as_precice_does(tmp_path):
    """Particles read the provider's data at their coordinates (nearest vertex) and write onto its nearest vertices,
    twice in a window (the values add up, and each window starts from zero): the values preCICE 3.4.1 gives with
    the same participants and configuration."""
    case_file = write_case(tmp_path, {"A": JIT_PROVIDER, "B": JIT_PARTICLES}, JIT_CONFIG)
    run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert json.loads((tmp_path / "B" / "reads.json").read_text()) == [[10.2, 10.4, 11.0], [20.2, 20.4, 21.0],
                                                                         [30.2, 30.4, 31.0]]
    assert json.loads((tmp_path / "A" / "seen.json").read_text()) == [[0.0] * 6, [0.0, 6.0, 2.0, 0.0, 0.0, 3.0],
                                                                        [0.0, 6.0, 2.0, 0.0, 0.0, 3.0]]


@pytest.mark.parametrize(("change", "message"), [
    (('<mapping:nearest-neighbor direction="read" from="A-Mesh" constraint="consistent" />',
      '<mapping:rbf-pum-direct direction="read" from="A-Mesh" constraint="consistent"><basis-function:'
      'thin-plate-splines /></mapping:rbf-pum-direct>'), "a just-in-time mapping is nearest-neighbor"),
    (('api-access="true"', ''), "on mesh 'A-Mesh', which it receives without direct-access"),
    (('direction="read" from="A-Mesh"', 'direction="read" to="A-Mesh"'), "the attribute 'from' is required"),
])
def test_a_just_in_time_mapping_cosim_does_not_do_is_refused_in_one_line(tmp_path, change, message):
    (tmp_path / "config.xml").write_text(JIT_CONFIG.replace(*change))
    with pytest.raises(SceneError, match=re.escape(message)):
        read_config(tmp_path / "config.xml")


def write_case(folder: Path, participants: dict[str, str], config: str) -> Path:
    """A case of participants written here, each in its folder beside ``config.xml``."""
    lines = ['[precice]', 'config = "config.xml"']
    for name, text in participants.items():
        (folder / name).mkdir(parents=True, exist_ok=True)
        (folder / name / "participant.py").write_text(text)
        lines += [f"[participants.{name}]", 'command = "python3 participant.py"', f'cwd = "{name}"']
    (folder / "config.xml").write_text(config)
    (folder / "case.toml").write_text("\n".join(lines) + "\n")
    return folder / "case.toml"


def test_a_participant_writes_directly_on_the_received_mesh_in_its_access_region(tmp_path):
    """preCICE's direct access: the accessor sees the provider's vertices in its box (ids 3 to 7 of 11), writes
    its data there, and the provider reads it without a mapping (zero outside the box)."""
    case_file = write_case(tmp_path, {"Provider": DIRECT_PROVIDER, "Accessor": DIRECT_ACCESSOR}, DIRECT_CONFIG)
    run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    region = json.loads((tmp_path / "Accessor" / "region.json").read_text())
    assert region == {"ids": [3, 4, 5, 6, 7], "size": 5}
    seen = np.array(json.loads((tmp_path / "Provider" / "seen.json").read_text()))
    x = np.linspace(0.0, 1.0, 11)
    for window, values in enumerate(seen, start=1):
        expected = np.where((x >= 0.25) & (x <= 0.75), window + x ** 2, 0.0)
        np.testing.assert_allclose(values, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("change", "message"), [
    (("api-access=\"true\"", ""), "which it receives without direct-access=\"true\""),
])
def test_data_on_a_received_mesh_without_direct_access_is_refused(tmp_path, change, message):
    (tmp_path / "config.xml").write_text(DIRECT_CONFIG.replace(*change))
    with pytest.raises(SceneError, match=re.escape(message)):
        read_config(tmp_path / "config.xml")


@pytest.mark.parametrize(("change", "message"), [
    (('participant.set_mesh_access_region("Provider-Mesh", [0.25, 0.75, -1.0, 1.0])\n', ""),
     "no access region is set on mesh 'Provider-Mesh' (set_mesh_access_region before initialize)"),
    (("participant.initialize()\nids, coordinates", "ids, coordinates"),
     "a received mesh's vertices are known after initialize"),
    (("[0.25, 0.75, -1.0, 1.0]", "[0.25, 0.75]"), "the bounding box has 2 values; expected 4 finite ones"),
])
def test_direct_access_misused_is_named_in_one_line(tmp_path, change, message):
    case_file = write_case(tmp_path, {"Provider": DIRECT_PROVIDER, "Accessor": DIRECT_ACCESSOR.replace(*change)},
                           DIRECT_CONFIG)
    with pytest.raises(CosimError) as failed:
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert message in str(failed.value)
    assert children_of(os.getpid()) == []


@pytest.fixture(scope="module")
def participant_run(tmp_path_factory) -> Path:
    return case(tmp_path_factory.mktemp("participants") / "run")


def test_a_precice_case_draws_no_run_plot_and_cosim_plot_draws_it_on_request(participant_run, tmp_path, capsys):
    """preCICE draws nothing at a run's end, and neither does a preCICE case (output.run_plot = false: the run's end
    does not wait for matplotlib); ``cosim plot DIR --run`` draws run.png from results.h5, the field the case plots
    (its first exchanged data) over its windows; it writes a PNG only, never over the run's files."""
    from matplotlib.image import imread
    assert not (participant_run / "run.png").exists()
    with RunResults(participant_run) as results:
        assert json.loads(results.attributes["scene_resolved"])["output"]["run_plot"] is False
    assert main(["plot", str(participant_run), "--run", "--out", str(tmp_path / "run.png")]) == 0
    assert imread(tmp_path / "run.png").shape[:2] == (660, 990)          # 9 x 6 inches at 110 dpi
    for out in (participant_run / "results.h5", tmp_path / "run.pdf"):
        assert main(["plot", str(participant_run), "--run", "--out", str(out)]) == 2
        assert "the run plot is written as a PNG" in capsys.readouterr().err
    assert main(["plot", str(tmp_path), "--run"]) == 2
    assert "holds no run's results" in capsys.readouterr().err


def train(results: Path, model: Path, component: str, inputs: str, outputs: str) -> None:
    assert main(["train", str(results / "results.h5"), "--config", str(ROOT / "rom_configs" / "tube_rom.toml"),
                 "--set", "snapshots.t_max=1.2", "--set", f"snapshots.component={component}",
                 "--set", f"snapshots.input={inputs}", "--set", f"snapshots.output={outputs}",
                 "--out", str(model)]) == 0


def test_the_solid_participant_swapped_for_its_rom_and_its_fmu_by_one_line_runs_as_the_native_rom(
        native_run, participant_run, tmp_path, capsys):
    """A ROM trained on the participants' recorded run is the native run's ROM, array for array; swapped in for the
    solid participant by one line (and its FMU by another), the unmodified fluid participant runs as the native
    ROM-FOM and FMU-FOM runs do, bit for bit."""
    train(native_run, tmp_path / "native.npz", "solid", "pressure", "section")
    train(participant_run, tmp_path / "participant.npz", "Solid", "Pressure", "CrossSectionLength")
    with np.load(tmp_path / "native.npz") as a, np.load(tmp_path / "participant.npz") as b:
        numeric = [k for k in a.files if a[k].dtype.kind == "f" and not k.startswith("mesh:")]   # meshes: their names
        assert numeric and all(np.array_equal(a[k], b[k]) for k in numeric)
    native_rom = native(tmp_path / "native_rom", "components.solid.backend=rom",
                        f"components.solid.rom.model={tmp_path / 'native.npz'}", "components.solid.rom.switch_time=0")
    swapped = case(tmp_path / "swapped", EXAMPLE / "case.toml", "participants.Solid.backend=rom",
                   f"participants.Solid.rom.model={tmp_path / 'participant.npz'}")
    same_run(native_rom, swapped)
    with RunResults(swapped) as results:
        assert results.component_names() == ["Fluid", "Solid_rom"]
    assert main(["export-fmu", str(tmp_path / "participant.npz"), "--out", str(tmp_path / "solid.fmu")]) == 0
    fmu = case(tmp_path / "fmu", EXAMPLE / "case.toml", "participants.Solid.backend=fmu",
               f"participants.Solid.fmu.path={tmp_path / 'solid.fmu'}")
    same_run(native_rom, fmu)
    capsys.readouterr()


def test_participants_started_by_hand_start_their_coupler_and_run_as_the_native_scene(tmp_path):
    """Two terminals, one participant in each, no third command: the first participant starts the coupler (cosim on
    PATH), the second finds it next to the configuration; the run is the native scene's, and nothing is left."""
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu", "cosim-run"))
    config = tmp_path / "case" / "precice-config.xml"
    config.write_text(config.read_text().replace('<max-time value="120" />', '<max-time value="1" />'))
    environment = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
                   "PYTHONPATH": os.pathsep.join([str(SHIM), str(ROOT)])}
    environment.pop("COSIM_PARTICIPANT_ENDPOINT", None)
    fluid = subprocess.Popen([sys.executable, "FluidSolver.py", "../precice-config.xml", "1"],
                             cwd=tmp_path / "case" / "fluid-python", env=environment, stderr=subprocess.PIPE, text=True)
    solid = subprocess.Popen([sys.executable, "SolidSolver.py", "../precice-config.xml"],
                             cwd=tmp_path / "case" / "solid-python", env=environment, stderr=subprocess.PIPE, text=True)
    for participant in (fluid, solid):
        _, err = participant.communicate(timeout=120)
        assert participant.returncode == 0, err
    runs = list((tmp_path / "case" / "cosim-run" / "runs").iterdir())
    assert len(runs) == 1
    wait_for(lambda: read_status(runs[0]).get("state") == "finished", "the coupler to finish")
    wait_for(lambda: not (tmp_path / "case" / "cosim-run" / "coupler.json").exists(), "the rendezvous to go")
    with RunResults(runs[0]) as by_hand, RunResults(native(tmp_path / "native", "time.end=1")) as reference:
        assert np.array_equal(by_hand.windows.iterations, reference.windows.iterations)
        assert by_hand.fields()["Pressure"].tobytes() == reference.fields()["pressure"].tobytes()


OLD_NUMPY = "1.26.4"


@pytest.fixture(scope="module")
def old_numpy_python() -> Path:
    """A second venv with numpy 1.26, pyzmq and msgpack (kept in ~/.cache/cosim across runs), and the participant
    package pip-installed into it from this checkout."""
    venv = Path.home() / ".cache" / "cosim" / "venvs" / f"participant-numpy-{OLD_NUMPY}"
    python = venv / "bin" / "python"
    if not (venv / ".ready").exists():
        shutil.rmtree(venv, ignore_errors=True)
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
        done = subprocess.run([str(python), "-m", "pip", "install", "--quiet", f"numpy=={OLD_NUMPY}", "pyzmq",
                               "msgpack"], capture_output=True, text=True, timeout=600)
        if done.returncode != 0:
            pytest.skip(f"numpy {OLD_NUMPY} cannot be installed here: {done.stderr.strip().splitlines()[-1:]}")
        (venv / ".ready").touch()
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps", "--force-reinstall", str(SHIM)],
                   check=True, capture_output=True, timeout=300)
    return python


def test_a_participant_in_its_own_venv_with_numpy_1_runs(old_numpy_python, tmp_path):
    """The participant package installed alone, beside numpy 1.26, couples a participant with cosim's coupler."""
    for name, text in (("A/A.py", SUBCYCLING.replace('json.dump(seen, open("seen.json", "w"))',
                                                     'json.dump([np.__version__, precice.__file__, seen], '
                                                     'open("seen.json", "w"))')),
                       ("B/B.py", PARTNER), ("config.xml", SUBCYCLING_CONFIG),
                       ("case.toml", f'[precice]\nconfig = "config.xml"\n[participants.A]\ncommand = '
                                     f'"{old_numpy_python} A.py"\ncwd = "A"\n[participants.B]\n'
                                     'command = "python3 B.py"\ncwd = "B"\n')):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    environment_path = os.environ.get("PYTHONPATH", "")
    try:       # the participant's own venv: nothing of this checkout on its path but what cosim gives every participant
        os.environ["PYTHONPATH"] = ""
        summary = run_scene(load_scene(tmp_path / "case.toml"), tmp_path / "out", progress=False)
    finally:
        os.environ["PYTHONPATH"] = environment_path
    import json
    version, where, seen = json.loads((tmp_path / "A" / "seen.json").read_text())
    assert version == OLD_NUMPY and summary.windows == 10 and len(seen) == 4 * summary.iterations
    assert Path(where).is_relative_to(SHIM)          # cosim puts its own package first for the participants it starts
    installed = subprocess.run([str(old_numpy_python), "-c", "import precice, numpy; print(precice.__file__, "
                                "numpy.__version__, precice.Participant, precice.Interface)"],
                               capture_output=True, text=True, env={"PATH": os.environ["PATH"]}, check=True).stdout
    assert "site-packages" in installed and OLD_NUMPY in installed     # the package installed alone imports there


def example_with_watch_point(folder: Path, write: str, mesh: str, name: str, coordinate: str) -> Path:
    """A copy of the example whose configuration watches ``mesh`` at ``coordinate`` (after its ``write`` data);
    its case file."""
    shutil.copytree(EXAMPLE, folder, ignore=shutil.ignore_patterns("*.npz", "*.fmu", "cosim-run"))
    config = folder / "precice-config.xml"
    tag = f'<write-data name="{write}" mesh="{mesh}" />'
    config.write_text(config.read_text().replace(
        tag, f'{tag}\n    <watch-point mesh="{mesh}" name="{name}" coordinate="{coordinate}" />'))
    return folder / "case.toml"


def watch_point_log(path: Path) -> tuple[list[str], np.ndarray]:
    """A preCICE watch point log: its columns' names and its rows."""
    header, *rows = path.read_text().splitlines()
    return header.split(), np.array([[float(v) for v in row.split()] for row in rows])


def test_a_watch_point_writes_precices_log_of_the_data_at_its_vertex(tmp_path):
    out = case(tmp_path / "out", example_with_watch_point(tmp_path / "case", "Pressure", "Fluid-Nodes", "Inlet",
                                                          "0.04;0.0"), "time.end=1")
    header, table = watch_point_log(out / "precice-Fluid-watchpoint-Inlet.log")
    assert header == ["Time", "Coordinate0", "Coordinate1", "Pressure", "CrossSectionLength"]
    with RunResults(out) as results:
        assert np.array_equal(table[:, 0], results.windows.time)
        assert np.array_equal(table[:, 3], results.fields()["Pressure"][:, 0])          # the vertex nearest x = 0.04
        used = results.calls("Fluid", converged_only=True).inputs["CrossSectionLength"]   # what the fluid read
        assert np.array_equal(table[:, 4], used[:, 0])



def test_a_watch_point_on_a_participant_swapped_for_its_rom_watches_the_rom(participant_run, tmp_path):
    """The solid participant's watch point, the solid served by its ROM: the log has the participant's name and the
    ROM's calls (the writer once looked for a component 'Solid' beside 'Solid_rom', and the run's closing then
    reported 'Bad file descriptor' instead)."""
    train(participant_run, tmp_path / "model.npz", "Solid", "Pressure", "CrossSectionLength")
    case_file = example_with_watch_point(tmp_path / "case", "CrossSectionLength", "Solid-Nodes", "Outlet", "10.0;0.0")
    out = case(tmp_path / "out", case_file, "participants.Solid.backend=rom",
               f"participants.Solid.rom.model={tmp_path / 'model.npz'}")
    header, table = watch_point_log(out / "precice-Solid-watchpoint-Outlet.log")
    assert sorted(p.name for p in out.glob("precice-*-*.log")) == [       # preCICE's logs: the participants' names
        "precice-Fluid-iterations.log", "precice-Solid-convergence.log", "precice-Solid-iterations.log",
        "precice-Solid-watchpoint-Outlet.log"]
    with RunResults(out) as results:
        assert results.component_names() == ["Fluid", "Solid_rom"]
        served = results.calls("Solid", converged_only=True)
        assert np.array_equal(table[:, 0], results.windows.time)
        assert np.array_equal(table[:, header.index("CrossSectionLength")], served.outputs[
            "CrossSectionLength"][:, -1])                                   # the last vertex, x = 10
        assert np.array_equal(table[:, header.index("Pressure")], served.inputs["Pressure"][:, -1])


# --- what pyprecice and preCICE do that unmodified participants rely on ----------------------------------------------
def run_fluid_variant(tmp_path, name: str, old: str, new: str, *settings: str) -> tuple[int, Path]:
    """The test participant with ``old`` replaced by ``new``, against the example's solid, for ten windows."""
    assert old in PARTICIPANT
    folder = tmp_path / name
    folder.mkdir()
    (folder / "Fluid.py").write_text(PARTICIPANT.replace(old, new, 1))
    out = tmp_path / f"{name}-run"
    code = main(["run", str(EXAMPLE / "case.toml"), "--out", str(out), "--quiet", "--set", "time.end=1",
                 "--set", f"participants.Fluid.command=python3 Fluid.py {EXAMPLE / 'precice-config.xml'}",
                 "--set", f"participants.Fluid.cwd={folder}", *settings])
    return code, out


@pytest.mark.parametrize("ending", ["", "del participant"], ids=["exits", "collected"])
def test_a_participant_that_never_calls_finalize_is_finalized_as_precices_destructor_does(tmp_path, capsys, ending):
    """preCICE's tutorials' elastic tube ends without finalize(): the participant's exit (or its collection)
    finalizes it, and the run ends as with finalize()."""
    code, out = run_fluid_variant(tmp_path, "fluid", "participant.finalize()", ending)
    assert code == 0, capsys.readouterr().err
    with RunResults(out / "results.h5") as results:
        assert len(results.windows) == 10 and results.windows.converged.all()
    assert children_of(os.getpid()) == []


def test_scalar_data_written_as_any_array_of_its_values_is_taken_as_pyprecice_takes_it(tmp_path, capsys):
    """A column (N, 1) of scalar data, as preCICE's FMI runner writes it, is the same data as (N,)."""
    write = 'participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, pressure)'
    code, plain = run_fluid_variant(tmp_path, "plain", write, write)
    assert code == 0, capsys.readouterr().err
    code, column = run_fluid_variant(tmp_path, "column", write, write.replace("pressure)", "pressure[:, None])"))
    assert code == 0, capsys.readouterr().err
    with RunResults(plain / "results.h5") as a, RunResults(column / "results.h5") as b:
        assert a.fields()["Pressure"].tobytes() == b.fields()["Pressure"].tobytes()
        assert np.array_equal(a.windows.iterations, b.windows.iterations)


def test_get_version_information_gives_bytes_that_start_with_the_version():
    """As pyprecice: tools decode it and read the version before the first ';'."""
    code = "import precice; v = precice.get_version_information(); print(type(v).__name__, v.decode().split(';')[0])"
    done = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(SHIM)},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    kind, version = done.stdout.split()
    assert kind == "bytes" and version.split(".")[0] == "3" and len(version.split(".")) == 3


GROWING = """
import precice
participant = precice.Participant("NAME", "../config.xml", 0, 1)
ids = participant.set_mesh_vertices("NAME-Mesh", [[0.0, 0.0]])
participant.initialize()
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()
    dt = participant.get_max_time_step_size()
    got = participant.read_data("NAME-Mesh", "READ", ids, dt)
    participant.write_data("NAME-Mesh", "WRITE", ids, GAIN * got + 1.0)
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
"""


def test_a_window_whose_residual_grows_is_accepted_at_max_iterations_as_precice_does(tmp_path):
    """x -> 2x + 1 iterated without relaxation: the residual doubles every iteration, 2^11 times in the window's 12.
    preCICE watches no growth and goes on after max-iterations; so does a preCICE case under cosim (a native scene
    stops it as diverged). preCICE's elastic beam in CalculiX grows so in its first window."""
    config = SUBCYCLING_CONFIG.replace('<max-iterations value="30"/>', '<max-iterations value="12"/>').replace(
        '<max-time-windows value="10"/>', '<max-time-windows value="2"/>').replace(
        '<acceleration:IQN-ILS>\n      <data name="B" mesh="B-Mesh"/><initial-relaxation value="0.5"/>\n    '
        '</acceleration:IQN-ILS>', '<acceleration:constant><relaxation value="1.0"/></acceleration:constant>')
    assert "acceleration:constant" in config and 'value="12"' in config
    case_file = write_case(tmp_path, {
        "A": GROWING.replace("NAME", "A").replace("READ", "B").replace("WRITE", "X").replace("GAIN", "1.0"),
        "B": GROWING.replace("NAME", "B").replace("READ", "X").replace("WRITE", "B").replace("GAIN", "2.0")}, config)
    summary = run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert summary.windows == 2 and summary.unconverged == 2 and summary.iterations == 24
    with RunResults(tmp_path / "out") as results:
        _, norms = results.residuals()
        assert norms[11] > 1e3 * norms[0]          # what a native scene's divergence_factor (1e3) stops
    with pytest.raises(CosimError, match="diverged: the coupling residual grew"):
        run_scene(load_scene(case_file, ["coupling.divergence_factor=1e3"]), tmp_path / "native", progress=False)


def test_constant_relaxation_naming_no_data_relaxes_what_the_scheme_iterates(tmp_path):
    """preCICE's <acceleration:constant> without <data> relaxes all of the scheme's iterated data: here the data the
    second participant sends (the heat case's config lists none)."""
    start = TUBE_CONFIG.index("<acceleration:IQN-ILS>")
    end = TUBE_CONFIG.index("</acceleration:IQN-ILS>") + len("</acceleration:IQN-ILS>")
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu"))
    (tmp_path / "case" / "precice-config.xml").write_text(
        TUBE_CONFIG[:start] + '<acceleration:constant><relaxation value="0.5" /></acceleration:constant>'
        + TUBE_CONFIG[end:])
    acceleration = load_scene(tmp_path / "case" / "case.toml")["coupling"]["acceleration"]
    assert (acceleration["type"], acceleration["data"], acceleration["relaxation"]) == \
        ("constant", ["CrossSectionLength"], 0.5)


def test_a_watch_point_on_a_subcycling_participant_gives_a_row_per_window(tmp_path):
    """A takes four steps a window and sends each (substeps): its watch point has the window's end, a row a window
    (the resonant circuit's case: it once failed on 222 calls for 10 windows)."""
    config = SUBCYCLING_CONFIG.replace('<exchange data="X" mesh="A-Mesh" from="A" to="B" substeps="false"/>',
                                       '<exchange data="X" mesh="A-Mesh" from="A" to="B" substeps="true"/>')
    config = config.replace('<write-data name="X" mesh="A-Mesh"/>',
                            '<write-data name="X" mesh="A-Mesh"/><watch-point mesh="A-Mesh" name="End" '
                            'coordinate="1.0;0.0"/>')
    assert config.count("substeps=\"true\"") == 1 and "watch-point" in config
    partner = PARTNER.replace("    t += dt", "    t = t if participant.requires_reading_checkpoint() else t + dt")
    assert partner != PARTNER            # B repeats its window's time: the windows converge
    for name, text in (("A/A.py", SUBCYCLING), ("B/B.py", partner), ("config.xml", config),
                       ("case.toml", '[precice]\nconfig = "config.xml"\n[participants.A]\ncommand = "python3 A.py"\n'
                                     'cwd = "A"\n[participants.B]\ncommand = "python3 B.py"\ncwd = "B"\n')):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    run_scene(load_scene(tmp_path / "case.toml"), tmp_path / "out", progress=False)
    header, table = watch_point_log(tmp_path / "out" / "precice-A-watchpoint-End.log")
    with RunResults(tmp_path / "out") as results:
        assert results.windows.converged.all()
        assert len(results.calls("A", converged_only=True)) == 4 * len(results.windows)   # a call a step
        assert np.array_equal(table[:, 0], results.windows.time)
        assert np.array_equal(table[:, header.index("X")], results.fields()["X"][:, 1])   # x = 1's vertex


WRAP = '''
core = participant._core
send = core._request
def _request(op, args=None, arrays=None):
    if op == "{op}":
        args, arrays = {change}
    return send(op, args, arrays)
core._request = _request
'''
RAW_WIRE = '''
import msgpack, precice._wire
def raw_encode(header, arrays=None):          # each array with its own dtype, as a foreign client may send it
    arrays = {name: np.ascontiguousarray(value) for name, value in (arrays or {}).items()}
    specs = [{"name": name, "dtype": a.dtype.name, "shape": list(a.shape)} for name, a in arrays.items()]
    return [msgpack.packb(dict(header, v=1, arrays=specs), use_bin_type=True)] + [a.tobytes() for a in arrays.values()]
precice._wire.encode = raw_encode
'''
MISBEHAVING = [   # a participant that holds the run's token and sends what no participant package sends
    ("a pid that is no number", "import precice", 'import precice, os\nos.getpid = lambda: "abc"',
     "its hello gave the pid 'abc', not a process number"),
    ("a one-dimensional mesh", "participant.write_data(\"Fluid-Nodes\", \"Pressure\", vertex_ids, fluid.get_values",
     "participant._core.vertices['Fluid-Nodes'] = [coords[:, 0].copy()]\n"
     "participant.write_data(\"Fluid-Nodes\", \"Pressure\", vertex_ids, fluid.get_values",
     "gave the vertices of mesh 'Fluid-Nodes' as float64 of shape (101,); expected float64 of shape (n, 2)"),
    ("a NaN vertex", "participant.write_data(\"Fluid-Nodes\", \"Pressure\", vertex_ids, fluid.get_values",
     "participant._core.vertices['Fluid-Nodes'][0][3, 1] = float('nan')\n"
     "participant.write_data(\"Fluid-Nodes\", \"Pressure\", vertex_ids, fluid.get_values",
     "gave vertices of mesh 'Fluid-Nodes' that are not finite"),
    ("boolean data", "participant.initialize()", "participant.initialize()" + RAW_WIRE + WRAP.format(
        op="advance", change="args, {k: v > 0 for k, v in arrays.items()}"), "wrote 'Pressure' as bool"),
    ("integer data", "participant.initialize()", "participant.initialize()" + WRAP.format(
        op="advance", change="args, {k: v.astype(int) for k, v in arrays.items()}"), "wrote 'Pressure' as int64"),
    ("float32 data", "participant.initialize()", "participant.initialize()" + RAW_WIRE + WRAP.format(
        op="advance", change="args, {k: v.astype('float32') for k, v in arrays.items()}"),
     "wrote 'Pressure' as float32"),
]


@pytest.mark.parametrize("what, old, new, message", MISBEHAVING, ids=[m[0] for m in MISBEHAVING])
def test_a_participant_sending_what_no_participant_sends_stops_the_run_in_one_line(tmp_path, capsys, what, old, new,
                                                                                 message):
    """The coupler checks what a participant holding the run's token sends: a bad pid, meshes that are not (n, dim)
    finite doubles and data that is not float64 are named, where they crashed the coupler or the other participant."""
    code, _ = run_fluid_variant(tmp_path, "fluid", old, new, "--set", "participants.Fluid.startup_timeout=20")
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert "component 'Fluid'" in err and message in err, err
    assert children_of(os.getpid()) == []


def test_timings_that_are_no_numbers_are_left_out_not_a_crash(tmp_path, capsys):
    new = "participant.initialize()" + WRAP.format(
        op="advance", change='{**(args or {}), "compute_seconds": "x", "cpu_seconds": None}, arrays')
    code, out = run_fluid_variant(tmp_path, "fluid", "participant.initialize()", new)
    assert code == 0, capsys.readouterr().err
    with RunResults(out / "results.h5") as results:
        assert results.windows.converged.all()


def test_a_participant_taking_more_steps_in_a_window_than_a_waveform_holds_is_named(tmp_path, capsys):
    """10,001 steps in one window, each a sample: one line naming the participant and the bound, not an allocation
    of gigabytes (substeps = 1000000 asked for 7 TiB)."""
    config = SUBCYCLING_CONFIG.replace('<exchange data="X" mesh="A-Mesh" from="A" to="B" substeps="false"/>',
                                       '<exchange data="X" mesh="A-Mesh" from="A" to="B" substeps="true"/>')
    many = SUBCYCLING.replace("for step in range(4):", "for step in range(10001):").replace("(4 - step)",
                                                                                           "(10001 - step)")
    assert many != SUBCYCLING and config != SUBCYCLING_CONFIG
    for name, text in (("A/A.py", many), ("B/B.py", PARTNER), ("config.xml", config),
                       ("case.toml", '[precice]\nconfig = "config.xml"\n[participants.A]\ncommand = "python3 A.py"\n'
                                     'cwd = "A"\n[participants.B]\ncommand = "python3 B.py"\ncwd = "B"\n')):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err, err
    assert "component 'A'" in err and "took 10,001 steps in the window" in err and "at most 10,000 steps" in err, err
    assert children_of(os.getpid()) == []


def test_a_participants_message_is_one_short_line_and_close_numbers_read_apart(tmp_path, capsys):
    """A participant's message with newlines, 2 MB long, is one line of at most 400 characters in the run's error;
    a read just past the step shows both numbers with the digits that tell them apart (%g printed 0.1 and 0.1)."""
    code, _ = run_fluid_variant(tmp_path, "long", "participant.initialize()",
                                'raise participant._core.fail("initialize", "line one\\nline two " + "x" * 2_000_000)')
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and len(err) < 1000, err[:300]
    assert "line one line two xxx" in err and err.endswith("..."), err[:300]
    code, _ = run_fluid_variant(tmp_path, "close", 'vertex_ids, dt)', 'vertex_ids, dt * (1 + 1e-6))')
    err = capsys.readouterr().err.strip()
    assert code == 2 and "relative_read_time 0.1000001" in err and "(0 to 0.1, what is left" in err, err


def find_coupler_in(config: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    """The participant package's search for the coupler of ``config``, in a process of its own."""
    code = ("import sys, pathlib, precice; from precice._connection import find_coupler; "
            "find_coupler(pathlib.Path(sys.argv[1]))")
    return subprocess.run([sys.executable, "-c", code, str(config)], capture_output=True, text=True, timeout=60,
                          env={"PYTHONPATH": str(SHIM), "PATH": "/usr/bin:/bin", **(env or {})})


def test_a_rendezvous_file_that_another_could_have_written_is_not_trusted(tmp_path):
    """A participant started by hand sends its hello, mesh and data only to a coupler named by a file of its own
    user that no one else can write (a planted coupler.json in a shared folder made it talk to whoever listened)."""
    config = tmp_path / "precice-config.xml"
    config.write_text("<precice-configuration/>")
    rendezvous = tmp_path / "cosim-run" / "coupler.json"
    rendezvous.parent.mkdir()
    rendezvous.write_text('{"endpoint": "tcp://127.0.0.1:9", "token": "planted", "pid": 1}')
    rendezvous.chmod(0o666)
    done = find_coupler_in(config)
    assert done.returncode == 2 and "is not trusted: it can be written by others" in done.stderr, done.stderr
    assert done.stderr.startswith("precice: error: ") and done.stderr.count("\n") == 1     # one line, no traceback
    if os.getuid() == 0:
        rendezvous.chmod(0o644)
        os.chown(rendezvous, 65534, 65534)
        done = find_coupler_in(config)
        assert done.returncode == 2 and "is not trusted: it belongs to another user" in done.stderr, done.stderr


def test_a_rendezvous_naming_a_live_program_that_is_no_coupler_or_a_zombie_is_stale(tmp_path):
    """A pid that now runs another program, a coupler that died unreaped (a zombie), or a cosim process that does
    not listen at the file's endpoint (it hung the participant silently) is no coupler: the participant does not
    wait on it (here it looks for the cosim command to start one, and says it has none);
    the coupler's own liveness test sees the zombie as gone too."""
    from cosim.rundir import alive
    config = tmp_path / "precice-config.xml"
    config.write_text("<precice-configuration/>")
    (tmp_path / "cosim-run").mkdir()
    sleeper = subprocess.Popen(["sleep", "60"])
    dead = subprocess.Popen(["true"])
    # a live process whose command line says cosim (another run's coupler, say), not listening at the endpoint
    other_run = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", "cosim"])
    try:
        wait_for(lambda: Path(f"/proc/{dead.pid}/stat").read_text().rpartition(")")[2][1:2] == "Z",
                 "the child to be a zombie")
        assert alive(sleeper.pid) and not alive(dead.pid)
        for pid in (sleeper.pid, dead.pid, other_run.pid):
            (tmp_path / "cosim-run" / "coupler.json").write_text(
                json.dumps({"endpoint": "tcp://127.0.0.1:9", "token": "t", "pid": pid}))
            (tmp_path / "cosim-run" / "coupler.json").chmod(0o600)
            done = find_coupler_in(config)
            assert done.returncode != 0 and "no `cosim` command starts one" in done.stderr, done.stderr
    finally:
        for process in (sleeper, other_run):
            process.kill()
            process.wait()
        dead.wait()


def test_a_second_coupler_for_the_same_configuration_is_refused_not_overwriting_the_first(tmp_path):
    """The rendezvous of a live coupler is not replaced by a second run's (the first run then failed with 'did not
    call its hello')."""
    from cosim.errors import CosimError
    from cosim.participant import ParticipantHub
    path = tmp_path / "cosim-run" / "coupler.json"
    first, second = ParticipantHub(), ParticipantHub()
    try:
        first.announce(path)
        written = path.read_text()
        document = json.loads(written)
        other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", "cosim"])
        try:
            path.write_text(json.dumps({**document, "pid": other.pid}))      # as another coupler's process wrote it
            with pytest.raises(CosimError, match=rf"another coupler \(pid {other.pid}\) serves the participants"):
                second.announce(path)
            assert json.loads(path.read_text())["pid"] == other.pid
        finally:
            other.kill()
            other.wait()
        second.announce(path)            # its coupler gone: the file is stale, and replaced
        assert json.loads(path.read_text())["pid"] == os.getpid()
    finally:
        first.close()
        second.close()


def test_a_parallel_scheme_accelerating_both_data_takes_each_preconditioner(tmp_path):
    """The perpendicular flap's configuration: parallel-implicit, IQN-ILS on both data, preconditioner residual-sum
    (refused before). Each preconditioner weighs the two data differently, and all find the same coupled solution
    to the measures' limit."""
    scheme = TUBE_CONFIG.replace("coupling-scheme:serial-implicit", "coupling-scheme:parallel-implicit")
    scheme = scheme.replace('<max-time value="120" />', '<max-time value="1.0" />')
    fields, iterations = {}, {}
    for kind in ("value", "residual", "residual-sum", "constant"):
        config = scheme.replace('<data name="CrossSectionLength" mesh="Solid-Nodes" />',
                                '<data name="CrossSectionLength" mesh="Solid-Nodes" /><data name="Pressure" '
                                f'mesh="Fluid-Nodes" /><preconditioner type="{kind}" freeze-after="-1" />')
        case = tmp_path / kind
        shutil.copytree(EXAMPLE, case, ignore=shutil.ignore_patterns("*.npz", "*.fmu"))
        (case / "precice-config.xml").write_text(config)
        acceleration = load_scene(case / "case.toml")["coupling"]["acceleration"]
        assert (acceleration["preconditioner"], acceleration["data"]) == (kind, ["CrossSectionLength", "Pressure"])
        run_scene(load_scene(case / "case.toml"), case / "out", progress=False)
        with RunResults(case / "out") as results:
            assert results.windows.converged.all(), kind
            fields[kind] = results.fields()["CrossSectionLength"][-1]
            iterations[kind] = tuple(results.windows.iterations)
    for kind in fields:
        np.testing.assert_allclose(fields[kind], fields["value"], rtol=1e-4)
    assert len(set(iterations.values())) > 1, iterations


def test_a_preconditioner_cosim_cannot_apply_is_refused_in_one_line(tmp_path, capsys):
    """cosim's IQN-IMVJ works on unscaled data: several data scaled by it are refused, as an unknown type is."""
    for config, message in (
            (TUBE_CONFIG.replace('<filter type="QR2" limit="1e-3" />', '<preconditioner type="norm" />'),
             "'type' is 'norm'; allowed: value, constant, residual, residual-sum"),
            (TUBE_CONFIG.replace("IQN-ILS>", "IQN-IMVJ>").replace("coupling-scheme:serial-implicit",
                                                                  "coupling-scheme:parallel-implicit")
             .replace('<time-windows-reused value="0" />', '<data name="Pressure" mesh="Fluid-Nodes" />'
                                                          '<preconditioner type="residual-sum" />'),
             "the preconditioner 'residual-sum': cosim's IQN-IMVJ does not scale its data")):
        shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu"), dirs_exist_ok=True)
        (tmp_path / "case" / "precice-config.xml").write_text(config)
        assert main(["check", str(tmp_path / "case" / "case.toml")]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and message in err and "precice-config.xml, line" in err, err


def test_a_measure_that_suffices_ends_the_window_alone(tmp_path):
    """preCICE's suffices="true": the pressure's measure met at 1e-2 ends a window though the cross-section's 1e-4 is
    not met yet; without suffices both must be met."""
    loose = TUBE_CONFIG.replace('<max-time value="120" />', '<max-time value="1.0" />').replace(
        '<relative-convergence-measure data="Pressure" mesh="Fluid-Nodes" limit="1e-4" strict="true" />',
        '<relative-convergence-measure data="Pressure" mesh="Fluid-Nodes" limit="1e-2" strict="true" SUFFICES/>')
    iterations = {}
    for name, attribute in (("all", ""), ("suffices", 'suffices="true" ')):
        case = tmp_path / name
        shutil.copytree(EXAMPLE, case, ignore=shutil.ignore_patterns("*.npz", "*.fmu"))
        (case / "precice-config.xml").write_text(loose.replace("SUFFICES", attribute))
        measures = load_scene(case / "case.toml")["coupling"]["convergence"]
        assert [m.get("suffices", False) for m in measures] == [bool(attribute), False]
        run_scene(load_scene(case / "case.toml"), case / "out", progress=False)
        with RunResults(case / "out") as results:
            assert results.windows.converged.all()
            iterations[name] = results.windows.iterations
            pressure = results.calls("Fluid").outputs["Pressure"]
            window = results.calls("Fluid").window
        last = np.cumsum(iterations[name]) - 1                  # each window's converged call (one call an iteration)
        change = np.linalg.norm(pressure[last] - pressure[last - 1], axis=1) / np.linalg.norm(pressure[last], axis=1)
        assert np.array_equal(window[last], np.arange(1, len(last) + 1)) and np.all(change < 1e-2)
    assert np.all(iterations["suffices"] <= iterations["all"]) and iterations["suffices"].sum() < \
        iterations["all"].sum(), iterations


def test_window_converged_takes_all_measures_or_one_that_suffices():
    from coupler.convergence import make_measure, window_converged
    strict = make_measure({"type": "relative", "data": "a", "limit": 1e-4})
    enough = make_measure({"type": "relative", "data": "b", "limit": 1e-2, "suffices": True})
    assert window_converged([strict, enough], [False, True])
    assert not window_converged([strict, enough], [True, False])
    assert window_converged([strict, enough], [True, True])


MASS = '''"""One mass of a chain wall-M1-M2-M3-wall, as a preCICE participant: trapezoidal rule, the neighbours'
displacements at the window's end read from preCICE."""
import json
import sys

import numpy as np
import precice

NAME = sys.argv[1]
I = int(NAME[-1])
MASS = {1: 1.0, 2: 2.0, 3: 1.0}[I]
WALL = {1: 4.0, 2: 0.0, 3: 3.0}[I]
SPRING = 1.0
NEIGHBOURS = [int(j) for j in sys.argv[2].split(",")] if len(sys.argv) > 2 else {1: [2], 2: [1, 3], 3: [2]}[I]
STIFFNESS = WALL + SPRING * len(NEIGHBOURS)

participant = precice.Participant(NAME, "../config.xml", 0, 1)
mesh = f"{NAME}-Mesh"
vertex = participant.set_mesh_vertices(mesh, np.zeros((1, 2)))
u, v = {1: 1.0, 2: 0.2, 3: -0.5}[I], {1: 0.0, 2: 0.3, 3: 0.0}[I]
written = [f"Displacement-{I}"]
read = [f"Displacement-{j}" for j in NEIGHBOURS]
if participant.requires_initial_data():
    for name in written:
        participant.write_data(mesh, name, vertex, [u])
participant.initialize()
dt = participant.get_max_time_step_size()
neighbours = np.array([participant.read_data(mesh, name, vertex, dt)[0] for name in read])
history = [u]
while participant.is_coupling_ongoing():
    if participant.requires_writing_checkpoint():
        saved = (u, v, neighbours)
    dt = participant.get_max_time_step_size()
    start = (u, v, neighbours)
    ends = np.array([participant.read_data(mesh, name, vertex, dt)[0] for name in read])
    a0 = (-STIFFNESS * u + SPRING * neighbours.sum()) / MASS
    u1 = (u + dt * v + dt ** 2 / 4 * (a0 + SPRING * ends.sum() / MASS)) / (1 + dt ** 2 * STIFFNESS / (4 * MASS))
    v1 = v + dt / 2 * (a0 + (-STIFFNESS * u1 + SPRING * ends.sum()) / MASS)
    u, v, neighbours = u1, v1, ends
    for name in written:
        participant.write_data(mesh, name, vertex, [u])
    participant.advance(dt)
    if participant.requires_reading_checkpoint():
        u, v, neighbours = saved
    elif participant.is_time_window_complete():
        history.append(u)
participant.finalize()
json.dump(history, open("history.json", "w"))
'''


def chain_config(masses: int, scheme: str, acceleration: str, initialize: bool) -> str:
    """A chain wall-M1-...-Mn-wall of masses coupled by springs, each mass a participant (n = 2 or 3); the
    middle one (M2) accelerates: multi's controller, parallel-implicit's second."""
    names = [f"M{i}" for i in range(1, masses + 1)]
    neighbours = {name: [other for other in names if abs(int(other[1]) - int(name[1])) == 1] for name in names}
    init = ' initialize="true"' if initialize else ""
    lines = ['<?xml version="1.0" encoding="UTF-8" ?>', "<precice-configuration>"]
    lines += [f'<data:scalar name="Displacement-{n[1]}" />' for n in names]
    for name in names:
        used = "".join(f'<use-data name="Displacement-{m[1]}" />' for m in [name, *neighbours[name]])
        lines.append(f'<mesh name="{name}-Mesh" dimensions="2">{used}</mesh>')
    for name in names:
        lines.append(f'<participant name="{name}"><provide-mesh name="{name}-Mesh" />'
                     f'<write-data name="Displacement-{name[1]}" mesh="{name}-Mesh" />')
        for other in neighbours[name]:
            lines.append(f'<receive-mesh name="{other}-Mesh" from="{other}" /><read-data name="Displacement-'
                         f'{other[1]}" mesh="{name}-Mesh" /><mapping:nearest-neighbor direction="read" '
                         f'from="{other}-Mesh" to="{name}-Mesh" constraint="consistent" />')
        lines.append("</participant>")
    lines += [f'<m2n:sockets acceptor="M2" connector="{n}" exchange-directory=".." />' for n in names if n != "M2"]
    lines.append(f"<coupling-scheme:{scheme}>")
    if scheme == "multi":
        lines += ['<participant name="M2" control="yes" />', '<participant name="M1" />', '<participant name="M3" />']
    else:
        lines.append('<participants first="M1" second="M2" />')
    lines += ['<max-time-windows value="40" />', '<time-window-size value="0.1" />', '<max-iterations value="40" />']
    for name in names:
        for other in neighbours[name]:
            lines.append(f'<exchange data="Displacement-{name[1]}" mesh="{name}-Mesh" from="{name}" to="{other}"'
                         f'{init} />')
        lines.append(f'<absolute-convergence-measure limit="1e-10" data="Displacement-{name[1]}" '
                     f'mesh="{name}-Mesh" />')
    lines += [acceleration.format(data="".join(f'<data name="Displacement-{n[1]}" mesh="{n}-Mesh" />'
                                               for n in names)), f"</coupling-scheme:{scheme}>",
              "</precice-configuration>"]
    return "\n".join(lines) + "\n"


RELAXATION = '<acceleration:constant><relaxation value="0.5" /></acceleration:constant>'
IQN_RESIDUAL_SUM = ('<acceleration:IQN-ILS>{data}<preconditioner type="residual-sum" /><filter type="QR2" '
                    'limit="1e-3" /><initial-relaxation value="0.5" /><max-used-iterations value="20" />'
                    '<time-windows-reused value="5" /></acceleration:IQN-ILS>')


def chain_run(folder: Path, masses: int, scheme: str, acceleration: str, initialize: bool) -> tuple[list[int],
                                                                                                   np.ndarray]:
    """The chain's run under cosim: iterations per window, and each mass's displacement at every window's end."""
    names = [f"M{i}" for i in range(1, masses + 1)]
    (folder / "mass.py").write_text(MASS)
    lines = ['[precice]', 'config = "config.xml"']
    for name in names:
        (folder / name).mkdir(parents=True, exist_ok=True)
        others = ",".join(str(i) for i in range(1, masses + 1) if abs(i - int(name[1])) == 1)
        lines += [f"[participants.{name}]", f'command = "python3 ../mass.py {name} {others}"', f'cwd = "{name}"']
    (folder / "config.xml").write_text(chain_config(masses, scheme, acceleration, initialize))
    (folder / "case.toml").write_text("\n".join(lines) + "\n")
    run_scene(load_scene(folder / "case.toml"), folder / "out", progress=False)
    with RunResults(folder / "out") as results:
        iterations = results.windows.iterations.tolist()
    return iterations, np.column_stack([json.loads((folder / n / "history.json").read_text()) for n in names])


def chain_exact(masses: int) -> np.ndarray:
    """The trapezoidal rule on the whole chain at once (the masses', walls' and springs' values of MASS)."""
    mass, wall, spring = np.array([1.0, 2.0, 1.0])[:masses], np.array([4.0, 0.0, 3.0])[:masses], 1.0
    K = np.diag(wall) + spring * (2 * np.eye(masses) - np.eye(masses, k=1) - np.eye(masses, k=-1))
    K[0, 0] -= spring
    K[-1, -1] -= spring
    A = np.block([[np.zeros((masses, masses)), np.eye(masses)], [-K / mass[:, None], np.zeros((masses, masses))]])
    step = np.linalg.solve(np.eye(2 * masses) - 0.05 * A, np.eye(2 * masses) + 0.05 * A)
    x = np.concatenate([[1.0, 0.2, -0.5][:masses], [0.0, 0.3, 0.0][:masses]])
    ends = [x[:masses]]
    for _ in range(40):
        x = step @ x
        ends.append(x[:masses])
    return np.array(ends)


# preCICE 3.4.1's iterations per window with the same participants and configurations (chain_config)
PRECICE_CHAIN = {
    ("multi", "relaxation", True): [35, 31] + [32] * 10 + [31, 31, 30, 31] + [32] * 11 + [31, 31, 31] + [32] * 10,
    ("parallel-implicit", "relaxation", True): [35, 31] + [32] * 9 + [31, 31, 29, 30, 31] + [32] * 9
                                               + [31, 30, 29, 30, 31, 32, 32, 32, 32, 33, 33, 32, 32, 32, 32],
    ("multi", "iqn", False): [5] + [3] * 39,
}


@pytest.mark.parametrize(("scheme", "acceleration", "initialize"), list(PRECICE_CHAIN))
def test_a_chain_of_masses_takes_precices_iterations_and_gives_the_monolithic_solution(tmp_path, scheme,
                                                                                       acceleration, initialize):
    """Three masses in one multi-coupling (two in a parallel scheme), each its own participant: every window
    converged to the trapezoidal rule on the whole chain, in the iterations preCICE 3.4.1 takes. With initial
    data, the accelerating participant's first iterate holds zero for the data it receives, as preCICE's does (35
    iterations in the first window; 30 were it the initial data). IQN-ILS's residual-sum weights from the first
    window's second iteration on, every iteration in it."""
    masses = 2 if scheme == "parallel-implicit" else 3
    form = RELAXATION if acceleration == "relaxation" else IQN_RESIDUAL_SUM
    iterations, ends = chain_run(tmp_path, masses, scheme, form, initialize)
    assert iterations == PRECICE_CHAIN[scheme, acceleration, initialize]
    if initialize:      # else the first window starts from neighbours at zero
        np.testing.assert_allclose(ends, chain_exact(masses), rtol=0, atol=1e-9)


@pytest.mark.parametrize(("change", "message"), [
    (('<participant name="M2" control="yes" />', '<participant name="M2" />'),
     "exactly one <participant name=\"...\" control=\"yes\"/> must control a multi-coupling, found 0"),
    (('<participant name="M1" />', '<participant name="M1" control="yes" />'), "found 2"),
    (('<participant name="M1" />', '<participant name="M2" />'), "participant 'M2' is named twice"),
    (('<participant name="M2" control="yes" />', '<participants first="M2" second="M1" />'),
     "this element of a coupling scheme is not supported"),
])
def test_a_multi_coupling_misconfigured_is_one_line(tmp_path, change, message):
    (tmp_path / "config.xml").write_text(chain_config(3, "multi", RELAXATION, True).replace(*change))
    with pytest.raises(SceneError, match=re.escape(message)):
        read_config(tmp_path / "config.xml")


GRADIENT_WRITER = '''import json
import numpy as np
import precice
participant = precice.Participant("A", "../config.xml", 0, 1)
grid = np.array([[x, y] for x in np.linspace(0, 1, 4) for y in np.linspace(0, 1, 3)])
ids = participant.set_mesh_vertices("A-Mesh", grid)
participant.initialize()
asked = [participant.requires_gradient_data_for("A-Mesh", "S"), participant.requires_gradient_data_for("A-Mesh", "V")]
t = 0.0
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    t += dt
    x, y = grid[:, 0], grid[:, 1]
    participant.write_data("A-Mesh", "S", ids, t + 2 * x - y)
    participant.write_data("A-Mesh", "V", ids, np.column_stack([x + 2 * y, t * (3 * x - y)]))
    if asked[0]:
        participant.write_gradient_data("A-Mesh", "S", ids, np.tile([2.0, -1.0], (len(ids), 1)))
    if asked[1]:
        participant.write_gradient_data("A-Mesh", "V", ids, np.tile([1.0, 3.0 * t, 2.0, -t], (len(ids), 1)))
    participant.advance(dt)
    participant.requires_reading_checkpoint()
participant.finalize()
json.dump(asked, open("asked.json", "w"))
'''
GRADIENT_READER = '''import json
import numpy as np
import precice
participant = precice.Participant("B", "../config.xml", 0, 1)
points = np.array([[0.1, 0.05], [0.45, 0.8], [0.9, 0.33], [0.6, 0.6]])
ids = participant.set_mesh_vertices("B-Mesh", points)
participant.initialize()
seen = []
while participant.is_coupling_ongoing():
    participant.requires_writing_checkpoint()     # preCICE wants it asked
    dt = participant.get_max_time_step_size()
    participant.advance(dt)
    participant.requires_reading_checkpoint()
    seen.append([participant.read_data("B-Mesh", "S", ids, 0.0).tolist(),
                 participant.read_data("B-Mesh", "V", ids, 0.0).tolist()])
participant.finalize()
json.dump(seen, open("seen.json", "w"))
'''
GRADIENT_CONFIG = '''<?xml version="1.0" encoding="UTF-8" ?>
<precice-configuration experimental="true">
  <data:scalar name="S" /><data:vector name="V" />
  <mesh name="A-Mesh" dimensions="2"><use-data name="S" /><use-data name="V" /></mesh>
  <mesh name="B-Mesh" dimensions="2"><use-data name="S" /><use-data name="V" /></mesh>
  <participant name="A"><provide-mesh name="A-Mesh" /><write-data name="S" mesh="A-Mesh" />
    <write-data name="V" mesh="A-Mesh" /></participant>
  <participant name="B"><provide-mesh name="B-Mesh" /><receive-mesh name="A-Mesh" from="A" />
    <read-data name="S" mesh="B-Mesh" /><read-data name="V" mesh="B-Mesh" />
    <mapping:nearest-neighbor-gradient direction="read" from="A-Mesh" to="B-Mesh" constraint="consistent" />
  </participant>
  <m2n:sockets acceptor="A" connector="B" exchange-directory=".." />
  <coupling-scheme:serial-explicit>
    <participants first="A" second="B" /><max-time-windows value="2" /><time-window-size value="1.0" />
    <exchange data="S" mesh="A-Mesh" from="A" to="B" />
    <exchange data="V" mesh="A-Mesh" from="A" to="B" />
  </coupling-scheme:serial-explicit>
</precice-configuration>
'''
# what B read with preCICE 3.4.1 and pyprecice 3.4.0, the same participants and configuration: S = t + 2x - y exactly
# (a linear field, corrected by its gradient); V's second component shows preCICE's layout of a vector's gradient
# (each component's d/dx, d/dy), and after the last advance B reads the last window's values
PRECICE_GRADIENT_READS = [
    [[1.15, 1.1, 2.47, 1.6], [[0.25, 0.15], [1.85, 0.43333333333333335], [1.39, 2.47], [1.9, 1.2666666666666666]]],
    [[2.15, 2.1, 3.47, 2.6], [[0.4, 0.1], [1.25, 0.6333333333333333], [0.88, 5.14], [2.2, 2.666666666666667]]]]


def test_nearest_neighbor_gradient_maps_with_the_gradients_the_writer_gives_as_precice_does(tmp_path):
    """The writer is asked for gradients of both its data (requires_gradient_data_for), writes them, and the
    reader's values are the nearest vertex's corrected by them: preCICE 3.4.1's values, to round-off."""
    case_file = write_case(tmp_path, {"A": GRADIENT_WRITER, "B": GRADIENT_READER}, GRADIENT_CONFIG)
    run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert json.loads((tmp_path / "A" / "asked.json").read_text()) == [True, True]
    seen = json.loads((tmp_path / "B" / "seen.json").read_text())
    for window, expected in zip(seen, PRECICE_GRADIENT_READS, strict=True):
        np.testing.assert_allclose(window[0], expected[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(window[1], expected[1], rtol=0, atol=1e-12)


@pytest.mark.parametrize(("participant", "change", "message"), [
    ("config", ('<precice-configuration experimental="true">', "<precice-configuration>"),
     "gradient data is preCICE's experimental API"),
    ("A", ("np.tile([2.0, -1.0], (len(ids), 1))", "np.ones((len(ids), 3))"),
     "gradients of shape (12, 3) for 12 vertices of 'S'; expected (12, 2)"),
    ("A", ("if asked[0]:", "if True:"), "''"),
])
def test_gradient_data_misused_is_named_in_one_line(tmp_path, participant, change, message):
    texts = {"A": GRADIENT_WRITER, "B": GRADIENT_READER, "config": GRADIENT_CONFIG}
    texts[participant] = texts[participant].replace(*change)
    case_file = write_case(tmp_path, {"A": texts["A"], "B": texts["B"]}, texts["config"])
    if message == "''":     # a participant that writes gradients where none is asked for: preCICE refuses it too
        texts["config"] = texts["config"].replace("nearest-neighbor-gradient", "nearest-neighbor")
        (tmp_path / "config.xml").write_text(texts["config"])
        message = "'S' on mesh 'A-Mesh' takes no gradients: no nearest-neighbor-gradient mapping maps it"
    with pytest.raises(CosimError) as failed:
        run_scene(load_scene(case_file), tmp_path / "out", progress=False)
    assert message in str(failed.value) and "\n" not in str(failed.value)
    assert children_of(os.getpid()) == []


def test_a_conservative_gradient_mapping_is_refused_in_one_line(tmp_path):
    (tmp_path / "config.xml").write_text(GRADIENT_CONFIG.replace('constraint="consistent"', 'constraint="conservative"'))
    with pytest.raises(SceneError, match="nearest-neighbor-gradient maps consistent data only"):
        read_config(tmp_path / "config.xml")


def test_an_implicit_run_writes_precices_iteration_and_convergence_logs_in_its_format(tmp_path):
    """Each participant's precice-<name>-iterations.log and the controller's precice-<name>-convergence.log, in the
    run directory: preCICE 3.4.1's header lines and column layout (its files from the same chain run), the same
    iterations, and the first window's residuals to preCICE's printed digits."""
    iterations, _ = chain_run(tmp_path, 3, "multi", IQN_RESIDUAL_SUM, False)
    out = tmp_path / "out"
    for name in ("M1", "M3"):
        lines = (out / f"precice-{name}-iterations.log").read_text().splitlines()
        assert lines[:3] == ["  TimeWindow  TotalIterations  Iterations  Convergence", "     1       5       5       1",
                             "     2       8       3       1"]
        assert [int(line.split()[2]) for line in lines[1:]] == PRECICE_CHAIN["multi", "iqn", False]
    header = (out / "precice-M2-iterations.log").read_text().splitlines()[0]
    assert header == ("  TimeWindow  TotalIterations  Iterations  Convergence  QNColumns  DeletedQNColumns  "
                      "DroppedQNColumns")
    lines = (out / "precice-M2-convergence.log").read_text().splitlines()
    assert lines[0] == ("  TimeWindow  Iteration  ResAbs(M1-Mesh:Displacement-1)  ResAbs(M2-Mesh:Displacement-2)  "
                        "ResAbs(M3-Mesh:Displacement-3)")
    assert all(re.fullmatch(r" +\d+ +\d+( +\d\.\d{8}e[+-]\d\d){3}", line) for line in lines[1:])
    assert [len(line) for line in lines[1:3]] == [65, 65]      # 6, 2 + 6, then 2 + 15 per measure
    precice_first_window = [[9.75308642e-01, 2.28927681e-01, 4.90099010e-01],
                            [4.87936948e-01, 1.14766340e-01, 2.44766179e-01],
                            [1.10937559e-06, 9.99743292e-07, 1.11212157e-06]]
    np.testing.assert_allclose([[float(v) for v in line.split()[2:]] for line in lines[1:4]], precice_first_window,
                               rtol=1e-6)
    assert not (out / "precice-M1-convergence.log").exists()


def test_the_convergence_log_names_each_measure_as_precice_does(tmp_path):
    """relative, residual-relative and absolute-or-relative measures are ResRel, ResDrop and ResAbsOrRel (which
    preCICE 3.4.1 logs as 0); the iterations log of a run without quasi-Newton has no QN columns."""
    measures = ('<absolute-convergence-measure limit="1e-10" data="Displacement-1" mesh="M1-Mesh" />',
                '<relative-convergence-measure limit="1e-8" data="Displacement-1" mesh="M1-Mesh" />'
                '<residual-relative-convergence-measure limit="1e-3" data="Displacement-2" mesh="M2-Mesh" />'
                '<absolute-or-relative-convergence-measure abs-limit="1e-12" rel-limit="1e-9" data="Displacement-2" '
                'mesh="M2-Mesh" />')
    config = chain_config(2, "parallel-implicit", RELAXATION, True).replace(*measures).replace(
        '<absolute-convergence-measure limit="1e-10" data="Displacement-2" mesh="M2-Mesh" />', "")
    (tmp_path / "mass.py").write_text(MASS)
    for name in ("M1", "M2"):
        (tmp_path / name).mkdir()
    (tmp_path / "config.xml").write_text(config)
    (tmp_path / "case.toml").write_text('[precice]\nconfig = "config.xml"\n' + "".join(
        f'[participants.{n}]\ncommand = "python3 ../mass.py {n} {o}"\ncwd = "{n}"\n' for n, o in (("M1", 2), ("M2", 1))))
    run_scene(load_scene(tmp_path / "case.toml"), tmp_path / "out", progress=False)
    lines = (tmp_path / "out" / "precice-M2-convergence.log").read_text().splitlines()
    assert lines[0] == ("  TimeWindow  Iteration  ResRel(M1-Mesh:Displacement-1)  ResDrop(M2-Mesh:Displacement-2)  "
                        "ResAbsOrRel(M2-Mesh:Displacement-2)")
    assert lines[1].split()[2:] == ["1.00000000e+00", "1.00000000e+00", "0.00000000e+00"]
    assert (tmp_path / "out" / "precice-M2-iterations.log").read_text().splitlines()[0] == \
        "  TimeWindow  TotalIterations  Iterations  Convergence"


def test_the_export_writers_give_precices_files_to_the_byte():
    """A 2-D mesh of four vertices with an edge and a triangle, a scalar and a 2-D vector: the vtu, vtk and csv
    texts preCICE 3.4.1 writes for it (its files of the same mesh and data, compared byte for byte here)."""
    sys.path.insert(0, str(SHIM))
    try:
        from precice._export import MeshView, csv_text, vtk_text, vtu_text
    finally:
        sys.path.remove(str(SHIM))
        for name in [n for n in sys.modules if n == "precice" or n.startswith("precice.")]:
            del sys.modules[name]
    mesh = MeshView(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.5, 1.0]]),
                    {"triangles": np.array([[1, 2, 3]]), "edges": np.array([[0, 1], [1, 2], [1, 3], [2, 3]])},
                    {"Temperature": np.array([226.4, 326.4, 439.12, 539.12]),
                     "Flux": np.array([[26.64, -1.1], [26.64, -1.1], [39.4032, -2.1], [39.4032, -2.1]])})
    vtu = vtu_text(mesh).splitlines()
    assert vtu[3] == '      <Piece NumberOfPoints="4" NumberOfCells="5" > '
    assert vtu[9] == "               1.5  1  0  "
    assert vtu[15] == "               1  2  3  0  1  1  2  1  3  2  3  "       # the triangle, then the edges
    assert vtu[18] == "               3  5  7  9  11  " and vtu[21] == "               5  3  3  3  3  "
    assert vtu[24] == '         <PointData Scalars="Rank Temperature " Vectors="Flux ">'
    assert vtu[26] == "               0 0 0 0 " and vtu[29] == "               226.4 326.4 439.12 539.12 "
    assert vtu[32] == "               26.64 -1.1 0.0  26.64 -1.1 0.0  39.4032 -2.1 0.0  39.4032 -2.1 0.0  "
    vtk = vtk_text(mesh).split("\n")
    assert vtk[:9] == ["# vtk DataFile Version 2.0", "", "ASCII", "", "DATASET UNSTRUCTURED_GRID", "",
                       "POINTS 4 double ", "", "0.00000000000000000e+00  0.00000000000000000e+00  "
                       "0.00000000000000000e+00"]
    assert vtk[12:19] == ["", "CELLS 4 12", "", "2 0 1 ", "2 1 2 ", "2 1 3 ", "2 2 3 "]     # a 2-D mesh: edges
    assert "VECTORS Flux double" in vtk and "3.94031999999999982e+01 -2.10000000000000009e+00 0" in vtk
    assert csv_text(mesh).splitlines()[:2] == ["PosX;PosY;Rank;Temperature;FluxX;FluxY", "0;0;0;226.4;26.64;-1.1"]


def test_a_participants_exports_write_its_meshes_as_precice_names_them_and_vtk_reads_them(tmp_path):
    """``<export:vtu|vtk|csv>`` of a participant: <mesh>-<participant>.init / .dt<N> / .it<K> files and a .series in
    the export's directory under the participant's folder, every-n-time-windows and every-iteration kept; VTK reads
    the mesh and the data the participant wrote, equal to results.h5's fields; the run itself opens from run.xdmf."""
    xml_reader = pytest.importorskip("vtkmodules.vtkIOXML", reason="VTK's Python wheel reads the exports")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader

    from tests.xdmf_check import assert_xdmf_holds_the_run
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu", "cosim-run"))
    config = tmp_path / "case" / "precice-config.xml"
    config.write_text(config.read_text().replace(
        '<write-data name="Pressure" mesh="Fluid-Nodes" />',
        '<write-data name="Pressure" mesh="Fluid-Nodes" />\n    <export:vtu directory="exports" />\n'
        '    <export:vtk directory="legacy" every-n-time-windows="2" />\n'
        '    <export:csv directory="iterations" every-iteration="true" />'))
    out = case(tmp_path / "out", tmp_path / "case" / "case.toml", "time.end=0.4")
    folder = tmp_path / "case" / "fluid-python"
    with RunResults(out) as run:
        pressure, times, iterations = run.fields()["Pressure"], run.windows.time, int(run.windows.iterations.sum())
        nodes = run.component("Fluid").meshes["Fluid-Nodes"]
    stem = "Fluid-Nodes-Fluid"
    assert sorted(p.name for p in (folder / "exports").iterdir()) == sorted(
        [f"{stem}.init.vtu", *(f"{stem}.dt{n}.vtu" for n in range(1, 5)), f"{stem}.vtu.series"])
    assert sorted(p.name for p in (folder / "legacy").iterdir()) == sorted(
        [f"{stem}.init.vtk", f"{stem}.dt2.vtk", f"{stem}.dt4.vtk", f"{stem}.vtk.series"])
    assert len(list((folder / "iterations").glob(f"{stem}.it*.csv"))) == iterations
    series = json.loads((folder / "exports" / f"{stem}.vtu.series").read_text())
    assert series["file-series-version"] == "1.0"
    assert [f["time"] for f in series["files"]] == pytest.approx([0.0, *times])
    for window in range(1, 5):
        reader = xml_reader.vtkXMLUnstructuredGridReader()
        reader.SetFileName(str(folder / "exports" / f"{stem}.dt{window}.vtu"))
        reader.Update()
        grid = reader.GetOutput()
        np.testing.assert_allclose(vtk_to_numpy(grid.GetPoints().GetData())[:, :2], nodes, rtol=5e-6, atol=1e-12)
        np.testing.assert_allclose(vtk_to_numpy(grid.GetPointData().GetArray("Pressure")), pressure[window - 1],
                                   rtol=5e-6)            # preCICE's vtu prints six significant digits
        assert vtk_to_numpy(grid.GetPointData().GetArray("Rank")).tolist() == [0] * len(nodes)
        assert grid.GetPointData().GetArray("CrossSectionLength") is not None      # the data it reads, too
    legacy = vtkUnstructuredGridReader()
    legacy.SetFileName(str(folder / "legacy" / f"{stem}.dt4.vtk"))
    legacy.ReadAllScalarsOn()          # Rank comes first; the reader takes only the first scalars otherwise
    legacy.Update()
    np.testing.assert_array_equal(vtk_to_numpy(legacy.GetOutput().GetPointData().GetArray("Pressure")),
                                  pressure[3])           # 17 digits: every bit
    header = (folder / "iterations" / f"{stem}.it1.csv").read_text().splitlines()[0]
    assert header == "PosX;PosY;Rank;CrossSectionLength;Pressure"          # the mesh's <use-data> order
    assert not list((folder / "iterations").glob("*.series"))       # csv and every-iteration keep no series
    assert assert_xdmf_holds_the_run(out) > 0


def test_a_participant_waiting_on_a_coupler_that_died_unreaped_sees_it_gone(tmp_path):
    """A participant started by hand starts the coupler, so a coupler that dies stays its zombie until reaped; the
    participant's wait for an answer asks whether the coupler runs, and a zombie does not (it hung forever)."""
    dead = subprocess.Popen(["true"])
    sleeper = subprocess.Popen(["sleep", "60"])
    try:
        wait_for(lambda: Path(f"/proc/{dead.pid}/stat").read_text().rpartition(")")[2][1:2] == "Z",
                 "the child to be a zombie")
        shim = ROOT / "precice_compat" / "participant"
        done = subprocess.run([sys.executable, "-c", f"from precice._connection import _alive; "
                               f"print(_alive({dead.pid}), _alive({sleeper.pid}))"],
                              env={**os.environ, "PYTHONPATH": str(shim)}, capture_output=True, text=True, timeout=60)
        assert done.stdout.split() == ["False", "True"], done.stderr
    finally:
        sleeper.kill()
        sleeper.wait()
        dead.wait()


def test_a_coupler_that_fails_at_start_up_leaves_no_rendezvous_behind(tmp_path, capsys):
    """cosim run of a configuration whose participants never come: one line, exit 2, and cosim-run/coupler.json
    removed (it stayed, and named a coupler that was gone)."""
    shutil.copytree(EXAMPLE, tmp_path / "case", ignore=shutil.ignore_patterns("*.npz", "*.fmu", "cosim-run"))
    code = main(["run", str(tmp_path / "case" / "precice-config.xml"), "--out", str(tmp_path / "out"), "--quiet",
                 "--set", "components.Fluid.startup_timeout=2", "--set", "components.Solid.startup_timeout=2"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "did not call its hello" in err, err
    assert not (tmp_path / "case" / "cosim-run" / "coupler.json").exists()
