"""The ROM with memory of Mok's wall, through real processes: trained on a short FOM-FOM run on a coarse mesh, it
takes over from the Kratos structure at a switch time with the history it is handed, and a ROM-FOM run stopped
after the switch resumes with that history."""

from pathlib import Path

import numpy as np
import pytest

from tests.conftest import needs_kratos
from tests.test_mok import COARSE, needs_gmsh, private_cache  # noqa: F401  (autouse: meshes in a private cache)

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "mok.toml"
COARSE_SETTINGS = [*(f"mesh.{key}={value}" for key, value in COARSE.items()), "time.end=2.0",
                   "output.checkpoint_every=2"]
SWITCH = 1.5


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A 20-window FOM-FOM run on the coarse mesh and a step map trained on its first 15 windows."""
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from rom_component.dynamic.train import train_step_map
    from rom_component.static.train import load_config
    folder = tmp_path_factory.mktemp("mok-rom")
    with pytest.MonkeyPatch.context() as patch:     # the meshes go to this session's cache, never to the user's
        patch.setenv("COSIM_CACHE", str(tmp_path_factory.getbasetemp() / "mok-cache"))
        run_scene(load_scene(SCENE, COARSE_SETTINGS), folder / "fom", progress=False)
    config = load_config(ROOT / "rom_configs" / "mok_rom.toml", [f"snapshots.t_max={SWITCH}", "selection.force_modes=[4, 8]",
                                                             "selection.disp_modes=[4]", "dynamics.history=[2, 3]"])
    metadata = train_step_map(folder / "fom" / "results.h5", folder / "model.npz", config, echo=lambda *_: None)
    return folder, metadata


def rom_settings(model: Path) -> list[str]:
    return [*COARSE_SETTINGS, "components.structure.backend=rom", f"components.structure.rom.model={model}",
            f"components.structure.rom.switch_time={SWITCH}"]


@needs_gmsh
@needs_kratos
def test_the_rom_takes_over_the_wall_with_its_history_and_follows_the_fom(trained):
    """Handed the structure's last converged windows, the ROM goes on where the structure was: point A stays within
    2 % of the FOM-FOM run's deflection over the served windows (from rest it would start at zero), and every window
    converges. The model file says what the hold-out chose and how stable its map is."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    folder, metadata = trained
    assert metadata["kind"] == "step-map" and metadata["history"] in (2, 3) and metadata["radius_served"] <= 1.0
    assert metadata["probes"] == ["point_a", "point_b"]
    run_scene(load_scene(SCENE, rom_settings(folder / "model.npz")), folder / "rom", progress=False)
    with RunResults(folder / "rom") as rom, RunResults(folder / "fom") as fom:
        assert rom.windows.converged.all() and len(rom.windows) == 20
        served = rom.windows.time > SWITCH + 0.05
        a_rom = rom.calls("structure", converged_only=True).outputs["point_a"][:, 0]
        a_fom = fom.calls("structure", converged_only=True).outputs["point_a"][:, 0]
        np.testing.assert_array_equal(a_rom[~served], a_fom[~served])       # the FOM's windows, as they were
        assert np.abs(a_rom[served] - a_fom[served]).max() < 0.02 * np.abs(a_fom).max()
        final = rom.component("structure_rom").final
        assert len(final["time"]) == served.sum() and final["full_field"].shape == (served.sum(), 2 * 63)


@needs_gmsh
@needs_kratos
def test_a_rom_fom_run_stopped_after_the_switch_resumes_with_the_rom_s_history(trained, monkeypatch):
    """The checkpoint carries the ROM's history and the schedule's record of the converged windows: stopped two
    windows after the switch and resumed, the run repeats the uninterrupted one (to Kratos's round-off)."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from tests.test_restart import stopped_at
    folder, _ = trained
    settings = rom_settings(folder / "model.npz")
    whole, cut = folder / "rom_whole", folder / "rom_cut"
    run_scene(load_scene(SCENE, settings), whole, progress=False)
    with monkeypatch.context() as patch:
        stopped_at(18, patch)
        with pytest.raises(KeyboardInterrupt):
            run_scene(load_scene(SCENE, settings), cut, progress=False)
    run_scene(load_scene(SCENE, settings), cut, progress=False, resume=True)
    with RunResults(whole) as a, RunResults(cut) as b:
        np.testing.assert_array_equal(b.windows.iterations, a.windows.iterations)
        pa, pb = (r.calls("structure", converged_only=True).outputs["point_a"] for r in (a, b))
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-8 * np.abs(pa).max())


@needs_gmsh
@needs_kratos
def test_the_roms_fmi3_fmu_takes_over_the_wall_as_its_fmi2_fmu_does(trained):
    """The step map exported as FMI 2.0 and FMI 3.0, each taking over from the Kratos structure at the switch with
    the history it is handed (through the FMU's take-over and its state): the two runs are the same, every dataset
    of their results files bit for bit."""
    from cosim.scene import load_scene
    from coupler.run import run_scene
    from rom_component.fmu.export import export_fmu
    from scripts.same_bits import datasets
    folder, _ = trained
    runs = []
    for fmi in (2, 3):
        fmu = export_fmu(folder / "model.npz", folder / f"wall{fmi}.fmu", fmi=fmi)
        settings = [*COARSE_SETTINGS, "output.checkpoint_every=0", "components.structure.backend=fmu",
                    f"components.structure.fmu.path={fmu}", f"components.structure.fmu.switch_time={SWITCH}"]
        run_scene(load_scene(SCENE, settings), folder / f"fmu{fmi}", progress=False)
        runs.append(datasets(folder / f"fmu{fmi}" / "results.h5"))
    two, three = runs
    assert len(two) > 10 and set(two) == set(three)
    assert [k for k in two if two[k] != three[k]] == []
