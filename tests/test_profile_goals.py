"""The patrol robot's goals and its stranger on the robot profiles (issue 29), started as a user would:
`roslaunch subsumption patrol.launch robot:=... level:=N`, then the simulator posing as that robot. Each run is
watched by experiments/profile_watch.py (the patrol experiment's observers) and judged by
experiments/profile_scenes.py, the scenes and the scorer bench/profile_patrol.py plays its longer runs with. A run
stops as soon as what it checks has happened (1 simulated s after move_base's first success, or after the
intruder alarm), not after a fixed time.

- level 3 on a TurtleBot 3 (its LDS, no camera) and on the generic profile (the simulator's own robot, a 270-degree
  laser on /scan): goal 0, 0.7 m ahead of the start, reached by move_base's word and by the ground truth (within
  its 0.2 m after the goal was sent), 0 collisions;
- level 4 on a TurtleBot 2 (the Kinect): goal 0 reached, then the intruder alarm on the stranger's face (the
  scorer's IoU against the true face box), no false alarm, 0 collisions.
"""
from __future__ import annotations

import pytest

from conftest import launch_against_simulator
from experiments.profile_scenes import Scene, figures, first_goal_scene, scene, verdict

# experiments/profile_watch.py as the watcher script launch_against_simulator runs (python -c SCRIPT UNTIL ...)
WATCHER = "from experiments.profile_watch import main; raise SystemExit(main())"


def play(group, robot: str, level: int, played: Scene, until: float, rate: float,
         *watch: str) -> tuple[dict, dict, str]:
    """One run of `played`; the watcher's record (with its world and goal files), its figures and the logs' tails."""
    args = ["subsumption", "patrol.launch", f"robot:={robot}", f"level:={level}", "use_sim_time:=true",
            *played.launch_args]
    seen, logs = launch_against_simulator(
        group, args, WATCHER, until, played.world, rate,
        ("--base-cmd", played.base_cmd, "--goals", str(played.goals), *played.watch_args, *watch))
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


def test_patrol_on_a_turtlebot2_reaches_its_goal_then_raises_the_alarm_on_the_stranger(ros_processes, tmp_path):
    """Levels 0-4 on the TurtleBot 2's Kinect in the bench's level-4 scene
    (experiments/worlds/pingpong_turtlebot2_intruder_world.yaml): goal 0 is 0.7 m ahead; the stranger stands 3.6 m
    ahead with its back to the robot until the robot has passed that goal, then turns its face to it. The watcher
    stops 1 simulated s after the first intruder alarm (false alarms before it count), or at 30 simulated s."""
    until = 30.0
    seen, f, logs = play(ros_processes, "turtlebot2", 4, scene("turtlebot2", 4, tmp_path), until, 1.0,
                         "--after-alarm", "1")
    assert "Traceback" not in logs, logs
    assert 0 in f["succeeded"], (f, seen["patrol"]["goal_log"], logs)
    assert 0 in f["truly_reached"], f
    assert f["on_target"] >= 1 and f["false_alarms"] == 0, (f, seen["patrol"]["alarm_log"])
    assert f["detected_at_s"] > f["first_success_s"], f  # the stranger turned after the goal
    assert f["collisions"] == 0, f
    assert verdict(4, f), f
