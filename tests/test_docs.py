"""The documentation: the scene reference is the one generated from the schema, and every key has a meaning."""

from __future__ import annotations

import pytest

from cosim.scene import MEANINGS
from coupler import scene_reference
from coupler.acceleration import ACCELERATIONS, IQNILS
from tests.conftest import ROOT


def test_the_scene_reference_page_is_the_generated_one():
    page = (ROOT / "docs/reference/scene.md").read_text()
    assert page == scene_reference.page(), \
        "docs/reference/scene.md is stale: python -m coupler.scene_reference > docs/reference/scene.md"
    for key in ("time.dt", "coupling.predictor", "rom.keep_warm", "fmu.stateful", "`stale_step_ratio`"):
        assert key in page


def test_a_schema_key_or_a_plug_in_setting_without_a_meaning_fails_the_reference(monkeypatch):
    monkeypatch.delitem(MEANINGS, "component.rom.keep_warm")
    with pytest.raises(scene_reference.MissingMeaning, match="'component.rom.keep_warm'"):
        scene_reference.page()
    monkeypatch.undo()
    monkeypatch.setitem(IQNILS.SETTINGS, "new_setting", 1.0)
    with pytest.raises(scene_reference.MissingMeaning, match="'iqn-ils' setting 'new_setting'"):
        scene_reference.page()
    assert "iqn-ils" in ACCELERATIONS.names()
