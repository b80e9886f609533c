"""A run's world: read and checked once, edited in memory, written once, and the copy works from any folder."""
from __future__ import annotations

import pytest

from subsim import world_path
from subsim.world import WorldDocument, WorldError, load_world


def test_the_copy_keeps_the_edits_and_finds_its_files_from_another_folder(tmp_path):
    source = world_path("pingpong")
    before = source.read_text()
    doc = WorldDocument(source)
    assert doc.world.robots[0].name == doc.robot["name"]  # the typed world of the same file
    doc.sensors.update({"laser": False, "sonar": False})
    doc.robot["start"] = [1.5, 1.0, 0.5]
    doc.data["agents"] = []
    written = doc.write(tmp_path / "deep" / "run" / "world.yaml")
    world = load_world(written)
    assert world.robots[0].laser is None and not world.agents
    assert world.robots[0].start == pytest.approx((1.5, 1.0, 0.5))
    assert doc.map_path.is_absolute() and doc.start == [1.5, 1.0, 0.5]
    assert source.read_text() == before  # the source file is never written


def test_a_bad_world_file_is_refused_before_any_edit(tmp_path):
    bad = tmp_path / "w.yaml"
    bad.write_text("map: nowhere.yaml\nrobots: [{name: r}]\n")
    with pytest.raises(WorldError, match=r"w.yaml: field 'map': no such file"):
        WorldDocument(bad)
