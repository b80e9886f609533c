"""The profile scenes' level-4 rule for goal 0 (experiments/profile_scenes.goal0_reached), on figures dicts (no ROS):
move_base's word counts; without it, only a pre-emption on the alarm after the robot truly stood on the goal does."""
from __future__ import annotations

import pytest

from experiments.profile_scenes import goal0_reached, verdict

ALARM_S = 18.2


def level4(succeeded=(), truly=(0,), preempted=(), alarm=ALARM_S) -> dict:
    return {"succeeded": list(succeeded), "truly_reached": list(truly), "preempted": [list(p) for p in preempted],
            "detected_at_s": alarm, "on_target": 1 if alarm is not None else 0, "false_alarms": 0, "collisions": 0}


@pytest.mark.parametrize("figures, reached", [
    (level4(succeeded=[0]), True),  # move_base's word
    (level4(preempted=[(0, ALARM_S + 0.1)]), True),  # level 4 took over on the alarm, the robot had been there
    (level4(truly=(), preempted=[(0, ALARM_S + 0.1)]), False),  # pre-empted before the robot got there
    (level4(preempted=[(0, ALARM_S - 5.0)]), False),  # pre-empted, but not by the alarm
    (level4(preempted=[(0, ALARM_S + 3.0)]), False),  # long after the alarm: something else
    (level4(preempted=[(1, ALARM_S)]), False),  # another goal
    (level4(), False),  # neither word nor pre-emption: still on its way
])
def test_goal0_counts_move_bases_word_or_a_preemption_by_the_alarm_after_a_true_reach(figures, reached):
    assert goal0_reached(figures) is reached
    assert verdict(4, figures) is reached


def test_no_alarm_no_level4_even_with_goal0_reached():
    assert goal0_reached(level4(succeeded=[0], alarm=None))
    assert not verdict(4, level4(succeeded=[0], alarm=None))
