"""The patrol robot's level 4 on the TurtleBot 2 profile, started as a user would: ``roslaunch subsumption
patrol.launch robot:=turtlebot2 level:=4`` against the simulator posing as a TurtleBot 2 (the Kobuki driver's topics
and types, the Kinect driver's camera/rgb and camera/depth images with their camera_info, in its optical frames).

The scene is bench.profile_patrol's level 4 (experiments/worlds/pingpong_turtlebot2_intruder_world.yaml): a goal
0.7 m ahead, then a stranger turns its face towards the robot. The run is watched and scored by the patrol
experiment's own observers and scorer (experiments/profile_watch.py, experiments.patrol_vision.score), on its own
master, stopping exactly the processes it started; it ends two simulated seconds after the first intruder alarm."""
from __future__ import annotations

import pytest

from bench import profile_patrol


@pytest.mark.timeout(420)
def test_patrol_level4_on_a_turtlebot2_reaches_its_goal_and_finds_the_stranger(tmp_path):
    seen = profile_patrol.run("turtlebot2", 4, duration=40.0, rate=1.0, scratch=tmp_path, after_alarm_s=2.0)
    log = "".join(path.read_text(errors="replace")[-3000:] for path in tmp_path.glob("run_*.log"))
    assert "failed" not in seen, (seen, log)
    figures = profile_patrol.figures(seen)
    assert figures["collisions"] == 0, figures
    assert 0 in figures["succeeded"], (figures, log)  # move_base reached the goal ahead, through the Kobuki's topic
    assert figures["on_target"] >= 1 and figures["false_alarms"] == 0, figures  # the stranger, and nothing else
    assert figures["detected_at_s"] > figures["first_success_s"], figures  # found on the patrol, after the goal
