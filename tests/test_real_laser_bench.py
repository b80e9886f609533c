"""bench.real_laser's --param: a slam parameter for every run of the grid (what a part of the method adds is measured
by turning it off across the logs), checked as `subsumption map --param` checks it."""
import json

import pytest

from bench import real_laser


def test_a_parameter_the_slam_node_lacks_is_refused_by_name(capsys, tmp_path):
    with pytest.raises(SystemExit) as stopped:
        real_laser.main(["--param", "odometry_adapted=false", "--out", str(tmp_path)])
    assert stopped.value.code == 2
    error = capsys.readouterr().err
    assert "--param 'odometry_adapted=false'" in error and "odometry_adapt" in error
    assert not any(tmp_path.iterdir())  # nothing written


def test_a_value_of_the_wrong_type_is_refused_by_name(capsys, tmp_path):
    with pytest.raises(SystemExit):
        real_laser.main(["--param", "local_keyframes=many", "--out", str(tmp_path)])
    assert "local_keyframes" in capsys.readouterr().err


def _scores(log_name: str, drift: float, seed: int) -> dict:
    """What a mapping run returns, made up: the bench prints and records it."""
    return {"log": log_name, "drift": drift, "seed": seed, "ate_m": 0.05, "odometry_ate_m": 0.5,
            "rpe_trans_m": 0.01, "rpe_rot_deg": 0.1, "walls_within_0p1m": 0.97, "ate_aligned_m": 0.04,
            "walls_within_0p1m_aligned": 0.98, "alignment_deg": 0.1, "loop_closures_accepted": 1,
            "loop_closures_tried": 2, "cpu_time_s": 1.0, "real_time_factor": 50}


def test_every_mapping_run_gets_the_parameters_and_results_record_them(monkeypatch, tmp_path):
    given = []

    def fake_run_map(log_name, drift, seed, out, params=None, resimulate=False):
        given.append(params)
        return _scores(log_name, drift, seed)

    monkeypatch.setattr(real_laser, "run_map", fake_run_map)
    assert real_laser.main(["--logs", "intel", "--drifts", "0", "5", "--seeds", "1", "--no-localize", "--out",
                            str(tmp_path), "--param", "odometry_adapt=false", "--param", "local_keyframes=10"]) == 0
    assert given == [{"odometry_adapt": False, "local_keyframes": 10}] * 2
    assert json.loads((tmp_path / "results.json").read_text())["params"] == given[0]


def test_resimulate_maps_every_run_re_simulated_and_says_so(monkeypatch, tmp_path):
    """--resimulate: each run on the log cast again with exact truth (bench/resimulate.py), no localization (its
    maps are the corrected logs'), and results.json records it."""
    asked = []

    def fake_run_map(log_name, drift, seed, out, params=None, resimulate=False):
        asked.append(resimulate)
        return _scores(log_name, drift, seed)

    def no_localization(*args, **kwargs):
        raise AssertionError("--resimulate runs no localization")

    monkeypatch.setattr(real_laser, "run_map", fake_run_map)
    monkeypatch.setattr(real_laser, "run_localize", no_localization)
    assert real_laser.main(["--logs", "aces", "--drifts", "5", "--seeds", "1", "2", "--resimulate", "--out",
                            str(tmp_path)]) == 0
    assert asked == [True, True]
    assert json.loads((tmp_path / "results.json").read_text())["resimulated"] is True
