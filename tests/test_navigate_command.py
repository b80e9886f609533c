"""`subsumption navigate`'s refusals: a robot with no range scan for amcl and move_base is named, not driven."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import subsim

ROOT = Path(__file__).resolve().parent.parent


def test_a_robot_without_a_range_scan_is_refused_in_one_line_naming_the_world_and_the_robot(tmp_path):
    """The office world's TurtleBot has only its Kinect: navigate used to run it anyway, blind (7 of 15 goals, 21
    collisions). It now says why not and what to do, before anything runs."""
    world = subsim.world_path("office")
    done = subprocess.run([sys.executable, "-m", "subsumption.cli", "navigate", "--world", str(world), "--goals", "1",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert str(world) in done.stderr and "robots[0]" in done.stderr and "no range scan" in done.stderr
    assert "--sensor depth" in done.stderr
    assert not (tmp_path / "out" / "metrics.json").exists()
