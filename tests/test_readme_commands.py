"""Every command in the README's shell blocks runs as written, in a short form where it is long (a run of 5
simulated seconds; the patrol experiment's `--help`), with its outputs sent to a temporary folder. A README
whose commands no longer work fails here, not in a reader's shell. `make demo` and `make test` are what the
suite itself is run by, so they are the two left out."""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

README = ROOT / "README.md"
SKIPPED = {"make demo", "make test"}      # the set-up itself: the suite runs under them
LONG = ("subsumption experiment ",)        # minutes even in short form: checked by --help (its own tests run it)


def readme_commands(text: str) -> list[str]:
    """The commands of the README's ```sh blocks: comments dropped, continued lines joined."""
    commands: list[str] = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            command = re.sub(r"\s+#.*$", "", line).strip()
            if command and not command.startswith("#"):
                commands.append(" ".join(command.split()))
    return commands


def short_form(command: str, out: Path) -> str:
    """The command as the test runs it: outputs under `out`, 5 simulated seconds, or --help when long."""
    command = re.sub(r"(?<=\s)out/", f"{out}/", command)
    command = re.sub(r"--duration \S+", "--duration 5", command)
    if command.startswith(LONG):
        command += " --help"
    return command


COMMANDS = [command for command in readme_commands(README.read_text()) if command not in SKIPPED]


def test_the_readme_has_its_commands_and_is_short():
    text = README.read_text()
    assert len(text.splitlines()) <= 250
    assert "make demo" in readme_commands(text) and "make test" in readme_commands(text)
    assert any(command.startswith("subsumption run ") for command in COMMANDS)


def test_every_figure_of_the_readme_exists_and_names_its_command():
    text = README.read_text()
    figures = re.findall(r"!\[([^\]]*)\]\(([^)]+)\)", text)
    assert figures
    for caption, path in figures:
        assert (ROOT / path).is_file(), path
        assert re.search(r"`[^`]*(subsumption|make demo|python -m bench)[^`]*`", caption), (
            f"the caption of {path} names no command that makes it")


def in_process(command: str) -> bool:
    """Commands of the `subsumption` CLI that start no process of their own run in this one (the same
    argv through the same main(); it saves an interpreter's start-up and imports per command)."""
    return command.startswith("subsumption ") and "--runtime ros" not in command


@pytest.mark.parametrize("command", COMMANDS, ids=[command[:60] for command in COMMANDS])
def test_readme_command_runs(command: str, tmp_path, capsys):
    run = short_form(command, tmp_path)
    if in_process(run):
        from subsumption.cli import main
        try:
            status = main(shlex.split(run)[1:])
        except SystemExit as exit_:  # --help
            status = exit_.code
        assert status == 0, f"{run}\n{capsys.readouterr()}"
        return
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    env["ROS_PACKAGE_PATH"] = f"{ROOT}:/usr/share"
    env["ROS_HOME"] = str(tmp_path / "ros_home")
    done = subprocess.run(["bash", "-c", run], cwd=ROOT, env=env, capture_output=True, text=True, timeout=240,
                          start_new_session=True)
    assert done.returncode == 0, f"{run}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
