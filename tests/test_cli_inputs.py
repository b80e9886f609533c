"""The last input gaps of issue 31: every command checks its values in one place (subsumption.arguments).

Before: ``--seed -1`` gave a traceback in ``subsumption map`` and ``subsumption navigate`` (``run`` refused it),
``--rate -3`` was taken by both on ROS, ``--param wander.interval=.nan`` was taken, and a module node started
with a NaN parameter ran with it. Now each is a one-line error naming the option and the value, exit status 2,
before anything starts.
"""
from __future__ import annotations

import pytest

from robots.wander.level1 import Wander
from subsumption import cli
from subsumption.module import ParamError
from subsumption.testing import Harness


def refused(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as raised:
        status = cli.main(list(argv))
        raise SystemExit(status)
    err = capsys.readouterr().err
    assert raised.value.code == 2, err
    assert len(err.strip().splitlines()) == 1, err  # one line, no usage block, no traceback
    return err


@pytest.mark.parametrize("command", [["map", "--world", "w.yaml"], ["navigate", "--map", "m.yaml"],
                                     ["run", "wander", "--level", "1", "--map", "m.yaml"]])
@pytest.mark.parametrize("option, value, expected", [
    ("--seed", "-1", "argument --seed: wants an integer from 0 to 4294967295, got '-1'"),
    ("--rate", "-3", "argument --rate: wants simulated s per wall s, >= 0, got '-3'"),
    ("--rate", "nan", "argument --rate: wants simulated s per wall s, >= 0, got 'nan'"),
])
def test_seed_and_rate_are_checked_alike_by_every_command(capsys, tmp_path, command, option, value, expected):
    err = refused(capsys, *command, "--runtime", "ros", option, value, "--out", str(tmp_path / "out"))
    assert f"subsumption {command[0]}: error: {expected}" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, expected", [
    (["run", "wander", "--level", "1", "--map", "subsim/maps/pingpong.yaml", "--param", "wander.interval=.nan"],
     "subsumption run: --param 'wander.interval=.nan': '.nan' is not a finite number"),
    (["run", "patrol", "--level", "3", "--map", "subsim/maps/pingpong.yaml", "--param",
      "move_base.max_vel_x=-1"], "subsumption run: --param 'move_base.max_vel_x=-1' must be >= 0.01, got -1.0"),
    (["navigate", "--map", "subsim/maps/pingpong.yaml", "--param", "xy_goal_tolerance=.nan"],
     "subsumption navigate: --param 'xy_goal_tolerance=.nan': '.nan' is not a finite number"),
    (["map", "--world", "w.yaml", "--param", "linearUpdate=[1, .inf]"],
     "subsumption map: --param 'linearUpdate=[1, .inf]': '[1, .inf]' is not a finite number"),
    (["replay", "x.bag", "--level", "0", "--param", "wander.interval=.nan"],
     "argument --param: wander.interval: '.nan' is not a finite number"),
])
def test_a_nan_or_out_of_range_param_is_refused_up_front(capsys, tmp_path, argv, expected):
    err = refused(capsys, *argv, *([] if argv[0] == "replay" else ["--out", str(tmp_path / "out")]))
    assert expected in err


def test_a_module_refuses_a_nan_parameter_as_the_docs_say():
    with pytest.raises(ParamError, match="interval must be a number, got nan"):
        Harness(Wander, params={"interval": float("nan")})


def test_the_command_finds_its_own_package_without_setup_bash(tmp_path):
    """Before: from a shell without `source setup.bash`, the patrol's level 5 (the terminal, an existing node of
    this package) was not found: `experiment patrol` died at level 5 after minutes of levels 0-4."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    network = tmp_path / "net.yaml"  # one existing node of this package, nothing to import: a quick check
    network.write_text("name: net\nexternal: {beat: std_msgs/Empty}\nlevels:\n  - name: zero\n    modules:\n"
                       "      - {name: terminal, node: subsumption/terminal, outputs: {stop: {type: std_msgs/Empty, "
                       "to: beat}}}\n")
    env = {"HOME": os.environ.get("HOME", str(tmp_path)), "PATH": "/usr/bin:/bin"}  # no ROS_PACKAGE_PATH, no venv
    done = subprocess.run([str(Path(sys.executable).parent / "subsumption"), "check", str(network)], env=env,
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "OK: network net" in done.stdout, done.stderr
