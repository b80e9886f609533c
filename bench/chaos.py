"""Chaos: the patrol robot at level 4 on ROS while a random non-critical node is killed (SIGKILL) every --every s.

The run is the ordinary command (``subsumption run patrol --level 4 --runtime ros --rate 1``, the ping-pong room
with its intruder coming and going); this process joins its master as a node of its own, reads /clock, and at every
--every simulated seconds SIGKILLs the process of a node drawn at random (--seed) from those the network file does
not mark ``critical`` and declares ``respawn: true`` (the robot is meant to live on without them). Afterwards it
reads the run's metrics.json and prints, per kill: whether the death was recorded (``deaths``), how long after the
kill the monitor reported it (simulated s; at --rate 1 that is wall s too), and whether the respawn was recorded
(``respawns``); then the run's collisions. The issue's figure is --duration 600 --every 60: 0 collisions, every
death reported within 3 s, every respawn recorded.

    .venv/bin/python -m bench.chaos [--duration 600] [--every 60] [--seed 1] [--groups none|level] [--out out/chaos]
    .venv/bin/python -m bench.chaos --duration 150 --every 30     # a short version (about 4 minutes of wall time)

Writes OUT/chaos.json (the kills and what was recorded of each) beside the run's own outputs.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
import xmlrpc.client
from pathlib import Path

from subsumption.network import load
from subsumption.network.wiring import wire
from subsumption.ros.launch import watched_nodes

ROOT = Path(__file__).resolve().parent.parent
PATROL = ROOT / "robots" / "patrol" / "patrol.yaml"
WORLD = ROOT / "experiments" / "worlds" / "pingpong_intruder_world.yaml"
MAP = ROOT / "subsim" / "maps" / "pingpong.yaml"
LEVEL = 4
REPORT_WITHIN = 3.0  # s: the bound on reporting a death


def victims(level: int = LEVEL, groups: str = "none") -> list[str]:
    """Nodes of the patrol at `level` (run with `groups`) that are neither critical nor left dead: non-critical,
    respawned."""
    return sorted(n["name"] for n in watched_nodes(wire(load(PATROL), level), groups)
                  if not n["critical"] and n["respawn"])


class RunWatch:
    """Reads the run's stderr (its master's URI, its progress) in a thread, keeping the last lines for errors."""

    def __init__(self, process: subprocess.Popen) -> None:
        self.process = process
        self.master_uri: str | None = None
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stderr:  # type: ignore[union-attr]
            self.lines = (self.lines + [line.rstrip()])[-20:]
            found = re.search(r"ROS master (http://\S+)", line)
            if found:
                self.master_uri = found.group(1)

    def wait_for_master(self, who: str, timeout: float = 120.0) -> str | None:
        """The run's master URI once it has printed it (wall clock: the run's start-up, at most `timeout` s); None,
        with the run's last lines on stderr under `who`'s name, if it did not."""
        end = time.monotonic() + timeout
        while self.master_uri is None and self.process.poll() is None and time.monotonic() < end:
            time.sleep(0.2)
        if self.master_uri is None:
            print(f"{who}: the run gave no master URI:\n" + "\n".join(self.lines), file=sys.stderr)
        return self.master_uri

    def join_graph(self, who: str) -> str | None:
        """Once the run's master is up (:meth:`wait_for_master`), this process joins its graph as the node `who`
        (rospy's signal handlers off: the bench stops the run itself). The master's URI; None if it never came."""
        master_uri = self.wait_for_master(who)
        if master_uri is not None:
            os.environ["ROS_MASTER_URI"] = master_uri
            import rospy

            rospy.init_node(who, disable_signals=True)
        return master_uri


def pid_of(master_uri: str, node: str) -> int | None:
    import rosgraph

    try:
        uri = rosgraph.Master("/chaos", master_uri=master_uri).lookupNode("/" + node)
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/chaos")
        return int(pid) if code == 1 else None
    except Exception:  # not registered, or its registration points at a dead process (not back yet)
        return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.chaos", description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="simulated s of the run")
    parser.add_argument("--every", type=float, default=60.0, help="simulated s between kills")
    parser.add_argument("--seed", type=int, default=1, help="the run's seed and the draw of the victims")
    parser.add_argument("--rate", type=float, default=1.0, help="simulated s per wall s")
    parser.add_argument("--out", type=Path, default=Path("out/chaos"))
    parser.add_argument("--kill", action="append", default=[], metavar="NODE@S",
                        help="kill NODE at S simulated s instead of the random draw (critical ones too: "
                             "move_base@22 is the issue's case); repeatable")
    parser.add_argument("--groups", choices=("none", "level"), default="none",
                        help="a node per module and arbiter (none: the victims are modules) or a process per level "
                             "(level, as the robot ships: the victims are levels)")
    parser.add_argument("--short", action="store_true",
                        help="the issue's short scene (pingpong_intruder_short_world and its goals)")
    args = parser.parse_args(argv)
    if not (args.duration > 0 and 0 < args.every < args.duration and args.rate > 0):
        parser.error("expected --duration > --every > 0 and --rate > 0")
    try:
        planned = sorted((float(at), node) for node, _, at in (item.rpartition("@") for item in args.kill))
    except ValueError:
        parser.error(f"--kill wants NODE@SECONDS, got {args.kill}")
    pool = victims(LEVEL, args.groups)
    draw = random.Random(args.seed)
    world, goals = (WORLD.with_name("pingpong_intruder_short_world.yaml"),
                    WORLD.with_name("pingpong_intruder_short_goals.yaml")) if args.short else (WORLD, None)
    command = [str(Path(sys.executable).parent / "subsumption"), "run", "patrol", "--level", str(LEVEL),
               "--world", str(world), "--map", str(MAP), "--runtime", "ros", "--rate", str(args.rate),
               "--duration", str(args.duration), "--seed", str(args.seed), "--out", str(args.out),
               "--groups", args.groups]
    command += ["--goals", str(goals)] if goals else []
    print(f"chaos: {' '.join(command)}\n  victims drawn from {len(pool)} nodes: {', '.join(pool)}", flush=True)
    run = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                           start_new_session=True)
    watch = RunWatch(run)
    kills: list[dict] = []
    try:
        master_uri = watch.join_graph("chaos")
        if master_uri is None:
            return 1
        import rospy

        next_kill = args.every
        while run.poll() is None:
            now = rospy.get_time()
            due = planned[0][0] if planned else next_kill
            if now >= due and now < args.duration - 5.0:
                node = planned.pop(0)[1] if planned else draw.choice(pool)
                pid = pid_of(master_uri, node)
                if pid is not None:
                    os.kill(pid, signal.SIGKILL)
                    kills.append({"node": node, "pid": pid, "at_s": round(now, 2)})
                    print(f"  {now:7.1f} s: SIGKILL {node} (pid {pid})", flush=True)
                if not args.kill:
                    next_kill += args.every
            if args.kill and not planned:
                next_kill = float("inf")
            time.sleep(0.05)
    finally:
        if run.poll() is None:
            run.send_signal(signal.SIGINT)
            run.wait(60)
    return report(args, kills, run.returncode, watch)


def report(args: argparse.Namespace, kills: list[dict], status: int, watch: RunWatch) -> int:
    metrics_path = args.out / "metrics.json"
    if not metrics_path.exists():
        print(f"chaos: the run wrote no metrics (status {status}):\n" + "\n".join(watch.lines), file=sys.stderr)
        return 1
    metrics = json.loads(metrics_path.read_text())
    deaths, respawns = metrics.get("deaths", []), metrics.get("respawns", [])
    late = unreported = not_back = 0
    for kill in kills:
        death = next((d for d in deaths if d["node"] == kill["node"] and d["at_s"] >= kill["at_s"] - 0.5), None)
        kill["reported_after_s"] = round(death["at_s"] - kill["at_s"], 2) if death else None
        kill["how"] = death["how"] if death else None
        back = next((r for r in respawns if r["node"] == kill["node"] and r["at_s"] >= kill["at_s"]), None)
        kill["respawned_after_s"] = round(back["at_s"] - kill["at_s"], 2) if back else None
        unreported += death is None
        late += death is not None and kill["reported_after_s"] > REPORT_WITHIN
        not_back += back is None
        print(f"  {kill['node']:>22} killed at {kill['at_s']:7.1f} s: death "
              f"{'reported %.2f s later' % kill['reported_after_s'] if death else 'NOT REPORTED'}, respawn "
              f"{'recorded %.2f s later' % kill['respawned_after_s'] if back else 'NOT RECORDED'}")
    summary = {"kills": len(kills), "deaths_recorded": len(deaths), "unreported": unreported,
               f"reported_later_than_{REPORT_WITHIN:g}_s": late, "respawns_not_recorded": not_back,
               "collisions": metrics.get("collisions"), "sim_time_s": metrics.get("sim_time_s"),
               "goals_failed": metrics.get("goals_failed"), "goals_reached": metrics.get("goals_reached"),
               "alarms": [f"{a['raised_at_s']:.1f} s: {a['name']}: {a['message']}" for a in metrics.get("alarm_log", [])],
               "complete": metrics.get("complete"), "ended": metrics.get("ended"), "kill_log": kills}
    (args.out / "chaos.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"chaos: {len(kills)} kills in {metrics.get('sim_time_s')} s simulated: {unreported} deaths unreported, "
          f"{late} reported later than {REPORT_WITHIN:g} s, {not_back} respawns not recorded, "
          f"{metrics.get('collisions')} collisions; {len(deaths)} deaths recorded in all ({args.out}/chaos.json)")
    print(f"  goals: {metrics.get('goals_reached')} reached, {metrics.get('goals_failed')} failed; alarms:\n    "
          + "\n    ".join(summary["alarms"]))
    return 0 if kills and not (unreported or late or not_back or metrics.get("collisions")) else 1


if __name__ == "__main__":
    sys.exit(main())
