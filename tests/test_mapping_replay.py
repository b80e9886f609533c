"""experiments.mapping_replay: a recording of a frontier-exploration run (SLAM in the loop, as the patrol's own map
is built) replayed through the SLAM core gives that run's own keyframes; measurements of SLAM changes rest on it."""
from __future__ import annotations

from pathlib import Path

from experiments.mapping_replay import load, record, replay, save
from experiments.patrol_map import explore_world

WORLD = Path(__file__).resolve().parent.parent / "experiments" / "worlds" / "pingpong_intruder_world.yaml"


def test_a_frontier_run_replays_to_its_own_keyframes(tmp_path):
    world, start = explore_world(WORLD, tmp_path / "world")
    rec = record(world, start, 25.0, seed=1, frontier=True)
    assert len(rec.inputs) > 100 and len(rec.live) > 5
    save(rec, tmp_path / "rec.pkl")
    metrics, core, _ = replay(load(tmp_path / "rec.pkl"))
    assert metrics["live_keyframes"] == len(core.keyframes)
    assert metrics["live_max_m"] is not None and metrics["live_max_m"] < 1e-6
