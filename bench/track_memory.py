"""Memory of the level-4 vision nodes over many encounters: a leak, or a high-water mark that levels off?

The one-hour soak (bench.soak) found the ``track`` node's resident memory +12.8 % from its 5-minute value (the
hour before +6.4 %; ``follow`` +9.5 %, ``detect`` +8.3 % in an older hour). This bench asks why, in minutes: it
starts its own ROS master and the real ``detect``, ``track`` and ``follow`` module nodes (``nodes/module``, wired
and parametrised as in robots/patrol/patrol.yaml, detect's target straight into track), and publishes the
simulator's camera frames to them at the camera's rate (30 per simulated second) on simulated time (/clock, as
``--runtime ros`` runs; as fast as this process renders, about half of real time on a loaded machine, so the
nodes keep up and nothing is dropped): the ping-pong room seen by a robot that
stands still while a TurtleBot with a face card drives towards it and away again, over and over (the card
faces the camera on the way in only). One round of that is an *encounter*: the target appears, detect raises
the alarm and hands it to track, track and follow keep it, it turns away, is lost, track gives up.

After each encounter it reads every node's resident memory (VmRSS, and RssAnon: the process's own heap, not
shared libraries) from /proc and prints it. At the end: each node's growth from encounter --baseline (the
soak's 5 minutes) to the end, and over the second half (a leak keeps growing; a high-water mark does not).

    .venv/bin/python -m bench.track_memory [--encounters 30] [--fps 30] [--malloc-env NAME=VALUE ...]

``--malloc-env`` sets glibc malloc tunables in the nodes' environment (e.g. ``MALLOC_ARENA_MAX=2``), to compare.
Writes OUT/track_memory.json (every sample).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
NODE = ROOT / "nodes" / "module"
CAMERA = {"image": "/camera/rgb/image_raw", "depth": "/camera/depth/image_raw", "camera_info": "/camera/rgb/camera_info"}
# as robots/patrol/patrol.yaml runs them (detect's target reaches track through the posters filter there)
NODES = {
    "detect": ("vision.modules:Detect", {**CAMERA}, {"below_horizon_px": 16, "rate": 5.0, "cpu_share": 0.08}),
    "track": ("vision.modules:Track", {"image": CAMERA["image"], "camera_info": CAMERA["camera_info"],
                                       "target": "/detect/target"}, {"give_up_s": 10.0}),
    "follow": ("vision.modules:Follow", {"box_info": "/track/box_info", "depth": CAMERA["depth"],
                                         "alarm": "/detect/alarm"}, {"distance_m": 1.2, "max_v": 0.6, "still_s": 1.0}),
}
ROBOT_AT = (1.0, 1.5, 0.0)
NEAR_X, FAR_X, SPEED = 2.8, 6.3, 0.5  # the target's round: in towards the robot, out again (m, m/s)


def proc_kb(pid: int, key: str) -> int | None:
    """A /proc/PID/status figure in kB (VmRSS, RssAnon), None if the process is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def cpu_s(pid: int) -> float | None:
    """User + system CPU seconds of a process so far (/proc/PID/stat), None if it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def scene(out: Path) -> Path:
    """The ping-pong room with the robot standing at ROBOT_AT looking east and the target driving its round."""
    from subsim import world_path

    base = world_path("pingpong").parent
    data = yaml.safe_load(world_path("pingpong").read_text())
    data["map"] = str((base / data["map"]).resolve())
    for picture in data["scene"]["pictures"]:
        picture["file"] = str((base / picture["file"]).resolve())
    data["robots"][0]["start"] = list(ROBOT_AT)
    data["agents"] = [{"name": "target", "kind": "robot", "motion": "waypoints", "speed": SPEED, "loop": True,
                       "start": [FAR_X, ROBOT_AT[1], 3.14159], "waypoints": [[NEAR_X, ROBOT_AT[1]], [FAR_X, ROBOT_AT[1]]],
                       "picture": {"file": str(base.parent / "pictures" / "face_astronaut.png"), "height": 0.45,
                                   "centre": 0.62}}]
    path = out / "track_memory_world.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def start_nodes(env: dict[str, str], out: Path) -> dict[str, subprocess.Popen]:
    from subsumption.ros.master import tied_to_parent

    processes = {}
    for name, (cls, remaps, params) in NODES.items():
        args = [sys.executable, str(NODE), f"__name:={name}", f"_class:={cls}"]
        args += [f"{port}:={topic}" for port, topic in remaps.items()]
        args += [f"_{key}:={value}" for key, value in params.items()]
        log = (out / f"{name}.log").open("w")
        processes[name] = subprocess.Popen(tied_to_parent(args), env=env, cwd=ROOT, stdout=log,
                                           stderr=subprocess.STDOUT, start_new_session=True)
        log.close()
    return processes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.track_memory", description=__doc__.split("\n\n")[0])
    parser.add_argument("--encounters", type=int, default=30)
    parser.add_argument("--baseline", type=int, default=5, help="encounter whose memory is the baseline")
    parser.add_argument("--fps", type=float, default=30.0, help="camera frames per second (the simulator's: 30)")
    parser.add_argument("--malloc-env", action="append", default=[], metavar="NAME=VALUE",
                        help="set in the nodes' environment (glibc tunables), e.g. MALLOC_ARENA_MAX=2")
    parser.add_argument("--allocator-default", action="store_true",
                        help="the nodes keep what they free: SUBSUMPTION_MALLOC=default, glibc's own behaviour (the "
                             "old code's; see subsumption.ros.memory)")
    parser.add_argument("--stall-every", type=int, default=0, metavar="K",
                        help="every Kth encounter, stop the nodes (SIGSTOP) for --stall-s wall s mid-way while frames "
                             "go on: what a loaded machine does to them, on purpose (0: never)")
    parser.add_argument("--stall-s", type=float, default=3.0)
    parser.add_argument("--out", type=Path, default=Path("out/track_memory"))
    args = parser.parse_args(argv)
    if not 0 < args.baseline < args.encounters:
        parser.error("expected 0 < --baseline < --encounters")
    if not args.fps > 0:
        parser.error(f"--fps must be > 0, got {args.fps}")
    extra = {}
    for item in args.malloc_env:
        name, sep, value = item.partition("=")
        if not sep or not name:
            parser.error(f"--malloc-env expects NAME=VALUE, got {item!r}")
        extra[name] = value
    if args.allocator_default:
        extra["SUBSUMPTION_MALLOC"] = "default"
    args.out.mkdir(parents=True, exist_ok=True)

    from subsim import Simulation
    from subsim.camera import depth_pixels
    from subsumption.images import from_array
    from subsumption.ros.master import host_env, start_master
    from vision.replay import camera_messages

    master = start_master(timeout=120.0)  # a loaded machine starts it slowly
    import rosgraph

    rosgraph.Master("/track_memory", master_uri=master.uri).setParam("/use_sim_time", True)
    env = host_env(dict(os.environ, ROS_MASTER_URI=master.uri, PYTHONUNBUFFERED="1", **extra))
    env["ROS_PACKAGE_PATH"] = f"{ROOT}:{env.get('ROS_PACKAGE_PATH', '/usr/share')}"
    processes = start_nodes(env, args.out)
    samples: dict[str, list[tuple[int, int, int]]] = {name: [] for name in NODES}  # (encounter, rss kB, anon kB)
    cpu: dict[str, float | None] = {}
    try:
        os.environ.update(ROS_MASTER_URI=master.uri, ROS_HOSTNAME="127.0.0.1", ROS_IP="127.0.0.1")
        import genpy
        import rospy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest
        from std_msgs.msg import Bool

        rospy.init_node("track_memory", disable_signals=True)
        publishers = {kind: rospy.Publisher(CAMERA[kind], msg, queue_size=1)
                      for kind, msg in (("image", Image), ("depth", Image), ("camera_info", CameraInfo))}
        clock = rospy.Publisher("/clock", Clock, queue_size=1)
        counts = {"targets": 0, "confident": 0}
        rospy.Subscriber("/detect/target", RegionOfInterest, lambda _: counts.__setitem__("targets", counts["targets"] + 1))
        rospy.Subscriber("/track/confident", Bool,
                         lambda m: counts.__setitem__("confident", counts["confident"] + bool(m.data)))
        sim = Simulation(scene(args.out), seed=0, record=False)
        period = 2 * (FAR_X - NEAR_X) / SPEED
        deadline = time.monotonic() + 300  # wall clock: the nodes' start-up
        while time.monotonic() < deadline and any(p.get_num_connections() == 0 for p in publishers.values()):
            clock.publish(Clock(genpy.Time.from_sec(0.0)))
            time.sleep(0.2)
        print(f"track_memory: {len(NODES)} nodes, {args.encounters} encounters of {period:.0f} s at {args.fps:g} "
              f"fps{' with ' + ' '.join(args.malloc_env) if args.malloc_env else ''}", flush=True)
        print(f"{'enc':>4} {'targets':>7} {'confident':>9}  " + "  ".join(f"{n + ' MB':>14}" for n in NODES)
              + "   (VmRSS/RssAnon; wall s)", flush=True)
        frame = 0
        start = time.monotonic()  # wall clock on purpose: how long the bench takes
        for encounter in range(1, args.encounters + 1):
            before = dict(counts)
            stall_at = (encounter - 0.5) * period if args.stall_every and encounter % args.stall_every == 0 else None
            while sim.time < encounter * period:
                if stall_at is not None and sim.time >= stall_at:
                    stall_at = None
                    stall(processes, args.stall_s)
                frame += 1
                while sim.time < frame / args.fps - 1e-9:
                    sim.step(0.02)
                rendered = sim.render("robot0")
                clock.publish(Clock(genpy.Time.from_sec(sim.time)))
                image, depth, info = camera_messages(rendered.rgb, rendered.depth, sim.time)
                depth = from_array(depth_pixels(rendered.depth, "16UC1"), "16UC1", depth.header)  # as the simulator's
                for kind, msg in (("camera_info", info), ("depth", depth), ("image", image)):
                    publishers[kind].publish(msg)
            row = []
            for name, process in processes.items():
                rss, anon = proc_kb(process.pid, "VmRSS"), proc_kb(process.pid, "RssAnon")
                if rss is None or anon is None:
                    print(f"track_memory: node {name} died (status {process.poll()}); see {args.out / name}.log",
                          file=sys.stderr)
                    return 1
                samples[name].append((encounter, rss, anon))
                row.append(f"{rss / 1024:6.1f}/{anon / 1024:6.1f}")
            print(f"{encounter:4d} {counts['targets'] - before['targets']:7d} {counts['confident'] - before['confident']:9d}  "
                  + "  ".join(f"{cell:>14}" for cell in row)
                  + f"   {time.monotonic() - start:6.0f} s", flush=True)
        cpu = {name: cpu_s(process.pid) for name, process in processes.items()}
    finally:
        for process in processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in processes.values():
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        master.stop()
    return report(args, samples, extra, cpu)


def stall(processes: dict[str, subprocess.Popen], seconds: float) -> None:
    """Stop the nodes for `seconds` of wall time (frames keep coming meanwhile: they wait in the sockets)."""
    for process in processes.values():
        process.send_signal(signal.SIGSTOP)
    time.sleep(seconds)  # wall clock on purpose: a machine too busy to run them
    for process in processes.values():
        process.send_signal(signal.SIGCONT)


def growth(values: list[tuple[int, int]], baseline: int) -> dict:
    """Growth of (encounter, kB) samples from `baseline` to the end, and over the second half."""
    base = next(kb for e, kb in values if e >= baseline)
    half = next(kb for e, kb in values if e >= values[-1][0] / 2)
    last = values[-1][1]
    return {"baseline_mb": round(base / 1024, 1), "end_mb": round(last / 1024, 1),
            "growth": round(last / base - 1.0, 4), "second_half_growth": round(last / half - 1.0, 4)}


def report(args: argparse.Namespace, samples: dict, extra: dict, cpu: dict) -> int:
    summary = {"encounters": args.encounters, "fps": args.fps, "baseline_encounter": args.baseline,
               "malloc_env": extra, "nodes": {}}
    print(f"\nfrom encounter {args.baseline} to {args.encounters} (second half: from {args.encounters // 2}):")
    for name, rows in samples.items():
        if not rows:
            continue
        rss = growth([(e, r) for e, r, _ in rows], args.baseline)
        anon = growth([(e, a) for e, _, a in rows], args.baseline)
        summary["nodes"][name] = {"rss": rss, "anon": anon, "cpu_s": cpu.get(name), "samples_kb": rows}
        print(f"  {name:>7}: VmRSS {rss['baseline_mb']:6.1f} -> {rss['end_mb']:6.1f} MB ({rss['growth']:+.1%}, "
              f"second half {rss['second_half_growth']:+.1%}); RssAnon {anon['baseline_mb']:6.1f} -> "
              f"{anon['end_mb']:6.1f} MB ({anon['growth']:+.1%}, second half {anon['second_half_growth']:+.1%}); "
              f"CPU {cpu.get(name) or 0:.0f} s")
    (args.out / "track_memory.json").write_text(json.dumps(summary, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
