"""Level 5's start on the ROS graph, with detect's hold and turn-back and without: does the scene happen?

In level 5's scene the target stands 2 m ahead at the left edge of the robot's first image while move_base turns
the robot right towards its first goal. Once (a make demo run under load) detect saw the face once, the turn
carried it out of view before the second look, and the scene never happened. detect's answer: hold the robot
still while it looks again (`look_s`, `look_edge`), and turn back towards the face by odometry if it is gone all
the same (`look_turn`). This runs the scene's first seconds several times per variant, as the experiment runs it
(`subsumption run patrol --level 5 ... --runtime ros --rate 1 --operator experiments/patrol_operator.yaml`), and
prints per run when the alarm came, when the robot stood still, when the operator selected the face, and whether
the scene (selected, driven, released, patrol resumed) happened. Nothing is asserted; the race is rare, so a row
of "yes" says only that it did not happen in those runs.

    .venv/bin/python -m bench.level5_start [--runs 3] [--duration 30] [--variants turn-back,hold,none] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


VARIANTS = {  # detect's parameters per variant
    "turn-back": [],                                        # as shipped: hold still, turn back if the face is gone
    "hold": ["--param", "detect.look_turn=0"],              # hold still only
    "none": ["--param", "detect.look_s=0"],                 # neither (before the fix)
}
WORLD = "experiments/worlds/pingpong_operator_world.yaml"
MAP = "subsim/maps/pingpong.yaml"


def run(variant: str, seed: int, duration: float, out: Path) -> dict:
    """One ROS run of level 5's scene; its metrics.json (the run's own scene verdict in `scene_missing`), or the
    failure."""
    folder = out / f"{variant}_{seed}"
    command = [sys.executable, "-m", "subsumption.cli", "run", "patrol", "--level", "5", "--world", WORLD, "--map",
               MAP, "--duration", str(duration), "--rate", "1", "--runtime", "ros", "--operator",
               "experiments/patrol_operator.yaml", "--seed", str(seed), "--out", str(folder), *VARIANTS[variant]]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ))
    metrics_file = folder / "metrics.json"
    if not metrics_file.exists():
        return {"failed": f"exit {done.returncode}: {done.stderr.strip().splitlines()[-1:]}"}
    return json.loads(metrics_file.read_text())


def row(variant: str, seed: int, m: dict) -> str:
    if "failed" in m:
        return f"| {variant} | {seed} | run failed: {m['failed']} | | | | |"
    selected = (m.get("operator") or {}).get("selected") or []

    def seconds(value) -> str:
        return "-" if value is None else f"{value:.2f}"

    missing = m["scene_missing"]
    return (f"| {variant} | {seed} | {seconds(m.get('detected_at_s'))} | {seconds(m.get('stopped_at_s'))} | "
            f"{seconds(selected[0]['at_s'] if selected else None)} | {m.get('operator_commands', 0)} | "
            f"{'yes' if not missing else 'NO: ' + ', '.join(missing)} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="runs per variant (seeds 1..N)")
    parser.add_argument("--duration", type=float, default=30.0, help="simulated s per run (the scene takes ~25)")
    parser.add_argument("--variants", default="turn-back,hold,none", help=f"of {', '.join(VARIANTS)}")
    parser.add_argument("--out", type=Path, default=None, help="keep the runs here (default: a temporary folder)")
    args = parser.parse_args()
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        parser.error(f"--variants: unknown {', '.join(unknown)} (known: {', '.join(VARIANTS)})")
    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch)
        out.mkdir(parents=True, exist_ok=True)
        print(f"level 5's start, {args.runs} run(s) per variant, {args.duration:g} s each, ROS graph at 1x "
              f"(load average {os.getloadavg()[0]:.1f} at the start)\n")
        print("| variant | seed | alarm at s | robot still at s | operator selected at s | operator commands | "
              "scene happened |")
        print("|---|---|---|---|---|---|---|")
        happened = {v: 0 for v in variants}
        for seed in range(1, args.runs + 1):  # the variants alternate, so that the load falls on each alike
            for variant in variants:
                metrics = run(variant, seed, args.duration, out)
                happened[variant] += "failed" not in metrics and not metrics["scene_missing"]
                print(row(variant, seed, metrics), flush=True)
        print("\n" + ", ".join(f"{v}: scene in {happened[v]} of {args.runs}" for v in variants))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
