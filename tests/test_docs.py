"""The documentation: the scene reference is the one generated from the schema, and every key has a meaning."""

from __future__ import annotations

import re

import pytest

from cosim.reference import MissingMeaning
from cosim.scene import MEANINGS
from coupler import scene_reference
from coupler.accelerations import ACCELERATIONS
from coupler.accelerations.quasi_newton import IQNILS
from tests.conftest import ROOT


def test_the_scene_reference_page_is_the_generated_one():
    page = (ROOT / "docs/reference/scene.md").read_text()
    assert page == scene_reference.page(), \
        "docs/reference/scene.md is stale: python -m coupler.scene_reference > docs/reference/scene.md"
    for key in ("time.dt", "coupling.predictor", "rom.keep_warm", "fmu.state", "`stale_step_ratio`"):
        assert key in page


def test_a_schema_key_or_a_plug_in_setting_without_a_meaning_fails_the_reference(monkeypatch):
    monkeypatch.delitem(MEANINGS, "component.rom.switch_time")
    with pytest.raises(MissingMeaning, match="'component.rom.switch_time'"):
        scene_reference.page()
    monkeypatch.undo()
    from rom_component.static.component import ROM_HELP
    monkeypatch.delitem(ROM_HELP, "keep_warm")
    with pytest.raises(MissingMeaning, match=r"no meaning for key 'keep_warm' \(the rom backend's parameter_help\)"):
        scene_reference.page()
    monkeypatch.undo()
    monkeypatch.setitem(IQNILS.SETTINGS, "new_setting", 1.0)
    with pytest.raises(MissingMeaning, match="'iqn-ils' setting 'new_setting'"):
        scene_reference.page()
    assert "iqn-ils" in ACCELERATIONS.names()


def test_the_rom_configuration_reference_is_the_generated_one(monkeypatch):
    from rom_component import config_reference
    from rom_component.static.regression import PolynomialRegression
    from rom_component.static.train import MEANINGS as ROM_MEANINGS
    page = (ROOT / "docs/reference/rom-config.md").read_text()
    assert page == config_reference.page(), \
        "docs/reference/rom-config.md is stale: python -m rom_component.config_reference > docs/reference/rom-config.md"
    for key in ("`t_max`", "`split`", "### `poly`", "`cubic_modes`", "### `quadratic`", "`regularization`"):
        assert key in page
    monkeypatch.delitem(ROM_MEANINGS, "selection.split")
    with pytest.raises(MissingMeaning, match="'selection.split'"):
        config_reference.page()
    monkeypatch.undo()
    monkeypatch.delitem(PolynomialRegression.HELP, "cubic_modes")
    with pytest.raises(MissingMeaning, match="'poly' setting 'cubic_modes'"):
        config_reference.page()


def test_the_front_door_points_to_every_way_in_and_the_notebook_sits_under_one_heading():
    index = (ROOT / "docs" / "index.md").read_text()
    for page in ("getting-started.md", "write-a-component.md", "precice.md", "kratos.md", "fmu.md"):
        assert f"]({page})" in index, page
    assert "FMI 3.0" in index
    navigation = (ROOT / "mkdocs.yml").read_text()
    notebook = ROOT / "docs" / "notebook"
    linked = (notebook / "index.md").read_text()
    for page in sorted(notebook.glob("20*.md")):
        assert f"]({page.name})" in linked, f"{page.name} is not linked from the notebook's index"
        assert page.name not in navigation, f"{page.name} is in the navigation: the notebook has one entry"
    for picture in re.findall(r"\]\((img/[^)]+)\)", (ROOT / "docs" / "getting-started.md").read_text()):
        assert (ROOT / "docs" / picture).is_file(), picture
