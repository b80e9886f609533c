"""bench.posters judges each run from its metrics.json: a stop before the target's face was ever 30 px high is in
time (the robot stopped farther away), a stop more than 0.5 s after it is late, no stop is not in time."""
from __future__ import annotations

import json

from bench.posters import judge


def test_a_stop_before_the_face_was_ever_30_px_is_in_time():
    row = judge({"stopped_at_s": 3.57, "face_30px_at_s": None, "stop_after_face_30px_s": None,
                 "alarms_on_target": 1, "false_alarms": 0})
    assert row["found"] and row["stopped_in_time"]


def test_stops_are_judged_against_half_a_second_after_the_30_px_face():
    early = {"stopped_at_s": 4.9, "face_30px_at_s": 7.7, "stop_after_face_30px_s": -2.8, "alarms_on_target": 1}
    late = {"stopped_at_s": 9.0, "face_30px_at_s": 7.7, "stop_after_face_30px_s": 1.3, "alarms_on_target": 1}
    assert judge(early)["stopped_in_time"] and not judge(late)["stopped_in_time"]


def test_no_stop_and_no_alarm_on_the_target_is_a_stranger_missed():
    row = judge({"stopped_at_s": None, "face_30px_at_s": 7.7, "stop_after_face_30px_s": None,
                 "alarms_on_target": 0, "false_alarms": 1})
    assert not row["found"] and not row["stopped_in_time"] and row["false_alarms"] == 1


def test_the_folder_summary_gathers_runs_of_several_invocations(tmp_path):
    """Scenes or seed ranges benched one invocation at a time into one folder: its posters.json covers them all,
    and a run benched again replaces its earlier row."""
    from bench.posters import merged, summarise

    summary = tmp_path / "posters.json"
    first = [{"scene": "short", "runtime": "ros", "seed": 1, "false_alarms": 1, "found": True,
              "stopped_in_time": True}]
    summary.write_text(json.dumps({"runs": first}))
    second = [{"scene": "room", "runtime": "ros", "seed": 1, "false_alarms": 0, "found": True,
               "stopped_in_time": True},
              {"scene": "short", "runtime": "ros", "seed": 1, "false_alarms": 0, "found": True,
               "stopped_in_time": False}]
    everything = merged(summary, second)
    assert [(r["scene"], r["false_alarms"]) for r in everything] == [("room", 0), ("short", 0)]
    totals = summarise(everything)
    assert totals["runs"] == 2 and totals["false_alarms"] == 0 and totals["stops_later_than_0.5_s"] == 1
    assert merged(tmp_path / "none.json", second) == sorted(second, key=lambda r: r["scene"])
