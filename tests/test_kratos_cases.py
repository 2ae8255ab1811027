"""Kratos CoSimulation cases under cosim (kratos_compat): the same iterations and fields as Kratos's own coupler on
the same files, Kratos's accelerators matched bit for bit, and bad CoSimulation files refused in one line."""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from cosim.cli import main
from coupler.accelerations import ACCELERATIONS
from tests.conftest import needs_kratos
from tests.xdmf_check import assert_xdmf_holds_the_run

needs_gmsh = pytest.mark.skipif(importlib.util.find_spec("gmsh") is None,
                                reason="needs gmsh (pip install -e '.[mesh]') for the cases' meshes")
needs_cosim_application = pytest.mark.skipif(
    importlib.util.find_spec("KratosMultiphysics") is None
    or importlib.util.find_spec("KratosMultiphysics.CoSimulationApplication") is None,
    reason="needs Kratos's CoSimulationApplication (pip install -e '.[kratos]')")


def linear_iterations(make_update, windows: int = 6, iterations: int = 9, n: int = 40) -> np.ndarray:
    """Every iterate of a fixed-point iteration x -> A x + b_window accelerated by ``make_update`` (Kratos's
    ``UpdateSolution(r, x)`` protocol, with InitializeSolutionStep / FinalizeSolutionStep around each window)."""
    rng = np.random.default_rng(7)
    A = 0.9 * rng.standard_normal((n, n)) / np.sqrt(n)
    update = make_update()
    x, iterates = np.zeros(n), []
    for _ in range(windows):
        b = rng.standard_normal(n)
        update.InitializeSolutionStep()
        for _ in range(iterations):
            x = x + update.UpdateSolution(A @ x + b - x, x)
            iterates.append(x.copy())
        update.FinalizeSolutionStep()
    return np.array(iterates)


class Ours:
    """A cosim acceleration behind Kratos's accelerator protocol."""

    def __init__(self, settings: dict):
        self.acceleration = ACCELERATIONS.create(settings)

    def InitializeSolutionStep(self) -> None:
        self.acceleration.start_window()

    def FinalizeSolutionStep(self) -> None:
        self.acceleration.end_window()

    def UpdateSolution(self, r: np.ndarray, x: np.ndarray) -> np.ndarray:
        self.acceleration.observe(x, x + r)
        return self.acceleration.next_iterate() - x


@needs_cosim_application
@pytest.mark.parametrize("kratos, ours", [
    ({"type": "mvqn", "horizon": 5, "alpha": 0.2}, {"type": "kratos-mvqn", "horizon": 5, "initial_relaxation": 0.2}),
    ({"type": "iqnils"}, {"type": "kratos-iqn-ils"}),
    ({"type": "iqnils", "iteration_horizon": 6, "timestep_horizon": 3, "alpha": 0.2},
     {"type": "kratos-iqn-ils", "iteration_horizon": 6, "timestep_horizon": 3, "initial_relaxation": 0.2}),
    ({"type": "aitken"}, {"type": "kratos-aitken"}),
    ({"type": "aitken"}, {"type": "aitken-bounded"}),          # its former name, an alias
    ({"type": "aitken", "init_alpha": 0.3, "init_alpha_max": 0.2, "alpha_max": 0.9, "alpha_min": -0.5},
     {"type": "kratos-aitken", "initial_relaxation": 0.3, "initial_relaxation_max": 0.2, "relaxation_max": 0.9,
      "relaxation_min": -0.5}),
    ({"type": "constant_relaxation", "alpha": 0.3}, {"type": "constant", "relaxation": 0.3}),
])
def test_each_kratos_accelerator_is_a_cosim_plugin_with_the_same_iterates_bit_for_bit(kratos, ours):
    import KratosMultiphysics as KM
    from KratosMultiphysics.CoSimulationApplication.factories.convergence_accelerator_factory import (
        CreateConvergenceAccelerator,
    )
    theirs = linear_iterations(lambda: CreateConvergenceAccelerator(KM.Parameters(json.dumps(kratos))))
    mine = linear_iterations(lambda: Ours(ours))
    assert np.abs(theirs).max() > 1.0          # the iteration went somewhere
    np.testing.assert_array_equal(mine, theirs)


def test_mvqn_is_not_iqn_imvj():
    """The reason MVQN is a plug-in of its own: on the same problem the iterates part."""
    mvqn = linear_iterations(lambda: Ours({"type": "kratos-mvqn", "horizon": 15, "initial_relaxation": 0.2}))
    imvj = linear_iterations(lambda: Ours({"type": "iqn-imvj", "initial_relaxation": 0.2}))
    assert np.abs(mvqn - imvj).max() > 1e-3 * np.abs(mvqn).max()


@pytest.fixture(scope="module")
def wall_case(tmp_path_factory) -> Path:
    if importlib.util.find_spec("gmsh") is None:
        pytest.skip("needs gmsh (pip install -e '.[mesh]') for the cases' meshes")
    from cases.kratos_wall.write import write_case
    return write_case(tmp_path_factory.mktemp("kratos_wall") / "dynamic", "dynamic", 3).parent


def edit(document: dict, path: str, value) -> None:
    *parents, last = path.split("/")
    for key in parents:
        document = document[int(key) if key.isdigit() else key]
    if value is DELETE:
        del document[int(last) if last.isdigit() else last]
    else:
        document[int(last) if last.isdigit() else last] = value


DELETE = object()
S = "solver_settings"
BAD = [  # (what, key path in the CoSim file, new value, message)
    ("an unknown wrapper type", f"{S}/solvers/structure/type", "solver_wrappers.sdof.sdof_solver_wrapper",
     r"line \d+: 'solver_settings.solvers.structure.type': 'solver_wrappers.sdof.sdof_solver_wrapper' is not a "
     r"supported solver wrapper \(supported: solver_wrappers.kratos.fluid_dynamics_wrapper"),
    ("a missing input_file", f"{S}/solvers/fluid/solver_wrapper_settings/input_file", "ProjectParametersCFDD",
     r"'solver_settings.solvers.fluid.solver_wrapper_settings.input_file': '.*ProjectParametersCFDD.json' does not "
     r"exist"),
    ("a model part that does not exist", f"{S}/solvers/structure/data/disp/model_part_name", "Structure.Interface",
     r"'solver_settings.solvers.structure.data.disp.model_part_name': model part 'Structure.Interface' does not "
     r"exist in structure's mesh \(it has: Structure, Structure.DISPLACEMENT_BCDisp"),
    ("an accelerator setting of the wrong type", f"{S}/convergence_accelerators/0/horizon", "15",
     r"'solver_settings.convergence_accelerators.0.horizon': must be an integer, got '15'"),
    ("a mapper between data of different dimension", f"{S}/solvers/structure/data/load/dimension", 3,
     r"'solver_settings.coupling_sequence.1.input_data_list.0': 'fluid.load' has dimension 2 and 'structure.load' "
     r"has 3: kratos_mapping cannot map between them"),
    ("an unknown coupled solver", f"{S}/type", "coupled_solvers.block_strong",
     r"'solver_settings.type': 'coupled_solvers.block_strong' is not supported \(supported: "
     r"coupled_solvers.gauss_seidel_strong"),
    ("a refused accelerator", f"{S}/convergence_accelerators/0/type", "anderson",
     r"'anderson' \(Anderson acceleration\) is not supported \(supported: constant_relaxation, aitken, iqnils, mvqn\)"),
    ("ibqnls", f"{S}/convergence_accelerators/0/type", "block_ibqnls",
     r"'block_ibqnls' \(a block accelerator\) is not supported"),
    ("an unknown criterion", f"{S}/convergence_criteria/0/type", "absolute_norm_energy_conjugate",
     r"'absolute_norm_energy_conjugate' is not supported \(supported: relative_norm_previous_residual, "
     r"relative_norm_initial_residual\)"),
    ("a refused predictor", f"{S}/predictors/0/type", "average_value_based",
     r"'average_value_based' \(a predictor\) is not supported \(supported: linear\)"),
    ("an unknown mapper", f"{S}/data_transfer_operators/mapper/mapper_settings/mapper_type", "barycentric",
     r"'barycentric' is not supported \(supported: nearest_neighbor"),
    ("add_values", f"{S}/coupling_sequence/1/input_data_list/0/data_transfer_operator_options", ["add_values"],
     r"'add_values' is not supported for kratos_mapping \(supported: swap_sign, use_transpose"),
    ("distribute_values", f"{S}/coupling_sequence/1/input_data_list/0/data_transfer_operator_options",
     ["distribute_values"], r"'distribute_values' is not supported for kratos_mapping"),
    ("an undefined transfer operator", f"{S}/coupling_sequence/1/output_data_list/0/data_transfer_operator", "map",
     r"no data transfer operator 'map' \(defined: mapper\)"),
    ("an unknown solver in the sequence", f"{S}/coupling_sequence/0/name", "fluidd",
     r"'solver_settings.coupling_sequence.0.name': no solver 'fluidd' \(solvers: fluid, structure\)"),
    ("data a solver lacks", f"{S}/convergence_criteria/0/data_name", "displacement",
     r"solver 'fluid' has no data 'displacement' \(it has: disp, load\)"),
    ("a misspelt accelerator setting", f"{S}/convergence_accelerators/0/horizonn", 5,
     r"'solver_settings.convergence_accelerators.0.horizonn': is not a setting of 'mvqn' \(its settings: .*horizon"),
    ("a non-nodal location", f"{S}/solvers/fluid/data/load/location", "element",
     r"'element' is not supported \(supported: node_historical, node_non_historical\)"),
    ("a negative relaxation", f"{S}/convergence_accelerators/0/alpha", -0.1,
     r"'solver_settings.convergence_accelerators.0.alpha': must be positive, got -0.1"),
    ("an accelerator on data going forward", f"{S}/convergence_accelerators/0/data_name", "load",
     r"'fluid.load' goes from 'fluid' to 'structure'; in a Gauss-Seidel sequence \(fluid, structure\) only data "
     r"going back to 'fluid' can be accelerated"),
    ("no end time", "problem_data/end_time", DELETE, r"'problem_data.end_time': is missing"),
    ("100000 threads", f"{S}/solvers/structure/solver_wrapper_settings/num_threads", 100000,
     r"'solver_settings.solvers.structure.solver_wrapper_settings.num_threads': 100000 threads; from 1 to \d+"),
    ("an end time of 1e9", "problem_data/end_time", 1e9,
     r"'problem_data.end_time': 1e\+09 makes 1e\+10 windows of 0.1 s; at most 10,000,000 are allowed"),
    ("an infinite end time", "problem_data/end_time", float("inf"), r"not valid JSON \(Infinity is not JSON"),
    ("a criterion on the other end of the accelerated data", f"{S}/convergence_criteria/0/solver", "structure",
     r"the criterion is on the source of 'disp' and the accelerator on its target; put both on the same data"),
    ("a coupling operation", f"{S}/coupling_operations", {"scale": {"type": "scaling"}},
     r"'solver_settings.coupling_operations': coupling operations are not supported by cosim"),
]


@needs_gmsh
@pytest.mark.parametrize("what, path, value, message", BAD, ids=[b[0] for b in BAD])
def test_a_bad_cosimulation_file_is_one_line_naming_its_file_line_and_key(wall_case, tmp_path, capsys, what, path,
                                                                          value, message):
    import re
    import shutil
    folder = tmp_path / "case"
    shutil.copytree(wall_case, folder)
    document = json.loads((folder / "ProjectParametersCoSim.json").read_text())
    edit(document, path, value if value is DELETE else copy.deepcopy(value))
    (folder / "ProjectParametersCoSim.json").write_text(json.dumps(document, indent=4))
    code = main(["check", str(folder / "case.toml")])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert "\n" not in err and "Traceback" not in err, err
    assert "ProjectParametersCoSim.json" in err, err
    assert re.search(message, err), err


@needs_gmsh
def test_a_solvers_input_file_that_is_a_fifo_is_named_as_one_not_as_missing(wall_case, tmp_path, capsys):
    import os
    import shutil
    folder = tmp_path / "case"
    shutil.copytree(wall_case, folder)
    os.mkfifo(folder / "fifo.json")
    document = json.loads((folder / "ProjectParametersCoSim.json").read_text())
    edit(document, f"{S}/solvers/structure/solver_wrapper_settings/input_file", "fifo.json")
    (folder / "ProjectParametersCoSim.json").write_text(json.dumps(document, indent=4))
    assert main(["check", str(folder / "case.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "fifo.json' is not a regular file" in err, err


@needs_gmsh
def test_a_json_syntax_error_names_its_line(wall_case, tmp_path, capsys):
    import shutil
    folder = tmp_path / "case"
    shutil.copytree(wall_case, folder)
    lines = (folder / "ProjectParametersCoSim.json").read_text().splitlines()
    lines[6] = lines[6] + ","          # a second comma on line 7, inside problem_data
    (folder / "ProjectParametersCoSim.json").write_text("\n".join(lines))
    assert main(["check", str(folder / "case.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "ProjectParametersCoSim.json, line 7: not valid JSON" in err, err


@needs_gmsh
def test_the_case_becomes_a_scene_with_kratos_settings_as_plugins(wall_case, capsys):
    from cosim.scene import load_scene
    scene = load_scene(wall_case / "case.toml", ["coupling.max_iterations=12"]).data
    coupling = scene["coupling"]
    assert coupling["scheme"] == "serial-implicit" and coupling["participants"] == ["fluid", "structure"]
    assert coupling["max_iterations"] == 12 and coupling["on_max_iterations"] == "accept"   # --set wins
    assert coupling["acceleration"]["type"] == "kratos-mvqn" and coupling["acceleration"]["data"] == ["disp"]
    assert coupling["extrapolation_order"] == 0          # Kratos's linear predictor on a cloned buffer
    load = next(e for e in scene["exchange"] if e["data"] == "load")
    assert load["scale"] == -1.0 and load["mapping"] == {"type": "nearest-neighbour", "constraint": "conservative"}
    assert scene["time"] == {"start": 0.0, "end": pytest.approx(0.3), "dt": 0.1}


@needs_gmsh
def test_the_cosimulation_file_alone_is_the_same_case(wall_case):
    """``cosim run ProjectParametersCoSim.json`` reads the file as its case.toml does (the reader by its suffix)."""
    from cosim.scene import load_scene
    alone = load_scene(wall_case / "ProjectParametersCoSim.json").data
    case = load_scene(wall_case / "case.toml").data
    assert alone["coupling"] == case["coupling"] and alone["exchange"] == case["exchange"]
    assert alone["components"] == case["components"] and alone["time"] == case["time"]


@needs_kratos
@needs_gmsh
@needs_cosim_application
def test_both_cases_give_kratoss_iterations_and_fields_under_cosim():
    """cosim run on the unmodified files against Kratos's own coupled analysis of them (5 windows, coarse mesh)."""
    from benchmarks.kratos_case import main as benchmark
    results = benchmark(["--small"])
    for kind in ("static", "dynamic"):
        result = results[kind]
        assert result["iterations"] == result["kratos_iterations"], kind
        assert sum(result["iterations"]) > 2 * len(result["iterations"]), kind     # it iterated
        for name, difference in result["fields"].items():
            assert difference <= 5e-3, (kind, name, difference)


@needs_kratos
@needs_gmsh
def test_a_kratos_case_resumes_with_the_structure_s_inertia(tmp_path, monkeypatch):
    """The dynamic wall stopped after window 3 and resumed from its checkpoint (Kratos's serialised model
    parts and the data entries' last inputs): the same iterations and fields as the run that went through."""
    from cases.kratos_wall.write import write_case
    from cosim.checkpoint import read
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_restart import stopped_at
    case = write_case(tmp_path / "case", "dynamic", 6)
    overrides = ["output.checkpoint_every=2"]
    run_scene(load_scene(case, overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(3, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(case, overrides), tmp_path / "cut", progress=False)
    assert read(tmp_path / "cut" / "checkpoint.npz")[0]["windows"] == 3      # written at the stop
    run_scene(load_scene(case, overrides), tmp_path / "cut", progress=False, resume=True)
    with RunResults(tmp_path / "whole") as whole, RunResults(tmp_path / "cut") as cut:
        np.testing.assert_array_equal(cut.windows.iterations, whole.windows.iterations)
        assert len(cut.windows.iterations) == 6
        for name, values in whole.fields().items():
            assert np.abs(cut.fields()[name] - values).max() <= 1e-8 * np.abs(values).max(), name


@needs_kratos
@needs_gmsh
def test_a_rom_trains_on_the_recorded_calls_it_is_told_to(wall_case, tmp_path):
    """Every recorded call of the structure, the converged ones, or all but each window's unconverged first (the
    predicted iterate): the calls the training reads (``snapshots.converged_only``, ``skip_first_iteration``)."""
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from rom_component.recorded import recorded_calls
    run_scene(load_scene(wall_case / "case.toml"), tmp_path / "run", progress=False)
    spec = {"component": "structure", "input": "load", "output": "disp", "field": "disp_field"}
    every, _ = recorded_calls(tmp_path / "run", {**spec, "skip_first_iteration": False})
    converged, _ = recorded_calls(tmp_path / "run", {**spec, "skip_first_iteration": False}, converged_only=True)
    later, _ = recorded_calls(tmp_path / "run", {**spec, "skip_first_iteration": True})
    windows = int(every.window.max())
    assert len(converged) == windows and converged.converged.all()
    first_unconverged = int(((every.iteration == 1) & ~every.converged).sum())
    assert first_unconverged == windows             # no window converged at its first iteration here
    assert len(later) == len(every) - first_unconverged and ((later.iteration > 1) | later.converged).all()
    np.testing.assert_array_equal(later.outputs["disp_field"], every.outputs["disp_field"][every.iteration > 1])
    assert assert_xdmf_holds_the_run(tmp_path / "run") >= 2 * windows     # the case's run opens in ParaView


def arc(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes on a half ellipse and the line elements joining them in order."""
    nodes = np.stack([np.cos(theta), 0.5 * np.sin(theta)], axis=1)
    return nodes, np.stack([np.arange(len(nodes) - 1), np.arange(1, len(nodes))], axis=1)


def test_nearest_element_interpolates_on_the_senders_lines_and_its_transpose_keeps_sums():
    from coupler.mapping import make_mapping
    source, lines = arc(np.linspace(0.0, np.pi, 17))
    target, target_lines = arc(np.sort(np.random.default_rng(1).uniform(0.0, np.pi, 23)))
    linear = source @ np.array([[2.0, -1.0], [0.5, 3.0]]) + 1.0           # linear along each line: exact
    mapping = make_mapping({"type": "nearest-element", "constraint": "consistent"}, source, target,
                           (17, 2), (23, 2), "test", lines, None)
    exact = []
    for x in target:            # the interpolation on the line of the point's projection, by hand
        best = min(range(len(lines)), key=lambda j: _distance(x, source[lines[j, 0]], source[lines[j, 1]]))
        a, b = source[lines[best, 0]], source[lines[best, 1]]
        s = float(np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        exact.append((1 - s) * linear[lines[best, 0]] + s * linear[lines[best, 1]])
    np.testing.assert_allclose(mapping(linear), np.array(exact), rtol=0, atol=1e-13)
    forces = np.random.default_rng(2).normal(size=(17, 2))
    conservative = make_mapping({"type": "nearest-element", "constraint": "conservative"}, source, target,
                                (17, 2), (23, 2), "test", None, target_lines)
    np.testing.assert_allclose(conservative(forces).sum(axis=0), forces.sum(axis=0), rtol=1e-13, atol=1e-13)


def _distance(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    s = float(np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
    return float(np.linalg.norm(x - (a + s * (b - a))))


def test_nearest_element_without_the_senders_lines_is_refused_naming_them():
    from cosim.errors import SceneError
    from coupler.mapping import make_mapping
    source, _ = arc(np.linspace(0.0, np.pi, 5))
    with pytest.raises(SceneError, match=r"exchange.1 \(disp\): nearest-element mapping \(consistent\) needs the "
                                         r"line elements of the sender's mesh"):
        make_mapping({"type": "nearest-element", "constraint": "consistent"}, source, source, (5, 2), (5, 2),
                     "exchange.1 (disp)", None, None)


@needs_cosim_application
@pytest.mark.parametrize("beyond", [0.1, 0.6])
def test_nearest_element_is_kratoss_mapper(beyond):
    """Against Kratos's MappingApplication on non-matching lines, target nodes reaching beyond the sender's ends
    (extrapolated within the local coordinate tolerance, else the nearest node): consistent and transposed."""
    import KratosMultiphysics as KM
    import KratosMultiphysics.MappingApplication  # noqa: F401

    from coupler.mapping import make_mapping
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)

    def part(model, name: str, theta: np.ndarray):
        nodes, lines = arc(theta)
        mp = model.CreateModelPart(name)
        mp.AddNodalSolutionStepVariable(KM.DISPLACEMENT)
        mp.ProcessInfo[KM.DOMAIN_SIZE] = 2
        for i, (x, y) in enumerate(nodes):
            mp.CreateNewNode(i + 1, x, y, 0.0)
        for j, (a, b) in enumerate(lines):
            mp.CreateNewCondition("LineCondition2D2N", j + 1, [int(a) + 1, int(b) + 1], mp.GetProperties()[0])
        return mp, nodes, lines

    def values(mp) -> np.ndarray:
        return np.array([[n.GetSolutionStepValue(KM.DISPLACEMENT)[k] for k in (0, 1)] for n in mp.Nodes])

    model = KM.Model()
    origin, source, lines = part(model, "origin", np.linspace(0.0, np.pi, 17))
    destination, target, target_lines = part(
        model, "destination", np.sort(np.random.default_rng(1).uniform(-beyond, np.pi + beyond, 40)))
    given = np.stack([source[:, 0] ** 2 + source[:, 1], np.sin(3 * source[:, 0])], axis=1)
    for node, v in zip(origin.Nodes, given):
        node.SetSolutionStepValue(KM.DISPLACEMENT, [v[0], v[1], 0.0])
    mapper = KM.MapperFactory.CreateMapper(origin, destination,
                                           KM.Parameters('{"mapper_type": "nearest_element", "echo_level": 0}'))
    for flags, constraint in ((KM.Flags(), "consistent"), (KM.Mapper.USE_TRANSPOSE, "conservative")):
        mapper.Map(KM.DISPLACEMENT, KM.DISPLACEMENT, flags)
        ours = make_mapping({"type": "nearest-element", "constraint": constraint}, source, target, given.shape,
                            target.shape, "test", lines, target_lines)(given)
        np.testing.assert_allclose(ours, values(destination), rtol=0, atol=1e-12)


CSM_BAD = [  # (what, key path in ProjectParametersCSM.json, new value, message)
    ("solver_settings as a list", "solver_settings", [1], r"'solver_settings': must be an object, got \[1\]"),
    ("time_stepping as a list", "solver_settings/time_stepping", [], r"'solver_settings.time_stepping': must be an "
                                                                     r"object, got \[\]"),
    ("model_import_settings as a string", "solver_settings/model_import_settings", "structure",
     r"'solver_settings.model_import_settings': must be an object, got \"structure\""),
    ("input_filename a number", "solver_settings/model_import_settings/input_filename", 5,
     r"'solver_settings.model_import_settings.input_filename': must be a string, got 5"),
    ("model_part_name a number", "solver_settings/model_part_name", 7,
     r"'solver_settings.model_part_name': must be a string, got 7"),
]


@needs_gmsh
@pytest.mark.parametrize("what, path, value, message", CSM_BAD, ids=[b[0] for b in CSM_BAD])
def test_a_solver_s_bad_parameters_are_one_line_naming_the_key(wall_case, tmp_path, capsys, what, path, value, message):
    import re
    import shutil
    folder = tmp_path / "case"
    shutil.copytree(wall_case, folder)
    document = json.loads((folder / "ProjectParametersCSM.json").read_text())
    edit(document, path, value)
    (folder / "ProjectParametersCSM.json").write_text(json.dumps(document, indent=4))
    assert main(["check", str(folder / "case.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    assert "ProjectParametersCSM.json" in err and re.search(message, err), err


@needs_gmsh
def test_the_json_reader_takes_what_kratos_takes_and_refuses_what_it_refuses(wall_case, tmp_path, capsys):
    """Kratos's parser takes comments and a byte order mark, and refuses NaN and Infinity; a number of thousands of
    digits, nesting thousands deep and an interval of strings are one line each, not a traceback."""
    import shutil
    folder = tmp_path / "case"
    shutil.copytree(wall_case, folder)
    cosim = folder / "ProjectParametersCoSim.json"
    original = cosim.read_text()
    cosim.write_text("\ufeff// a Kratos case\n" + original.replace("{", "{ /* the top */", 1))
    assert main(["check", str(folder / "case.toml")]) == 0, capsys.readouterr().err
    capsys.readouterr()
    document = json.loads(original)
    document["problem_data"]["echo_level"] = 123456.5           # where each raw value below is put
    document["solver_settings"]["coupling_sequence"][1]["input_data_list"][0]["interval"] = ["a", "b"]
    with_interval = json.dumps(document)
    del document["solver_settings"]["coupling_sequence"][1]["input_data_list"][0]["interval"]
    for what, raw, message in (("NaN", "NaN", "NaN is not JSON (Kratos refuses it)"),
                               ("Infinity", "-Infinity", "-Infinity is not JSON (Kratos refuses it)"),
                               ("digits", "9" * 5001, "a number of more digits than Python reads"),
                               ("nesting", "[" * 2000 + "]" * 2000, "objects and arrays nested more than 64 deep"),
                               ("interval", None, "must be [start, end] of numbers")):
        text = with_interval.replace("123456.5", "0") if raw is None else json.dumps(document).replace("123456.5", raw)
        cosim.write_text(text)
        assert main(["check", str(folder / "case.toml")]) == 2, what
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "Traceback" not in err and message in err, (what, err)


@needs_kratos
@needs_gmsh
def test_a_kratos_case_resumes_only_with_the_solvers_files_it_started_with(tmp_path, monkeypatch):
    """A solver's own files (its ProjectParameters, its materials, its mesh) changed after the stop: --resume is
    refused naming the file (it went on with the new Newmark-to-Bossak scheme, 17 of 25 datasets different)."""
    from cases.kratos_wall.write import write_case
    from cosim.checkpoint import CheckpointError
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_restart import stopped_at
    case = write_case(tmp_path / "case", "dynamic", 6)
    overrides = ["output.checkpoint_every=2"]
    with monkeypatch.context() as patch:
        stopped_at(3, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(case, overrides), tmp_path / "cut", progress=False)
    for name, old, new, label in (("ProjectParametersCSM.json", '"newmark"', '"bossak"', "project"),
                                  ("StructuralMaterials.json", "YOUNG_MODULUS", "YOUNG_MODULUS", "materials")):
        path = case.parent / name
        original = path.read_text()
        assert old in original, name
        changed = original.replace(old, new) if old != new else original.replace('"Variables"', '"Variables" ', 1)
        assert changed != original, name
        path.write_text(changed)
        with pytest.raises(CheckpointError, match=rf"'components.structure.parameters.inputs.{label}' \(.*{name}\) "
                                                  r"is not the file the run started with"):
            run_scene(load_scene(case, overrides), tmp_path / "cut", progress=False, resume=True)
        path.write_text(original)


@needs_kratos
@needs_gmsh
def test_a_kratos_cases_own_vtk_output_goes_into_each_runs_directory(tmp_path):
    """The structure's vtk_output_process of the case writes under DIR/kratos/<solver>/ of each run, never into
    the case's folder, so that two runs of one case keep their own files; VTK reads the last one back with the
    displacement the run recorded."""
    from cases.kratos_wall.write import write_case
    from cosim.scene import load_scene
    from coupler.run import run_scene
    legacy = pytest.importorskip("vtkmodules.vtkIOLegacy", reason="VTK's Python wheel reads the files back")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    case = write_case(tmp_path / "case", "dynamic", 2)
    parameters = case.parent / "ProjectParametersCSM.json"
    document = json.loads(parameters.read_text())
    document["output_processes"] = {"vtk_output": [{
        "python_module": "vtk_output_process", "kratos_module": "KratosMultiphysics", "process_name": "VtkOutputProcess",
        "Parameters": {"model_part_name": "Structure", "output_control_type": "step", "output_interval": 1,
                       "file_format": "ascii", "output_precision": 16, "output_path": "vtk_output",
                       "nodal_solution_step_data_variables": ["DISPLACEMENT"]}}]}
    parameters.write_text(json.dumps(document, indent=1))
    before = sorted(p.name for p in case.parent.iterdir())
    for run in ("first", "second"):
        run_scene(load_scene(case), tmp_path / run, progress=False)
    assert sorted(p.name for p in case.parent.iterdir()) == before          # nothing written into the case
    written = [sorted((tmp_path / run / "kratos").rglob("*.vtk")) for run in ("first", "second")]
    assert len(written[0]) == len(written[1]) >= 2 and written[0][0].parent.name == "vtk_output"
    assert [p.name for p in written[0]] == [p.name for p in written[1]]
    reader = legacy.vtkUnstructuredGridReader()
    reader.SetFileName(str(max(written[0], key=lambda p: p.stat().st_mtime)))
    reader.ReadAllVectorsOn()
    reader.Update()
    grid = reader.GetOutput()
    displacement = vtk_to_numpy(grid.GetPointData().GetArray("DISPLACEMENT"))
    assert grid.GetNumberOfPoints() > 0 and np.isfinite(displacement).all() and np.abs(displacement).max() > 0
