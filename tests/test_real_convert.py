"""`subsumption convert carmen`: a slice of the Intel Research Lab log as a bag; the drift model; bad lines."""
from __future__ import annotations

import gzip
import math

import numpy as np
import pytest
import rosbag

from navigation.carmen import CarmenError, drifted, read_log
from subsumption.planar import from_pose_msg, wrap
from real_data_slice import INTEL, write_slice
from subsumption.cli import main


@pytest.fixture(scope="module")
def intel_slice(tmp_path_factory):
    return write_slice(tmp_path_factory.mktemp("carmen") / "intel.log", 60)


def odometry_of(bag_path):
    with rosbag.Bag(str(bag_path)) as bag:
        odom = np.array([from_pose_msg(m.pose.pose) for _, m, _ in bag.read_messages(topics=["/odom"])])
        truth = np.array([from_pose_msg(m.pose.pose) for _, m, _ in bag.read_messages(topics=["/ground_truth"])])
    return odom, truth


def test_slice_becomes_a_bag_with_the_topics_a_robot_records(intel_slice, tmp_path, capsys):
    out = tmp_path / "intel.bag"
    assert main(["convert", "carmen", str(intel_slice), str(out)]) == 0
    assert "60 scans" in capsys.readouterr().out
    with rosbag.Bag(str(out)) as bag:
        info = bag.get_type_and_topic_info().topics
        assert {t: (i.msg_type, i.message_count) for t, i in info.items()} == {
            "/scan": ("sensor_msgs/LaserScan", 60), "/odom": ("nav_msgs/Odometry", 60), "/tf": ("tf2_msgs/TFMessage", 60),
            "/ground_truth": ("nav_msgs/Odometry", 60), "/tf_static": ("tf2_msgs/TFMessage", 1)}
        scan = next(m for _, m, _ in bag.read_messages(topics=["/scan"]))
        static = next(m for _, m, _ in bag.read_messages(topics=["/tf_static"]))
    log = read_log(intel_slice)
    assert len(scan.ranges) == 180 and scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.angle_increment == pytest.approx(math.pi / 180)
    first = log.scans[0].ranges
    assert np.allclose(np.asarray(scan.ranges)[first < 30], first[first < 30], atol=1e-5)
    assert static.transforms[0].header.frame_id == "base_link" and static.transforms[0].child_frame_id == "laser"
    odom, truth = odometry_of(out)
    reference = np.array([s.pose for s in log.scans])
    assert np.allclose(odom, truth) and np.allclose(truth[:, :2], reference[:, :2])  # no drift asked: none
    assert np.allclose(wrap(truth[:, 2] - reference[:, 2]), 0.0, atol=1e-9)


def test_drift_is_seeded_and_grows_with_the_percentage(intel_slice, tmp_path):
    poses = np.array([s.pose for s in read_log(intel_slice).scans])
    assert np.array_equal(drifted(poses, 5, 1), drifted(poses, 5, 1))
    assert not np.allclose(drifted(poses, 5, 1), drifted(poses, 5, 2))
    errors = [np.mean([np.hypot(*(drifted(poses, p, s)[:, :2] - poses[:, :2]).T).mean() for s in (1, 2, 3)])
              for p in (2, 5, 10)]
    assert 0 < errors[0] < errors[1] < errors[2]
    assert np.allclose(drifted(poses, 5, 1)[0], poses[0])  # the odometry starts where the reference does
    out = tmp_path / "drift.bag"
    assert main(["convert", "carmen", str(intel_slice), str(out), "--odom-drift", "5", "--seed", "2"]) == 0
    odom, truth = odometry_of(out)
    assert np.allclose(odom, drifted(truth, 5, 2))


def test_a_raw_log_keeps_its_own_odometry_and_has_no_ground_truth(intel_slice, tmp_path, capsys):
    """A raw log (FLASER's odometry fields differ from its poses): /odom is that odometry, and nothing claims to be
    the truth."""
    raw = tmp_path / "raw.log"
    lines = []
    for line in intel_slice.read_text().splitlines():
        words = line.split()
        if words and words[0] == "FLASER":
            n = int(words[1])
            x, y, theta = (float(v) for v in words[2 + n + 3:2 + n + 6])  # the odometry fields, after the pose
            words[2 + n + 3:2 + n + 6] = [f"{x * 1.05 + 3:.6f}", f"{y * 0.95 - 2:.6f}", f"{theta + 0.1:.6f}"]
        lines.append(" ".join(words))
    raw.write_text("\n".join(lines) + "\n")
    log = read_log(raw)
    assert not log.corrected
    out = tmp_path / "raw.bag"
    assert main(["convert", "carmen", str(raw), str(out)]) == 0
    assert "from a raw log, its own odometry" in capsys.readouterr().out
    odom, truth = odometry_of(out)
    assert len(truth) == 0
    assert np.allclose(odom[:, :2], np.array([sc.odom for sc in log.scans])[:, :2])


def test_raw_takes_a_log_whose_poses_agree_as_its_own_odometry(intel_slice, tmp_path, capsys):
    """--raw: a log whose lines carry one pose (ROBOTLASER1) reads as corrected; given --raw, that pose is the
    robot's odometry and no /ground_truth is written."""
    out = tmp_path / "raw.bag"
    assert main(["convert", "carmen", str(intel_slice), str(out), "--raw"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("from a raw log, its own odometry")
    odom, truth = odometry_of(out)
    assert len(truth) == 0
    assert np.allclose(odom[:, :2], np.array([sc.pose for sc in read_log(intel_slice).scans])[:, :2])
    assert main(["convert", "carmen", str(intel_slice), str(out), "--raw", "--odom-drift", "5"]) == 0
    assert capsys.readouterr().out.rstrip().endswith("its own odometry, drifted 5% further (seed 1)")


def test_a_bad_line_is_named_and_nothing_is_written(intel_slice, tmp_path, capsys):
    lines = intel_slice.read_text().splitlines(keepends=True)
    number = next(i for i, line in enumerate(lines) if line.startswith("FLASER")) + 1 + 40  # a later line
    number = next(i for i in range(number, len(lines)) if lines[i].startswith("FLASER")) + 1
    words = lines[number - 1].split()
    words[10] = "1.2x"
    lines[number - 1] = " ".join(words) + "\n"
    bad = tmp_path / "bad.log"
    bad.write_text("".join(lines))
    out = tmp_path / "out.bag"
    assert main(["convert", "carmen", str(bad), str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"subsumption convert: {bad}:{number}: FLASER ranges: '1.2x' is not a number"
    assert list(tmp_path.iterdir()) == [bad]  # no bag, no temporary file
    cut = tmp_path / "cut.log"
    cut.write_text("".join(lines[:number - 1]) + " ".join(words[:50]) + "\n")
    assert main(["convert", "carmen", str(cut), str(out)]) == 2
    assert f"{cut}:{number}: FLASER with 180 beams" in capsys.readouterr().err
    assert not out.exists()


def test_a_truncated_gzip_is_named_and_nothing_is_written(tmp_path, capsys):
    data = INTEL.read_bytes()
    cut = tmp_path / "intel.log.gz"
    cut.write_bytes(data[:len(data) // 3])
    out = tmp_path / "out.bag"
    assert main(["convert", "carmen", str(cut), str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"subsumption convert: {cut}:") and "truncated" in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["intel.log.gz"]
    with pytest.raises(CarmenError, match="no such file"):
        read_log(tmp_path / "missing.log")


def test_stamps_that_go_back_a_little_are_repaired_and_far_is_an_error(intel_slice, tmp_path, capsys):
    lines = intel_slice.read_text().splitlines(keepends=True)
    flaser = [i for i, line in enumerate(lines) if line.startswith("FLASER")]
    def with_stamp(index: int, shift: float) -> list[str]:
        words = lines[flaser[index]].split()
        words[-3] = f"{float(words[-3]) + shift:.6f}"
        return lines[:flaser[index]] + [" ".join(words) + "\n"] + lines[flaser[index] + 1:]
    gap = float(lines[flaser[10]].split()[-3]) - float(lines[flaser[9]].split()[-3])
    little = tmp_path / "little.log"
    little.write_text("".join(with_stamp(10, -gap - 0.2)))
    assert main(["convert", "carmen", str(little), str(tmp_path / "a.bag")]) == 0
    assert "1 stamps did not increase (going back by up to 0.2 s, under the 1 s allowed" in capsys.readouterr().out
    far = tmp_path / "far.log"
    far.write_text("".join(with_stamp(10, -gap - 50)))
    assert main(["convert", "carmen", str(far), str(tmp_path / "b.bag")]) == 2
    assert f"{far}:{flaser[10] + 1}: the timestamp" in capsys.readouterr().err
    assert not (tmp_path / "b.bag").exists()
