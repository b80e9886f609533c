"""Posters and animals: every shipped level-4 scene on many seeds, both runtimes: no false alarm, every stranger found.

Each run is the ordinary command (``subsumption run patrol --level 4``) on one scene and seed; its metrics.json says
``false_alarms`` (alarms whose box was not on the target's face: a poster, the cat, an enrolled person),
``alarms_on_target`` and ``stop_after_face_30px_s`` (how long after the target's face was 30 px high the robot
stood still). The issue's figure: seeds 1-20 of every scene on both runtimes, 0 false alarms, every stranger
found, each stop within 0.5 s of the 30-px face. A ROS run of a scene takes its simulated time at 1x plus about a
minute of start-up: the whole grid is hours; --seeds and --runtimes cut it.

    .venv/bin/python -m bench.posters [--seeds 1-20] [--runtimes local,ros] [--scenes short,room,office]
        [--groups level|file|none] [--out out/posters] [--resume]

Prints a row per run and the totals; writes OUT/posters.json, which gathers every run judged into OUT (a later
invocation's rows replace the same scene, runtime and seed's).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WORLDS = ROOT / "experiments" / "worlds"
MAPS = ROOT / "subsim" / "maps"
# scene: (world, goals or None, simulated s, map): the shipped level-4 scenes (experiments/worlds/*intruder*), each
# with its room's map as given, so that a run is the encounter, not map building
SCENES = {
    "short": (WORLDS / "pingpong_intruder_short_world.yaml", WORLDS / "pingpong_intruder_short_goals.yaml", 30.0,
              MAPS / "pingpong.yaml"),
    "room": (WORLDS / "pingpong_intruder_world.yaml", None, 100.0, MAPS / "pingpong.yaml"),
    "office": (WORLDS / "office_intruder_world.yaml", WORLDS / "office_intruder_goals.yaml", 100.0,
               MAPS / "office.yaml"),
}
STOP_WITHIN = 0.5  # s after the 30-px face


def seeds(text: str) -> list[int]:
    first, _, last = text.partition("-")
    return list(range(int(first), int(last or first) + 1))


def command(scene: str, seed: int, runtime: str, out: Path, groups: str = "level") -> list[str]:
    world, goals, duration, map_file = SCENES[scene]
    args = [str(Path(sys.executable).parent / "subsumption"), "run", "patrol", "--level", "4", "--world", str(world),
            "--duration", f"{duration:g}", "--seed", str(seed), "--runtime", runtime, "--rate", "1",
            "--map", str(map_file), "--out", str(out)]
    if runtime == "ros":
        args += ["--groups", groups]
    return args + (["--goals", str(goals)] if goals else [])


def judge(m: dict) -> dict:
    """One run's row from its metrics.json. A stop counts as in time when it came within STOP_WITHIN s of the
    target's face being 30 px high, or before the face ever was (the robot stopped farther away and kept it so)."""
    stop = m.get("stop_after_face_30px_s")
    stopped = m.get("stopped_at_s") is not None
    in_time = stopped and (stop <= STOP_WITHIN if stop is not None else m.get("face_30px_at_s") is None)
    return {"false_alarms": m.get("false_alarms"), "alarms_on_target": m.get("alarms_on_target"),
            "stop_after_face_30px_s": stop, "found": bool(m.get("alarms_on_target")), "stopped_in_time": in_time}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.posters", description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=seeds, default=seeds("1-20"), help="FIRST-LAST (default 1-20)")
    parser.add_argument("--runtimes", default="local,ros", help="comma-separated: local, ros")
    parser.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated of {', '.join(SCENES)}")
    parser.add_argument("--out", type=Path, default=Path("out/posters"))
    parser.add_argument("--groups", default="level", choices=("file", "level", "none"),
                        help="ROS runs: `subsumption run --groups` (default level: a process per level, as the "
                             "patrol experiment runs)")
    parser.add_argument("--resume", action="store_true",
                        help="judge a run's metrics.json already in --out instead of running it again")
    args = parser.parse_args(argv)
    rows = []
    for scene in args.scenes.split(","):
        for runtime in args.runtimes.split(","):
            for seed in args.seeds:
                out = args.out / f"{scene}_{runtime}_{seed}"
                metrics_path = out / "metrics.json"
                error = ""
                if not (args.resume and metrics_path.exists()):
                    metrics_path.unlink(missing_ok=True)
                    error = subprocess.run(command(scene, seed, runtime, out, args.groups), capture_output=True,
                                           text=True).stderr.strip()[-300:]
                row = {"scene": scene, "runtime": runtime, "seed": seed}
                if metrics_path.exists():
                    row.update(judge(json.loads(metrics_path.read_text())))
                else:
                    row["error"] = error
                rows.append(row)
                print("  " + json.dumps(row), flush=True)
    totals = summarise(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    everything = merged(args.out / "posters.json", rows)
    folder = summarise(everything)
    (args.out / "posters.json").write_text(json.dumps({"totals": folder, "runs": everything}, indent=2) + "\n")
    print(f"posters: {json.dumps(totals)}")
    print(f"every run in {args.out} ({args.out}/posters.json): {json.dumps(folder)}")
    return 0 if totals["runs"] > totals["failed_to_run"] and \
        not (totals["false_alarms"] or totals["strangers_missed"]) else 1


def summarise(rows: list[dict]) -> dict:
    """The totals of judged rows: false alarms, strangers missed, late stops, and the runs that failed to run."""
    judged = [r for r in rows if "error" not in r]
    return {"runs": len(rows), "failed_to_run": len(rows) - len(judged),
            "false_alarms": sum(r["false_alarms"] or 0 for r in judged),
            "strangers_missed": sum(not r["found"] for r in judged),
            f"stops_later_than_{STOP_WITHIN:g}_s": sum(r["found"] and not r["stopped_in_time"] for r in judged)}


def merged(summary: Path, rows: list[dict]) -> list[dict]:
    """The rows of an earlier summary in the same folder with `rows` in place of their runs (scene, runtime,
    seed): one folder gathers a grid run a scene or a seed range at a time, and its summary covers all of it."""
    key = lambda row: (row["scene"], row["runtime"], row["seed"])  # noqa: E731
    earlier = json.loads(summary.read_text())["runs"] if summary.exists() else []
    runs = {key(row): row for row in earlier}
    runs.update({key(row): row for row in rows})
    return sorted(runs.values(), key=key)

if __name__ == "__main__":
    sys.exit(main())
