"""bench.resimulate: a real log cast again in the building its own scans draw, so that its poses are exact truth.
Checked on a slice of the Intel log: the re-cast scans see the walls the real ones saw, and the poses agree with
the re-cast scans far better than the corrected poses agree with the real scans."""
from __future__ import annotations

import numpy as np

from bench.reference_consistency import step_by_step
from bench.resimulate import resimulated
from navigation.carmen import read_log
from tests.real_data_slice import write_slice


def _slice(tmp_path, scans: int = 150):
    log = read_log(write_slice(tmp_path / "intel_slice.log", scans))
    return log, resimulated(log, seed=1)


def test_the_recast_scans_see_the_walls_the_log_saw(tmp_path):
    """Same stamps, poses, mount and beams; where both hit, the re-cast range is the real one to a few cm, median (the
    world is the building the log saw, not a shifted, mirrored or turned copy)."""
    log, again = _slice(tmp_path)
    assert len(again.scans) == len(log.scans)
    differences = []
    for real, cast in zip(log.scans, again.scans):
        assert real.stamp == cast.stamp and np.array_equal(real.pose, cast.pose)
        assert np.array_equal(real.mount, cast.mount) and len(real.ranges) == len(cast.ranges)
        assert real.angle_min == cast.angle_min and real.angle_increment == cast.angle_increment
        both = np.isfinite(real.ranges) & (real.ranges < 30) & np.isfinite(cast.ranges)
        differences.append(np.abs(real.ranges[both] - cast.ranges[both]))
    differences = np.concatenate(differences)
    assert len(differences) > 100 * len(log.scans)
    assert np.median(differences) < 0.05  # 3 cm here: the corrected poses, from which the walls are drawn, are that good


def test_its_poses_agree_with_its_scans_as_truth_does(tmp_path):
    """Each keyframe fitted to the ten before it, all at their poses (bench.reference_consistency's step-by-step
    check): the re-cast scans need a tenth of a degree at most, in the median; the corrected log's real scans need
    several times that (the corrected poses are somebody's map, good to a fraction of a degree)."""
    log, again = _slice(tmp_path)
    real_turns = np.abs([turn for _, turn, _, _ in step_by_step(log.scans)])
    cast_turns = np.abs([turn for _, turn, _, _ in step_by_step(again.scans)])
    assert len(cast_turns) >= 0.8 * len(real_turns) > 10
    assert np.median(cast_turns) < 0.1
    assert np.median(real_turns) > 2 * np.median(cast_turns)
