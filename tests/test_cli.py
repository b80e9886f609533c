"""The `subsumption` command: exit statuses and output of check, graph, launch --write-only, info, and plugins."""
from __future__ import annotations

import importlib.metadata
import textwrap

import pytest
from test_network_files import EXAMPLE, LEVEL0, write

from subsumption import cli


def run(capsys, *argv: str) -> tuple[int, str, str]:
    status = cli.main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_check_ok_prints_one_line(capsys):
    status, out, err = run(capsys, "check", str(EXAMPLE))
    assert status == 0 and err == ""
    assert out.splitlines() == [f"{EXAMPLE}: OK: network avoid_demo, levels 0..1 (of 0..1), 5 modules, "
                                f"1 arbiters, 6 topics"]


def test_check_reports_every_error_and_fails(capsys, tmp_path):
    path = write(tmp_path, LEVEL0.replace("time_unit: 0.1", "time_unit: 0.1\ncolour: red")
                 .replace("{heading: runaway.heading}", "{heading: runaway.nothing}"))
    status, out, err = run(capsys, "check", str(path))
    assert status == 1 and out == ""
    assert err.splitlines() == [
        f"{path}:3: network: unknown key 'colour' (expected one of description, external, levels, name, time_unit)",
        f"{path}:11: module runaway: output heading has no reader (no input, arbiter or external topic reads "
        f"runaway.heading)",
        f"{path}:16: module turn: input heading: module runaway has no output 'nothing' (heading)",
        f"{path}: 3 errors"]


def test_check_level(capsys):
    status, out, _ = run(capsys, "check", str(EXAMPLE), "--level", "0")
    assert status == 0 and "levels 0..0 (of 0..1), 3 modules, 0 arbiters" in out


def test_graph(capsys, tmp_path):
    status, out, _ = run(capsys, "graph", str(EXAMPLE), "-o", str(tmp_path / "g.svg"))
    assert status == 0 and out.strip() == str(tmp_path / "g.svg")
    assert ">avoid<" in (tmp_path / "g.svg").read_text()


def test_graph_of_a_broken_file_fails(capsys, tmp_path):
    path = write(tmp_path, LEVEL0.replace("{force: feelforce.force}", "{force: sonar}"))
    status, _, err = run(capsys, "graph", str(path), "-o", str(tmp_path / "g.svg"))
    assert status == 1 and "unknown topic 'sonar'" in err and not (tmp_path / "g.svg").exists()


def test_launch_write_only(capsys, tmp_path):
    status, out, _ = run(capsys, "launch", str(EXAMPLE), "--level", "0", "--xml", str(tmp_path / "a.launch"),
                         "--namespace", "r1", "--write-only")
    assert status == 0 and out.strip() == str(tmp_path / "a.launch")
    text = (tmp_path / "a.launch").read_text()
    assert '<group ns="r1">' in text and 'name="runaway"' in text and "suppressor" not in text


def test_info_afsm_with_state_diagram(capsys, tmp_path):
    status, out, _ = run(capsys, "info", "subsumption.examples.avoid:Avoid", "--dot", str(tmp_path / "avoid.png"))
    assert status == 0
    assert "input  force: geometry_msgs/Vector3Stamped" in out and "AFSM Avoid" in out and "[event dispatch]" in out
    assert (tmp_path / "avoid.png").read_bytes().startswith(b"\x89PNG")


def test_info_plain_module_and_bad_class(capsys):
    status, out, _ = run(capsys, "info", "subsumption.examples.avoid_demo:Turn")
    assert status == 0 and "output cmd_vel: geometry_msgs/Twist" in out and "AFSM" not in out
    status, _, err = run(capsys, "info", "subsumption.examples.avoid_demo:Nope")
    assert status == 1 and "has no class 'Nope'" in err


def test_plugins_add_subcommands_through_entry_points(capsys, tmp_path, monkeypatch):
    (tmp_path / "hello_plugin.py").write_text(textwrap.dedent("""\
        def register(subparsers):
            parser = subparsers.add_parser("hello", help="say hello")
            parser.add_argument("who")
            parser.set_defaults(func=lambda args: print(f"hello {args.who}") or 3)

        def broken(subparsers):
            raise RuntimeError("cannot")
        """))
    monkeypatch.syspath_prepend(str(tmp_path))
    found = [importlib.metadata.EntryPoint("hello", "hello_plugin:register", cli.ENTRY_POINT_GROUP),
             importlib.metadata.EntryPoint("broken", "hello_plugin:broken", cli.ENTRY_POINT_GROUP)]
    monkeypatch.setattr(cli, "entry_points",
                        lambda group: [e for e in found if e.group == group])
    status, out, err = run(capsys, "hello", "brooks")
    assert (status, out, err) == (3, "hello brooks\n", "")  # only the command's own plugin is loaded
    with pytest.raises(SystemExit) as raised:  # every plugin is loaded for the usage: the broken one is said
        cli.main(["--help"])
    assert raised.value.code == 0
    out, err = capsys.readouterr()
    assert "hello" in out and "ignoring command plugin broken (hello_plugin:broken): RuntimeError: cannot" in err


def test_a_core_command_loads_no_plugin(monkeypatch, capsys):
    """`subsumption check` does not import the plugins' packages (the simulator, matplotlib: seconds)."""
    def fail(group):
        raise AssertionError("plugins were looked up for a core command")

    monkeypatch.setattr(cli, "entry_points", fail)
    status, out, _ = run(capsys, "check", str(EXAMPLE))
    assert status == 0 and ": OK: network" in out


def test_unknown_command_exits_with_usage(capsys):
    with pytest.raises(SystemExit) as raised:
        cli.main(["frobnicate"])
    assert raised.value.code == 2


def test_version(capsys):
    with pytest.raises(SystemExit) as raised:
        cli.main(["--version"])
    assert raised.value.code == 0
    assert capsys.readouterr().out == f"subsumption {importlib.metadata.version('subsumption')}\n"


def _options(parser):
    """(command path, action) for every option and positional of `parser` and its subcommands."""
    import argparse
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from ((f"{name} {path}".strip(), a) for path, a in _options(sub))
        elif not isinstance(action, argparse._HelpAction):
            yield "", action


def test_every_option_of_every_command_is_explained():
    parser = cli.build_parser()  # with the installed plugins (run, demo, ...)
    unexplained = [f"{path or 'subsumption'}: {action.dest}" for path, action in _options(parser)
                   if not (action.help or "").strip()]
    assert unexplained == []
    commands = {path.split()[0] for path, _ in _options(parser) if path}
    assert {"check", "graph", "launch", "info", "watch", "replay", "reconfigure", "run", "demo"} <= commands


def test_run_join_without_a_master_is_one_line(capsys, monkeypatch, tmp_path):
    from subsumption.ros.master import free_port
    uri = f"http://127.0.0.1:{free_port()}/"
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    status, out, err = run(capsys, "run", "wander", "--level", "0", "--map", "subsim/maps/room.yaml", "--runtime",
                           "ros", "--join", "--duration", "1", "--out", str(tmp_path / "out"))
    assert status == 2 and err.splitlines() == [f"subsumption run: --join: no ROS master answers at {uri} "
                                                f"(ROS_MASTER_URI)"]


@pytest.mark.parametrize("item, named", [
    ("move_base.seen_kep=3", "move_base (navigation.move_base:MoveBase) has no parameter 'seen_kep'"),
    ("nobody.x=3", "no module 'nobody'"),
    ("move_base", "expected MODULE.NAME=VALUE"),
])
def test_run_refuses_a_bad_param_override_before_the_run_naming_it(capsys, tmp_path, item, named):
    """`run --param MODULE.NAME=VALUE` is checked against the network file before anything starts: a typo in a
    parameter's name would otherwise be set on the parameter server and silently ignored."""
    status, out, err = run(capsys, "run", "patrol", "--level", "3", "--world", "subsim/maps/office_world.yaml",
                           "--param", item, "--duration", "5", "--out", str(tmp_path / "out"))
    assert status == 2 and f"--param '{item}'" in err and named in err
    assert not (tmp_path / "out" / "metrics.json").exists()


def test_run_param_override_reaches_the_module(tmp_path):
    """The override is the run's: the network the run builds carries it over the file's value."""
    from experiments.runner import RunSpec, configured, module_overrides, network_file
    from subsumption.network import load

    params = module_overrides(["move_base.max_vel_x=0.25", "patrol.localization_wait=5"], network_file("patrol"))
    network = configured(load(network_file("patrol")), RunSpec("patrol", 3, tmp_path, 1.0, params=params))
    assert network.module("move_base").params["max_vel_x"] == 0.25
    assert network.module("patrol").params["localization_wait"] == 5
