"""The double-flap scene: mappings on the real interfaces, the Kratos solid and fluid components,
an in-process coupling of both, and three windows through real processes."""

import os
import re
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import ComponentError
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.accelerations.quasi_newton import IQNILS
from coupler.mapping import make_mapping
from coupler.run import run_scene
from tests.conftest import needs_kratos
from tests.xdmf_check import assert_xdmf_holds_the_run

pytestmark = needs_kratos

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "double_flap.toml"
MESHES = ROOT / "scenes" / "double_flap"
DT = 0.008


def mdpa_sub_model_part_nodes(path: Path, part: str) -> np.ndarray:
    """Coordinates (x, y) of a sub-model part's nodes, in node-id order, read from an .mdpa file."""
    text = path.read_text()
    nodes_block = re.search(r"Begin Nodes\n(.*?)End Nodes", text, re.S).group(1)
    table = np.array([line.split() for line in nodes_block.strip().splitlines()], dtype=float)
    coordinates = dict(zip(table[:, 0].astype(int), table[:, 1:3]))
    block = re.search(rf"Begin SubModelPart {part}\b.*?Begin SubModelPartNodes\n(.*?)End SubModelPartNodes", text, re.S)
    ids = sorted(int(i) for i in block.group(1).split())
    return np.array([coordinates[i] for i in ids])


@pytest.fixture(scope="module")
def interfaces():
    fluid = mdpa_sub_model_part_nodes(MESHES / "fluid.mdpa", "NoSlip2D_Interface")
    solid = mdpa_sub_model_part_nodes(MESHES / "solid.mdpa", "StructureInterface2D_Struc_Fsi")
    assert len(fluid) == len(solid) == 265
    return fluid, solid


MAPPINGS = [{"type": "nearest-neighbour"}, {"type": "rbf", "support_radius": 0.02}]


@pytest.mark.parametrize("settings", MAPPINGS, ids=["nearest-neighbour", "rbf"])
def test_conservative_mapping_keeps_the_total_force_on_the_real_interfaces(interfaces, settings):
    fluid, solid = interfaces
    forces = np.random.default_rng(0).standard_normal((265, 2)) * [3.0, 0.5]
    mapping = make_mapping({**settings, "constraint": "conservative"}, fluid, solid, (265, 2), (265, 2), "force")
    mapped = mapping(forces)
    assert mapped.shape == (265, 2)
    np.testing.assert_allclose(mapped.sum(axis=0), forces.sum(axis=0), rtol=0, atol=1e-12 * np.abs(forces).sum())


@pytest.mark.parametrize("settings", MAPPINGS, ids=["nearest-neighbour", "rbf"])
def test_consistent_mapping_reproduces_constant_fields_on_the_real_interfaces(interfaces, settings):
    fluid, solid = interfaces
    mapping = make_mapping({**settings, "constraint": "consistent"}, solid, fluid, (265, 2), (265, 2), "displacement")
    np.testing.assert_allclose(mapping(np.tile([1e-3, -2e-3], (265, 1))), np.tile([1e-3, -2e-3], (265, 1)),
                               rtol=1e-12, atol=1e-15)


def test_rbf_consistent_mapping_reproduces_linear_fields_on_the_real_interfaces(interfaces):
    fluid, solid = interfaces
    mapping = make_mapping({"type": "rbf", "support_radius": 0.02, "constraint": "consistent"}, solid, fluid,
                           (265, 2), (265, 2), "displacement")

    def linear(nodes):
        return np.column_stack([0.01 + 0.2 * nodes[:, 0] - 0.1 * nodes[:, 1], 0.3 * nodes[:, 1]])

    np.testing.assert_allclose(mapping(linear(solid)), linear(fluid), rtol=0, atol=1e-12)
    # nearest neighbour cannot: the nodes lie up to 0.38 mm apart
    nearest = make_mapping({"type": "nearest-neighbour", "constraint": "consistent"}, solid, fluid,
                           (265, 2), (265, 2), "displacement")
    assert np.abs(nearest(linear(solid)) - linear(fluid)).max() > 1e-6


@pytest.fixture
def solid():
    from kratos_solvers.solid import KratosSolid
    component = KratosSolid()
    component.instantiate({"time": {"start": 0.0, "end": 1.0, "dt": DT}, "mesh": str(MESHES / "solid.mdpa")})
    yield component
    component.close()


def test_kratos_solid_at_rest_and_in_equilibrium(solid):
    at_rest = solid.step(0.0, DT, {"force": np.zeros((265, 2))})
    assert np.abs(at_rest["displacement"]).max() < 1e-15 and np.abs(at_rest["displacement_field"]).max() < 1e-15
    loads = np.zeros((265, 2))
    loads[:, 0], loads[:, 1] = 2.0, -0.5
    solid.step(0.0, DT, {"force": loads})          # the same window again, now loaded
    out = solid.step(0.0, DT, {"force": loads})    # and once more: Kratos re-solves from its last iterate
    # loads on the clamped base's own nodes go straight into the support: the rest balances the reactions
    base = solid.interface_nodes[:, 1] == 0.0
    assert base.sum() == 2
    np.testing.assert_allclose(solid.reactions().sum(axis=0), -loads[~base].sum(axis=0), rtol=1e-9)
    assert out["displacement"][:, 0].max() > 1e-4          # pushed in +x
    field_at_interface = out["displacement_field"][[solid._node_index[n.Id] for n in solid.interface]]
    np.testing.assert_array_equal(field_at_interface, out["displacement"])
    again = solid.step(0.0, DT, {"force": loads})
    np.testing.assert_allclose(again["displacement"], out["displacement"], rtol=0, atol=1e-15)
    assert solid.take_warnings() == []


def test_the_static_solid_jumps_to_a_later_window_with_the_same_solution(solid):
    """The solid FOM kept beside a ROM takes a fallback window now and then: a static solve does not depend on
    the windows in between, only on the load."""
    from kratos_solvers.solid import KratosSolid
    loads = np.zeros((265, 2))
    loads[:, 0], loads[:, 1] = 2.0, -0.5
    stepped = [solid.step(k * DT, DT, {"force": loads * (1 + 0.1 * k)}) for k in range(6)][-1]
    jumper = KratosSolid()
    jumper.instantiate({"time": {"start": 0.0, "end": 1.0, "dt": DT}, "mesh": str(MESHES / "solid.mdpa")})
    try:
        jumper.step(0.0, DT, {"force": loads})
        jumped = jumper.step(5 * DT, DT, {"force": loads * 1.5})      # windows 1 to 4 never asked for
        jumped = jumper.step(5 * DT, DT, {"force": loads * 1.5})      # Newton from a farther start: once more
        assert np.abs(stepped["displacement"]).max() > 1e-4
        np.testing.assert_allclose(jumped["displacement_field"], stepped["displacement_field"], rtol=0,
                                   atol=1e-7 * np.abs(stepped["displacement_field"]).max())   # Newton tolerance
        with pytest.raises(ComponentError, match="cannot step back"):
            jumper.step(2 * DT, DT, {"force": loads})
    finally:
        jumper.close()


def test_fluid_and_solid_coupled_in_process_for_two_windows():
    """Gauss-Seidel with IQN-ILS on the fluid's force, driven directly (no processes)."""
    from kratos_solvers.fluid import KratosFluid
    from kratos_solvers.solid import KratosSolid
    time = {"start": 0.0, "end": 1.0, "dt": DT}
    fluid, solid = KratosFluid(), KratosSolid()
    try:
        fluid.instantiate({"time": time, "mesh": str(MESHES / "fluid.mdpa"), "flow": {"reynolds": 250.0}})
        solid.instantiate({"time": time, "mesh": str(MESHES / "solid.mdpa")})
        to_solid = make_mapping({"type": "nearest-neighbour", "constraint": "conservative"},
                                fluid.interface_nodes, solid.interface_nodes, (265, 2), (265, 2), "force")
        to_fluid = make_mapping({"type": "nearest-neighbour", "constraint": "consistent"},
                                solid.interface_nodes, fluid.interface_nodes, (265, 2), (265, 2), "displacement")
        acceleration = IQNILS(0.5, reused_time_windows=2)
        force = np.zeros((265, 2))
        for window in range(2):
            t = window * DT
            acceleration.start_window()
            for _ in range(50):
                displacement = solid.step(t, DT, {"force": to_solid(force)})["displacement"]
                new_force = fluid.step(t, DT, {"displacement": to_fluid(displacement)})["force"]
                change = np.linalg.norm(new_force - force)
                acceleration.observe(force.ravel(), new_force.ravel())
                if change < 5e-3 * np.linalg.norm(new_force) or change / np.sqrt(530) < 5e-3:
                    break
                force = acceleration.next_iterate().reshape(265, 2)
            else:
                raise AssertionError(f"window {window + 1} did not converge in 50 iterations")
            acceleration.end_window()
            force = new_force
            assert np.isfinite(force).all() and np.abs(force).sum() > 1.0
            np.testing.assert_allclose(to_solid(force).sum(axis=0), force.sum(axis=0), rtol=1e-13)
        assert displacement[:, 0].max() > 0.0       # the inflow pushes the flaps downstream
        assert fluid.take_warnings() == [] and solid.take_warnings() == []
    finally:   # the stages go before the models, in both components
        fluid.close()
        solid.close()


@pytest.fixture(scope="module")
def three_windows(tmp_path_factory):
    """A FOM-FOM run of three windows through real processes: its directory and run summary."""
    out = tmp_path_factory.mktemp("flap") / "flap"
    return out, run_scene(load_scene(SCENE, [f"time.end={3 * DT!r}"]), out, progress=False)


@pytest.fixture(scope="module")
def three_window_rom(three_windows, tmp_path_factory):
    """A ROM (r_f = r_u = 3, quadratic decoder) trained on the three windows' calls: its path and training config."""
    from rom_component.static.train import load_config, train
    config = load_config(None, ["snapshots.input=force", "snapshots.output=displacement",
                                "snapshots.field=displacement_field", "model.encoder.modes=3", "model.decoder.modes=3",
                                "model.decoder.type=quadratic", "selection.table=false"])
    model = tmp_path_factory.mktemp("rom") / "model.npz"
    train(three_windows[0] / "results.h5", model, config, echo=lambda *a: None)
    return model, config


def test_three_windows_through_real_processes(three_windows):
    out, summary = three_windows
    assert summary.windows == 3
    with RunResults(out) as run:
        assert run.windows.converged.all()
        pids = {name: run.component(name).attributes["pid"] for name in ("fluid", "solid")}
        assert len(set(pids.values()) | {os.getpid()}) == 3
        assert run.component("fluid").attributes["endpoint"].startswith("tcp://127.0.0.1:")
        calls = run.calls("solid")
        n = int(run.windows.iterations.sum())
        assert calls.inputs["force"].shape == (n, 265, 2)
        assert calls.outputs["displacement"].shape == (n, 265, 2)
        assert calls.outputs["displacement_field"].shape == (n, 1805, 2)
        assert calls.window.tolist() == [w for w, k in enumerate(run.windows.iterations, 1) for _ in range(k)]
        assert calls.converged.sum() == 3
        assert run.fields()["displacement"].shape == (3, 265, 2)
    for png in ("run.png", "tips.png", "last_window.png"):
        assert (out / png).stat().st_size > 10_000
    assert assert_xdmf_holds_the_run(out) == 2 * 4         # force and displacement, initial and three windows


def test_a_rom_learns_the_full_field_and_serves_its_interface_part(three_windows, three_window_rom):
    """Trained on the recorded displacement field (1805 x 2), the ROM's interface path u_G = K u_mean + A u~ (+ B q(u~))
    equals the full reconstruction restricted to the 265 interface nodes."""
    from rom_component import model_file
    from rom_component.static.load import load_rom
    from rom_component.static.train import interface_index
    out, (model, config) = three_windows[0], three_window_rom
    rom = load_rom(model)
    K = interface_index(out / "results.h5", config["snapshots"])
    assert K.shape == (530,) and rom.n_inputs == 530 and rom.n_outputs == 530
    with RunResults(out) as run:
        calls = run.calls("solid")
        forces, fields = calls.inputs["force"].reshape(len(calls.window), -1), calls.outputs["displacement_field"]
        interface = calls.outputs["displacement"].reshape(len(calls.window), -1)
    np.testing.assert_array_equal(fields.reshape(len(fields), -1)[:, K], interface)   # K picks the interface values
    for f in forces:
        u_G = rom(f)
        np.testing.assert_allclose(u_G, rom.full_field(rom.reduced[None])[0][K], rtol=0, atol=1e-13)
    metadata = model_file.load_arrays(model)[1]
    assert metadata["field_variable"] == "displacement_field"
    assert [(v["name"], v["mesh"], v["components"]) for v in metadata["variables"]] == \
        [("force", "interface", 2), ("displacement", "interface", 2)]


def test_the_step_error_script_replays_every_late_step_through_the_rom(three_windows, three_window_rom):
    """cases/double_flap/step_error.py: one step per pair of consecutive calls of a window from the given iteration on;
    the ROM's RBF interpolates the calls it was trained on, so the reduced displacements it answers are the solid's
    fields projected as the script projects them, and only the decoder's truncation (r_u = 3) is left on the
    interface."""
    from cases.double_flap.step_error import step_errors
    out, model = three_windows[0], three_window_rom[0]
    with RunResults(out) as run:
        iterations = run.windows.iterations
    for first in (2, 3):
        e = step_errors(out / "results.h5", model, (1, 3), first)
        assert int(e["steps"]) == int(np.maximum(iterations - first + 1, 0).sum())
        assert e["reduced_steps"].shape == e["reduced_levels"].shape == (3,)
        assert e["reduced_steps"].max() < 1e-8 and e["reduced_levels"].max() < 1e-8
    assert 0 < e["interface_levels"] < 0.01 and 0 < e["interface_steps"] < 0.05


def test_the_report_measures_a_double_flap_rom_on_the_whole_field(tmp_path):
    """FOM-FOM for six windows; a ROM trained on the first three serves the last three; e(t) on the 1805 x 2 field."""
    from rom_component.report.compare import Run, compare
    from rom_component.static.train import load_config, train
    fom = tmp_path / "fom"
    run_scene(load_scene(SCENE, [f"time.end={6 * DT!r}"]), fom, progress=False)
    config = load_config(None, ["snapshots.input=force", "snapshots.output=displacement",
                                "snapshots.field=displacement_field", f"snapshots.t_max={3 * DT!r}",
                                "model.encoder.modes=4", "model.decoder.modes=4", "selection.table=false"])
    train(fom / "results.h5", tmp_path / "model.npz", config, echo=lambda *a: None)
    rom = tmp_path / "rom"
    run_scene(load_scene(SCENE, [f"time.end={6 * DT!r}", "components.solid.backend=rom",
                                 f"components.solid.rom.model={tmp_path / 'model.npz'}",
                                 f"components.solid.rom.switch_time={3 * DT!r}"]), rom, progress=False)
    run, reference = Run.read(rom), Run.read(fom)
    field = reference.displacement_field("solid", "displacement_field")
    assert field.shape == (6, 3610) and np.isfinite(field).all()
    served = run.displacement_field("solid", "displacement_field")
    assert served.shape == (6, 3610) and np.isfinite(served).all()     # FOM windows recorded, ROM windows rebuilt
    np.testing.assert_array_equal(served[:3], field[:3])                # the same FOM solves before the switch
    row = compare(run, reference)
    assert row["predicted_windows"] == 3 and 0.0 < row["displacement_error"]["mean"] < 0.5


def test_the_solid_seen_through_a_roms_bases_answers_with_their_projection(tmp_path, three_window_rom):
    """The diagnostic solid (rom_component.static.projected) returns, from its from_time on, the ROM decoder's image of
    its own displacement field's projection; with rom_modes, those reduced displacements come from the ROM."""
    from rom_component.static.load import load_rom
    model = three_window_rom[0]
    rom = load_rom(model)
    a = rom.arrays
    for rom_modes in ([], [1]):
        out = tmp_path / f"projected{len(rom_modes)}"
        parameters = (f"{{mesh='{MESHES / 'solid.mdpa'}', model='{model}', project='both', "
                      f"from_time={2 * DT!r}, rom_modes={rom_modes}}}")
        overrides = [f"time.end={4 * DT!r}", "components.solid.entry='rom_component.static.projected:ProjectedSolid'",
                     f"components.solid.parameters={parameters}"]
        run_scene(load_scene(SCENE, overrides), out, progress=False)
        with RunResults(out) as run:
            calls = run.calls("solid")
            fields = calls.outputs["displacement_field"].reshape(len(calls.window), -1)
            served = calls.outputs["displacement"].reshape(len(calls.window), -1)
            forces = calls.inputs["force"].reshape(len(calls.window), -1)
        late = calls.window >= 3
        reduced = (fields - a["u_mean"]) @ a["Phi_u"]
        for k in np.flatnonzero(late):
            if rom_modes:
                rom(forces[k])
                reduced[k, 0] = rom.reduced[0]
        i, j = np.triu_indices(3)
        decoded = a["base"] + reduced @ a["A"].T + (reduced[:, i] * reduced[:, j]) @ a["B"].T
        np.testing.assert_allclose(served[late], decoded[late], rtol=0, atol=1e-12 * np.abs(served).max())
        assert np.abs(served[~late] - decoded[~late]).max() > 1e-6 * np.abs(served).max()   # the solid's own before
    with pytest.raises(Exception, match="'project' is 'all'"):
        from rom_component.static.projected import ProjectedSolid
        ProjectedSolid().instantiate({"mesh": str(MESHES / "solid.mdpa"), "model": str(model),
                                      "project": "all", "time": {"end": 1.0, "dt": DT}})


@needs_kratos
def test_a_double_flap_run_resumes_from_kratos_s_own_restart_serialisation(tmp_path, monkeypatch):
    """Kratos's fluid and solid checkpoint through Kratos's serializer. The resumed run repeats the uninterrupted
    one's coupling iterations; its fields differ at round-off, as Kratos rebuilds its system on load (measured:
    docs/restart.md)."""
    from tests.test_restart import stopped_at
    overrides = [f"time.end={6 * DT!r}", "output.checkpoint_every=2"]
    run_scene(load_scene(SCENE, overrides), tmp_path / "whole", progress=False)
    with monkeypatch.context() as patch:
        stopped_at(3, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(SCENE, overrides), tmp_path / "cut", progress=False)
    from cosim.checkpoint import read
    assert read(tmp_path / "cut" / "checkpoint.npz")[0]["windows"] == 3     # a Kratos checkpoint outlasts the stop
    run_scene(load_scene(SCENE, overrides), tmp_path / "cut", progress=False, resume=True)
    with RunResults(tmp_path / "whole") as whole, RunResults(tmp_path / "cut") as cut:
        np.testing.assert_array_equal(cut.windows.iterations, whole.windows.iterations)
        for name, values in whole.fields().items():
            assert cut.fields()[name][:3].tobytes() == values[:3].tobytes()      # before the stop: the same run
            scale = np.abs(values).max()
            assert np.abs(cut.fields()[name] - values).max() <= 1e-9 * scale, name


def test_the_roms_fmi3_fmu_serves_the_flaps_as_its_fmi2_fmu_does(three_windows, three_window_rom, tmp_path):
    """The double flap's ROM (530 interface values a call, a quadratic decoder) exported as FMI 2.0 and FMI 3.0
    (one array variable of 265 x 2 each way), each serving the third window after the Kratos solid: the two runs are
    the same, every dataset of their results files bit for bit."""
    from rom_component.fmu.export import export_fmu
    from scripts.same_bits import datasets
    model, _ = three_window_rom
    runs = []
    for fmi in (2, 3):
        fmu = export_fmu(model, tmp_path / f"flap{fmi}.fmu", fmi=fmi)
        run_scene(load_scene(SCENE, [f"time.end={3 * DT!r}", "components.solid.backend=fmu",
                                     f"components.solid.fmu.path={fmu}",
                                     f"components.solid.fmu.switch_time={2 * DT!r}"]), tmp_path / f"fmu{fmi}",
                  progress=False)
        runs.append(datasets(tmp_path / f"fmu{fmi}" / "results.h5"))
    two, three = runs
    assert len(two) > 10 and set(two) == set(three)
    assert [k for k in two if two[k] != three[k]] == []
