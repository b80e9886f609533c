"""`subsumption params`: parameter tables printed from the `Param` declarations, and the tables of docs/ kept
the same as what it prints."""
from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT

from subsumption.cli import main
from subsumption.params import generated_blocks, generated_table, markdown_table, refresh_blocks

DOCS = sorted((ROOT / "docs").glob("*.md"))


def test_the_docs_hold_generated_tables():
    """The capability pages show their modules' parameters as generated tables (not hand-written lists)."""
    targets = {target for doc in DOCS for command, target, _ in generated_blocks(doc.read_text())
               if command == "params"}
    assert {"navigation.move_base:MoveBase", "navigation.slam:Slam", "navigation.amcl:Amcl",
            "navigation.explore:Explore", "vision.modules:Detect"} <= targets


@pytest.mark.parametrize("doc", DOCS, ids=lambda path: path.name)
def test_every_generated_table_matches_the_code(doc: Path):
    text = doc.read_text()
    for command, target, table in generated_blocks(text):
        assert table == generated_table(command, target), (
            f"docs/{doc.name}: the {'parameters' if command == 'params' else 'topics'} of {target} changed; print "
            f"the tables again with `.venv/bin/python -m subsumption.params docs/*.md`")
    assert refresh_blocks(text) == text


def test_params_of_a_module_class_as_markdown(capsys):
    assert main(["params", "robots.first.cruise:Cruise", "--markdown"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "| parameter | type | default | range | what it does |"
    assert "| `cone` | float | `0.5` | 0 to 3.14159 | half-width of the 'ahead' cone, rad |" in lines


def test_info_markdown_lists_the_topics(capsys):
    assert main(["info", "robots.first.cruise:Cruise", "--markdown"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "| topic | in/out | type | what it carries |"
    assert "| `scan` | in | `sensor_msgs/LaserScan` | the laser scan, robot frame |" in lines
    assert "| `~cmd_vel` | out | `geometry_msgs/Twist` | velocity command for the base |" in lines


def test_params_of_a_network_shows_the_values_the_file_sets(capsys):
    assert main(["params", "robots/wander/wander.yaml", "--markdown"]) == 0
    out = capsys.readouterr().out
    assert "### `wander` (level 1, `robots.wander.level1:Wander`)" in out
    assert main(["params", "robots/patrol/patrol.yaml"]) == 0  # plain text, with the file's own values
    out = capsys.readouterr().out
    assert "move_base (level 3, navigation.move_base:MoveBase)" in out
    assert ", set to " in out


def test_a_parameter_doc_with_a_bar_stays_in_its_cell(tmp_path):
    from subsumption import Module, Param

    class Bar(Module):
        """A module with a parameter whose doc has a bar."""
        mode = Param("a", "a|b: which one")

    assert "| a\\|b: which one |" in markdown_table(Bar)


@pytest.mark.parametrize("target, message", [
    ("nowhere.at_all:Thing", "subsumption params: cannot import 'nowhere.at_all'"),
    ("no_such_network.yaml", "no_such_network.yaml:0: cannot read network file"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, target, message):
    assert main(["params", target]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(message) and len(err.splitlines()) == 1, err


def module_classes(packages=("subsumption", "navigation", "vision", "terminal", "robots")):
    """Every Module subclass defined in the packages (private modules left out)."""
    import importlib
    import inspect
    import pkgutil

    from subsumption import Module
    found = []
    for package in packages:
        root = importlib.import_module(package)
        for info in pkgutil.walk_packages(root.__path__, prefix=package + "."):
            if any(part.startswith("_") for part in info.name.split(".")):
                continue
            module = importlib.import_module(info.name)
            found += [value for value in vars(module).values() if inspect.isclass(value)
                      and issubclass(value, Module) and value.__module__ == info.name
                      and hasattr(value, "interface")]
    return found


def test_every_parameter_says_what_it_does():
    """A help string is more than a unit: ``"m/s"`` alone tells the unit but not what the parameter does."""
    bare = [f"{cls.__module__}:{cls.__qualname__}.{name}: {param.doc!r}"
            for cls in module_classes() for name, param in cls.interface.params.items()
            if name in vars(cls) and len(param.doc.replace(":", " ").split()) < 3]
    assert not bare, "parameters whose help says too little:\n" + "\n".join(bare)
