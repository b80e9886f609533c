"""The patrol robot reaches its goals on the robot profiles (issue 29), started as a user would:
`roslaunch subsumption patrol.launch robot:=... level:=3`, then the simulator posing as that robot. Each run is
watched by experiments/profile_watch.py (the patrol experiment's observers) and judged by
experiments/profile_scenes.py, the scenes and the scorer bench/profile_patrol.py plays its longer runs with. A run
stops 1 simulated s after move_base's first success, not after a fixed time.

Level 3 on a TurtleBot 3 (its LDS, no camera) and on the generic profile (the simulator's own robot, a 270-degree
laser on /scan): goal 0, 0.7 m ahead of the start, reached by move_base's word and by the ground truth (within its
0.2 m after the goal was sent), 0 collisions. Level 4 on a TurtleBot 2 (goal 0, then the alarm on the stranger) is
tests/test_catkin.py's run from the install space, in the same scene; levels 0-1 on a TurtleBot 2 (the stair edge)
are tests/test_profile_patrol.py's.
"""
from __future__ import annotations

import pytest

from conftest import launch_against_simulator
from experiments.profile_scenes import Scene, figures, first_goal_scene, verdict

# experiments/profile_watch.py as the watcher script launch_against_simulator runs (python -c SCRIPT UNTIL ...)
WATCHER = "from experiments.profile_watch import main; raise SystemExit(main())"


def play(group, robot: str, level: int, played: Scene, until: float, rate: float) -> tuple[dict, dict, str]:
    """One run of `played`; the watcher's record (with its world and goal files), its figures and the logs' tails."""
    args = ["subsumption", "patrol.launch", f"robot:={robot}", f"level:={level}", "use_sim_time:=true",
            *played.launch_args]
    seen, logs = launch_against_simulator(
        group, args, WATCHER, until, played.world, rate,
        ("--base-cmd", played.base_cmd, "--goals", str(played.goals), *played.watch_args))
    seen.update(world=str(played.world), goals=str(played.goals))
    return seen, figures(seen), logs


@pytest.mark.parametrize("robot", ["turtlebot3", "generic"])
def test_patrol_on_the_profile_reaches_its_first_goal(ros_processes, tmp_path, robot):
    """Levels 0-3 on the laser, at twice real time (no camera is rendered): the watcher stops 1 simulated s after
    move_base's first success, or at 40 simulated s (goal 0 is 0.7 m ahead: about 3 s of driving at the
    Burger's 0.22 m/s, after amcl's first estimate)."""
    until = 40.0
    seen, f, logs = play(ros_processes, robot, 3, first_goal_scene(robot, tmp_path), until, 2.0)
    assert "Traceback" not in logs, logs
    assert f["goals_sent"] >= 1, (f, logs)
    assert 0 in f["succeeded"], (f, seen["patrol"]["goal_log"], logs)  # move_base's word
    assert 0 in f["truly_reached"], (f, seen["path"][-1])  # and the ground truth's
    assert f["collisions"] == 0, f
    assert seen["t"] < until, seen["t"]  # stopped at the success, not by the clock
    assert verdict(3, f), f

