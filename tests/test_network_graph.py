"""`subsumption graph`: a drawing with every module, the arbiters as S/I/D circles and the level legend."""
from __future__ import annotations

from test_network_files import EXAMPLE

from subsumption.network import load, wire
from subsumption.network.graph import draw, to_graph


def test_svg_names_modules_arbiters_and_levels(tmp_path):
    out = draw(wire(load(EXAMPLE), 1), tmp_path / "avoid.svg")
    svg = out.read_text()
    for name in ("feelforce", "runaway", "turn", "wander", "avoid", "cmd_vel", "avoid objects"):
        assert f">{name}<" in svg, name
    assert ">S<" in svg and ">20<" in svg  # Brooks' "S 20", in the file's units
    assert not (tmp_path / "avoid.gv").exists()


def test_png_is_written(tmp_path):
    out = draw(wire(load(EXAMPLE), 0), tmp_path / "avoid.png")
    data = out.read_bytes()
    assert data.startswith(b"\x89PNG") and len(data) > 2000


def test_level0_has_no_arbiter_and_no_level1_module():
    source = to_graph(wire(load(EXAMPLE), 0)).source
    assert "module__turn" in source and "module__wander" not in source and "arbiter__" not in source
