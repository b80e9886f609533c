"""`subsumption replay`: a recording's sensors played into the network, its answers compared with the recording.

The recording is made here, so the test needs no fixture file: the wander robot's level 0 with the simulator in
the room where a person walks up and down (so runaway has something to run from), recorded topic by topic into
a real bag as rosbag record would. Replaying it must reproduce every line; a changed parameter must show, and
in isolation only at the module that changed and what it feeds."""
from __future__ import annotations

import subprocess
from pathlib import Path

import genpy
import pytest
import rosbag
from conftest import ROOT

import subsim.local
from subsumption import LocalRuntime, cli
from subsumption.network import load
from subsumption.network.local import build_local
from subsumption.ros.replay import default_network

WORLD = ROOT / "subsim" / "maps" / "room_people_world.yaml"
LINES = ["/cmd_vel", "/feelforce/force", "/runaway/heading", "/sonar/map", "/turn/encoders"]


def record_local_run(path: Path, level: int, duration: float, leave_out: tuple[str, ...] = ()) -> Path:
    runtime = LocalRuntime()
    subsim.local.attach(runtime, WORLD, seed=3, record=False)
    build_local(load(default_network()), runtime, level)
    bag = rosbag.Bag(str(path), "w")
    recorder = runtime.node("recorder")
    for topic, entry in list(runtime.topics.items()):
        if entry.msg_type is not None and topic not in leave_out:
            recorder.subscribe(topic, entry.msg_type,
                               lambda msg, topic=topic: bag.write(topic, msg, genpy.Time.from_sec(runtime.now())))
    runtime.run_until(duration)
    bag.close()
    return path


@pytest.fixture(scope="module")
def level0_bag(tmp_path_factory) -> Path:
    return record_local_run(tmp_path_factory.mktemp("replay") / "level0.bag", 0, 20.0)


def replay_here(capsys, *args: str) -> subprocess.CompletedProcess:
    """`subsumption replay ... --runtime local` in this process (no ROS node: no process needed)."""
    status = cli.main(["replay", *args, "--runtime", "local"])
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(args, status, out, err)


def rows(stdout: str) -> dict[str, list[str]]:
    return {line.split()[0]: line.split() for line in stdout.splitlines() if line.startswith("/")}


def test_an_unchanged_network_reproduces_the_recording(level0_bag, capsys):
    done = replay_here(capsys, str(level0_bag), "--level", "0")
    assert done.returncode == 0, done.stdout + done.stderr
    table = rows(done.stdout)
    assert sorted(table) == LINES
    for topic in LINES:
        recorded, replayed, matched = (int(x) for x in table[topic][1:4])
        if topic == "/cmd_vel":  # forward's timer: a tick at the very instant of a sweep may see it or not
            assert recorded == replayed and matched >= 0.97 * recorded, table[topic]
        else:  # everything driven by the sonars: message for message
            assert recorded == replayed == matched > 0, table[topic]
    assert int(table["/runaway/heading"][1]) > 10  # the person came close: the robot ran away
    assert done.stdout.splitlines()[-1] == "PASS"


def test_a_changed_parameter_shows_where_it_acts(level0_bag, capsys):
    done = replay_here(capsys, str(level0_bag), "--level", "0", "--param", "runaway.threshold=3.0")
    assert done.returncode == 1 and done.stdout.splitlines()[-1] == "FAIL"
    table = rows(done.stdout)
    assert table["/feelforce/force"][-1] == "ok" and table["/sonar/map"][-1] == "ok"  # upstream of the change
    assert "DIFFERS" in table["/runaway/heading"] and "DIFFERS" in table["/turn/encoders"]


def test_isolated_replay_keeps_a_difference_at_its_module(level0_bag, capsys):
    changed = ["--param", "turn.gain=1.0"]  # turn's default is 2.0
    whole = rows(replay_here(capsys, str(level0_bag), "--level", "0", *changed).stdout)
    isolated = replay_here(capsys, str(level0_bag), "--level", "0", "--isolated", *changed)
    assert isolated.returncode == 1 and "each module fed its recorded inputs" in isolated.stdout.splitlines()[0]
    alone = rows(isolated.stdout)
    assert "DIFFERS" in whole["/cmd_vel"] and "DIFFERS" in whole["/turn/encoders"]
    assert "DIFFERS" in alone["/turn/encoders"]
    # forward got the recorded encoders, not turn's new ones: its cmd_vel still matches
    assert alone["/cmd_vel"][-1] == "ok" and alone["/runaway/heading"][-1] == "ok"


def test_bad_input_is_one_line(tmp_path, capsys):
    no_odom = record_local_run(tmp_path / "no_odom.bag", 1, 2.0, leave_out=("/odom",))
    done = replay_here(capsys, str(no_odom), "--level", "1")
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip() == ("subsumption replay: the bag has no /odom: levels 0..1 of network wander read it")
    missing = replay_here(capsys, str(tmp_path / "nothing.bag"), "--level", "0")
    assert missing.returncode == 2 and len(missing.stderr.strip().splitlines()) == 1
    assert "nothing.bag: cannot read the bag" in missing.stderr


def test_stamped_answers_are_timed_by_their_stamp_not_by_when_a_loaded_machine_passed_them_on():
    from geometry_msgs.msg import Vector3Stamped
    from std_msgs.msg import Float64

    from subsumption.ros.replay import by_stamp, compare

    def force(stamp: float) -> Vector3Stamped:
        msg = Vector3Stamped()
        msg.header.stamp = genpy.Time.from_sec(stamp)
        msg.vector.x = stamp
        return msg

    recorded = {"/force": [(t + 0.01, force(t)) for t in (1.0, 2.0)], "/heading": [(1.01, Float64(0.5))]}
    late = {"/force": [(t + 0.6, force(t)) for t in (1.0, 2.0)], "/heading": [(1.6, Float64(0.5))]}
    timed = {topic: by_stamp(sent) for topic, sent in recorded.items()}
    results = {r.topic: r for r in compare(timed, {topic: by_stamp(sent) for topic, sent in late.items()},
                                           time_tolerance=0.25, value_tolerance=1e-6)}
    assert results["/force"].matched == 2       # the same sensor time: the same answer, however late it came
    assert results["/heading"].matched == 0     # no stamp: arrival decides, and 0.6 s is beyond the tolerance
    wrong = {"/force": [(1.01, force(1.5))]}    # a different stamp is a different answer even when on time
    assert compare({"/force": timed["/force"][:1]}, wrong, 0.25, 1e-6)[0].matched == 0


def test_a_bag_that_joined_a_played_topic_late_says_so_up_front(level0_bag, tmp_path, capsys):
    """rosbag record -a joins each topic when it appears: a bag whose sensors start late cannot replay as a whole
    network, and replay says so before it runs, naming the topic and when it was first recorded."""
    late = tmp_path / "late.bag"
    with rosbag.Bag(str(level0_bag)) as source, rosbag.Bag(str(late), "w") as out:
        first = source.get_start_time()
        for topic, msg, t in source.read_messages():
            if topic != "/sonar" or t.to_sec() - first >= 1.5:
                out.write(topic, msg, t)
    done = replay_here(capsys, str(late), "--level", "0")
    note = [line for line in done.stderr.splitlines() if line.startswith("subsumption replay: note:")]
    assert len(note) == 1 and "(/sonar 1.5 s in" in note[0] and "--isolated" in note[0], done.stderr
    isolated = replay_here(capsys, str(late), "--level", "0", "--isolated")
    assert "note:" not in isolated.stderr  # isolated replay is the remedy: nothing to warn of
    assert "note:" not in replay_here(capsys, str(level0_bag), "--level", "0").stderr
