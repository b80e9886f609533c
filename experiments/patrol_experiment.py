"""`subsumption experiment patrol --out D`: the paper's second experiment (its Fig. 7), level by level.

The security patrol robot (robots/patrol/patrol.yaml) in the ping-pong room, each level in the scene the paper
shows it in, on the real ROS graph (one process per module, arbiter and the simulator), and for levels 0-4 again
in the in-process runtime for the numbers:

- level 0: a person walks at the robot, which backs away (Fig. 7(a));
- level 1: it wanders, the target robot crossing the room; on a bumper hit it backs off and turns away (Fig. 7(b));
- level 2: it explores the corridors round the table (Fig. 7(c));
- level 3: it builds the map with the project's own SLAM (once, the room empty), then patrols the room's four
  corners through move_base (Fig. 7(d)); a goal that fails raises an alarm, spoken into a WAV file;
- level 4: the target with a face photo comes in; the robot stops, raises the alarm, follows it, loses it at
  the door and patrols on (Fig. 7(e); experiments/worlds/pingpong_intruder_world.yaml);
- level 5: a scripted operator at the web terminal selects the target, drives by hand and lets go (Fig. 7(f);
  experiments/patrol_operator.yaml; ROS only: the terminal is a web server on real sockets).

Writes, in D: ``map/`` (the built map), ``levelN/`` per level (the ROS run's ``trajectory.png``,
``metrics.json``, ``alarms/*.wav``, ``logs/``, for levels 4-5 ``encounter.png`` and ``camera_strip.png``;
``levelN/local/`` the in-process run), ``fig7_trajectories.png`` (one panel per level, from the ROS runs),
``camera_strip_level4.png``/``_level5.png`` and ``summary.md`` (every run's figures, the encounter's times, the
alarm sounds). Each ROS run is its own ``subsumption run patrol`` process, exactly what a user would type.

A level whose scene has events (levels 4 and 5, experiments.patrol_scene) judges it in its own run: its
``metrics.json`` has ``scene_happened`` and ``scene_missing`` (what did not happen), written once by the run. The
experiment reads that verdict back and gives summary.md and the output a line each; when a scene did not happen
the experiment exits with status 3 once everything is written.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import textwrap
import time
from concurrent.futures import Future
from dataclasses import dataclass, field, replace
from pathlib import Path

import matplotlib
import yaml

from subsim import world_path
from subsim.world import WorldDocument

from .patrol import PatrolRun, built_map, execute
from .patrol_scene import SCENE_EVENTS
from .runner import ROBOTS, Stage
from .worker import InProcessWork

matplotlib.use("Agg")  # headless: figures are files, on CI and over ssh alike
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)

WORLDS = Path(__file__).with_name("worlds")


@dataclass(frozen=True)
class Scene:
    """What a level is shown doing (the paper's Fig. 7 panel), in which world, with which extra options."""

    caption: str
    world: str | None = None          # a world file in experiments/worlds/ (None: the shipped ping-pong room)
    ros_only: bool = False            # level 5's terminal is a web server on real sockets: ROS only
    options: tuple[str, ...] = ()     # more options of `subsumption run patrol`
    max_rate: float = 3.0             # on ROS, at most this many times real time


SCENES = {
    0: Scene("a person walks at the robot: it backs away"),
    1: Scene("it wanders; on a bumper hit it backs off and turns away"),
    2: Scene("it explores the corridors round the table"),
    3: Scene("map built by its own SLAM, then the four corners patrolled through move_base"),
    4: Scene("the target with a face enters: stop, alarm, follow, patrol resumes", "pingpong_intruder_world.yaml",
             max_rate=2.0),  # at 3x the pursuit closed in on the target in some runs only
    5: Scene("an operator selects the target, drives by hand, releases", "pingpong_operator_world.yaml",
             ros_only=True, options=("--operator", str(Path(__file__).with_name("patrol_operator.yaml"))),
             max_rate=2.0),  # with the terminal's server and the operator's client beside the graph, 3x lost frames
}
# The short form's level 4: the same encounter cut short (the robot already on the north side, the target ahead
# of it), so that every CI run sees stop, alarm, follow and patrol resumed on the ROS graph in 28-36 simulated s.
SHORT_SCENES = {
    4: Scene(SCENES[4].caption + " (cut short: the robot starts on the north side)",
             "pingpong_intruder_short_world.yaml", max_rate=SCENES[4].max_rate,
             options=("--goals", str(WORLDS / "pingpong_intruder_short_goals.yaml"))),
}
# The short form is the test suite's, which runs beside another test worker on two cores: there the graph cannot
# give the camera's frames 2x (track lost the target after 0.4 s of following once), so it runs level 4 at 1x.
QUICK_SCENES = {4: replace(SHORT_SCENES[4], max_rate=1.0)}
# Where the robot starts when its scene is the ping-pong room with another start than the shipped corner (1, 1)
# facing the south wall: level 0 with 4.5 m free behind (room to back away into); level 1 in the same corner but
# facing into the room (from the wall-facing start, seed 1 turned in the corner for its first 35 s: wander's random
# headings kept pointing into it, and the 57-degree camera forgets a wall once turned away from it).
SCENE_STARTS = {0: [5.0, 1.2, 0.0], 1: [1.0, 1.0, 0.785]}


@dataclass(frozen=True)
class Plan:
    """How long each run is: the full experiment (make demo) or the short form (the test of every CI run).
    Durations are simulated seconds per level; a level missing from `local` has no in-process run."""

    ros: dict[int, float]     # each level's run on the ROS graph
    rate: float               # simulated s per wall s on the ROS graph
    local: dict[int, float]   # each level's in-process run
    map_duration: float       # map building before the first level that navigates
    scenes: dict[int, Scene] = field(default_factory=dict)  # levels whose scene differs from SCENES'

    def scene(self, level: int) -> Scene:
        return self.scenes.get(level, SCENES[level])


# Durations are cut to what each panel needs, for make demo's 6 minutes. Level 4 is the cut scene in both forms
# (SHORT_SCENES): stop, alarm, follow, target lost and patrol resumed in 28 simulated s on the ROS graph; the short
# form gives it 36 s, since a run whose alarm comes early follows the target longer and resumes later. The whole
# lap of pingpong_intruder_world.yaml (the target cued by the robot reaching the south-east corner, the encounter
# at about 37 s) takes 100 s: `subsumption run patrol --level 4 --world experiments/worlds/pingpong_intruder_world.yaml`
# runs it. Level 5's operator selects the target at about 6 s.
# The short form leaves level 5 out, whose scene needs a minute at 1x: tests/test_patrol_level5.py runs a scripted
# operator live.
SHORT_FORM_LEAVES_OUT = "its scripted operator runs live in tests/test_patrol_level5.py"
FULL = Plan(ros={0: 20.0, 1: 30.0, 2: 30.0, 3: 45.0, 4: 28.0, 5: 60.0}, rate=3.0,
            local={0: 300.0, 1: 300.0, 2: 300.0, 3: 120.0}, map_duration=240.0, scenes=SHORT_SCENES)
QUICK = Plan(ros={0: 10.0, 1: 10.0, 2: 10.0, 3: 20.0, 4: 36.0}, rate=3.0,
             local={0: 30.0, 1: 30.0, 2: 30.0, 3: 60.0}, map_duration=240.0,  # shorter drives leave corners unmapped
             scenes=QUICK_SCENES)


def scene_of(level: int, metrics: dict) -> list[str] | None:
    """What of `level`'s scene did not happen, as its run judged it (``scene_missing`` in its metrics.json, written
    by the run itself: the experiment reads it and writes nothing back); None for a level without events."""
    return metrics["scene_missing"] if level in SCENE_EVENTS else None


def network_levels() -> int:
    """How many levels robots/patrol/patrol.yaml has (levels 4 and 5 are added by their own issues)."""
    return len(yaml.safe_load(ROBOTS["patrol"].read_text())["levels"])


def scene_world(level: int, folder: Path, scene: Scene | None = None) -> Path:
    """The world of `level`'s scene: the ping-pong room as shipped, a scene of experiments/worlds/ (levels 4 and
    5: the target's way through the room), or for levels 0 and 1 the room with the robot started as SCENE_STARTS
    says."""
    scene = scene or SCENES[level]
    if scene.world is not None:
        return WORLDS / scene.world
    world = world_path("pingpong")
    if level not in SCENE_STARTS:
        return world
    doc = WorldDocument(world)
    doc.robot["start"] = list(SCENE_STARTS[level])
    return doc.write(folder / "scene_world.yaml")


def in_process_run(run: PatrolRun) -> tuple[dict, float]:
    """One in-process run (in the worker): its metrics and the CPU s it took."""
    cpu = time.process_time()
    metrics = execute(run).metrics
    return metrics, time.process_time() - cpu


def run_level(level: int, out: Path, plan: Plan, seed: int, work: InProcessWork | None = None,
              nav_map: Path | None = None) -> tuple[dict, Future | None]:
    """One level on the ROS graph (a `subsumption run patrol` process, what a user would type); its in-process
    run, if the plan has one, handed to `work` before the ROS run starts (its future: metrics and CPU s).
    `nav_map`: the navigation map of levels 3 and up."""
    folder = out / f"level{level}"
    scene = plan.scene(level)
    world = scene_world(level, folder, scene)
    # a process per level: its in-process wires pass messages without copies (about half the CPU of a process per
    # module), which the camera levels at 1x need
    command = [sys.executable, "-m", "subsumption.cli", "run", "patrol", "--level", str(level), "--world",
               str(world), "--duration", str(plan.ros[level]), "--seed", str(seed), "--runtime", "ros",
               "--rate", str(min(plan.rate, scene.max_rate)), "--groups", "level", "--out", str(folder),
               *scene.options]
    if nav_map is not None:
        command += ["--map", str(nav_map)]
    _share_staff_model(out, folder)
    local = None  # given to the worker first, so that it runs beside this level's ROS run
    if level in plan.local and not scene.ros_only and work is not None:
        local = work.submit(in_process_run, PatrolRun(level, world, folder / "local", plan.local[level], seed,
                                                       "local", map_yaml=nav_map, progress=False))
    done = subprocess.run(command)
    if done.returncode != 0 or not (folder / "metrics.json").exists():
        raise RuntimeError(f"the ROS run of level {level} failed (exit {done.returncode}); see {folder / 'logs'}")
    return json.loads((folder / "metrics.json").read_text()), local


def _share_staff_model(out: Path, folder: Path) -> None:
    """The staff's face model enrolled by an earlier level (levels 4 and 5 use the same photos) copied into
    `folder`, where `subsumption run patrol` reuses it while it is newer than the photos: enrolling takes seconds."""
    made = sorted(out.glob("level*/staff.npz"))
    if made and not (folder / "staff.npz").exists():
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copy2(made[0], folder / "staff.npz")


def figure_7(out: Path, levels: int, plan: Plan) -> Path:
    """The paper's Fig. 7: one panel per level, the ROS runs' trajectories (goals and other agents drawn)."""
    fig, axes = plt.subplots(2, 3, figsize=(18, 11))
    for level, ax in enumerate(axes.flat):
        ax.axis("off")
        caption = textwrap.fill(f"({'abcdef'[level]}) level {level}: {plan.scene(level).caption}", 70)
        picture = out / f"level{level}" / "trajectory.png"
        if level < levels and picture.exists():
            ax.imshow(plt.imread(picture))
        else:
            why = "not in robots/patrol/patrol.yaml yet" if level >= levels else "not in this form of the experiment"
            ax.text(0.5, 0.5, f"level {level} is {why}", ha="center", va="center", fontsize=12, color="gray",
                    transform=ax.transAxes)
        ax.set_title(caption, fontsize=10)
    fig.tight_layout()
    path = out / "fig7_trajectories.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def summary_table(rows: list[tuple[int, str, dict]], plan: Plan) -> str:
    """Every run's figures, a row each (the keys the patrol issues name)."""
    head = ("| level | scene | runtime | simulated s | wall s | collisions | distance m | goals reached / sent | "
            "laps | alarms |")
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for level, runtime, m in rows:
        goals = f"{m.get('goals_reached', 0)} / {m.get('goals_sent', 0)}" if level >= 3 else "-"
        laps = str(m.get("laps", 0)) if level >= 3 else "-"
        lines.append(f"| {level} | {plan.scene(level).caption} | {runtime} | {m['sim_time_s']:.0f} | "
                     f"{m['wall_time_s']:.1f} | {m['collisions']} | {m.get('distance_m', 0.0):.1f} | {goals} | "
                     f"{laps} | {m.get('alarms', 0)} |")
    return "\n".join(lines)


ENCOUNTER_KEYS = [("detected_at_s", "detected at s"), ("stopped_at_s", "stopped at s"), ("followed_s", "followed s"),
                  ("mean_follow_distance_m", "follow distance m"), ("lost_at_s", "lost at s"),
                  ("resumed_patrol_at_s", "patrol resumed at s"), ("false_alarms", "false alarms"),
                  ("operator_commands", "operator commands"), ("manual_control_s", "manual control s")]


def encounter_table(rows: list[tuple[int, str, dict]]) -> str:
    """Levels 4 and 5: the target's encounter (and the operator's part), as simulated seconds from the start."""
    head = "| level | runtime | " + " | ".join(title for _, title in ENCOUNTER_KEYS) + " |"
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    for level, runtime, m in rows:
        if level < 4:
            continue
        cells = []
        for key, _ in ENCOUNTER_KEYS:
            value = m.get(key)
            cells.append("-" if value is None else f"{value:.1f}" if isinstance(value, float) else str(value))
        lines.append(f"| {level} | {runtime} | " + " | ".join(cells) + " |")
    return "\n".join(lines) if len(lines) > 2 else ""


def collect_media(out: Path, levels: int) -> list[str]:
    """The camera strips of levels 4 and 5 copied beside Fig. 7, and every alarm sound listed; Markdown lines."""
    lines = []
    for level in range(4, levels):
        strip = out / f"level{level}" / "camera_strip.png"
        if strip.exists():
            shutil.copyfile(strip, out / f"camera_strip_level{level}.png")
            lines.append(f"![level {level}: camera frames with the tracked box](camera_strip_level{level}.png)")
    sounds = sorted(out.glob("level*/alarms/*.wav"))
    if sounds:
        lines.append("Alarm sounds: " + ", ".join(f"[{p.relative_to(out)}]({p.relative_to(out)})" for p in sounds))
    return lines


def queue_map(work: InProcessWork, out: Path, plan: Plan, seed: int = 1) -> Future | None:
    """The map the navigating levels share, given to `work` to build into OUT/map with the project's SLAM (None when
    no level of the plan navigates). `make demo` queues it while the wander robot's ROS runs go on."""
    levels = network_levels()
    if not any(3 <= level < levels for level in plan.ros):
        return None
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    return work.submit(built_map, world_path("pingpong"), out, seed, plan.map_duration)


def main(out: Path, plan: Plan, seed: int = 1, work: InProcessWork | None = None,
         map_job: Future | None = None) -> int:
    """The experiment into `out`. `work`: the worker for the in-process runs (default: one of its own); `map_job`:
    the shared map already queued there by :func:`queue_map` (default: queued now, before the first level)."""
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    levels = network_levels()
    own_work = work is None
    work = work or InProcessWork()
    try:
        if map_job is None:
            map_job = queue_map(work, out, plan, seed)
        return _main(out, plan, seed, levels, work, started, map_job)
    finally:
        if own_work:
            work.close()


def _main(out: Path, plan: Plan, seed: int, levels: int, work: InProcessWork, started: float,
          map_job: Future | None) -> int:
    rows: list[tuple[int, str, dict]] = []
    stages: list[tuple[str, str]] = []
    verdicts: dict[int, list[str]] = {}  # level -> what of its scene did not happen
    in_process: dict[int, Future] = {}
    # map_job: built once, in D/map, by the worker while levels 0-2 run, and shared by the levels that navigate
    for level in range(levels):
        if level not in plan.ros:
            print(f"[patrol {level + 1}/{levels}] level {level}: not in this form ({SHORT_FORM_LEAVES_OUT})",
                  flush=True)
            continue
        if level >= 4 and work.busy():  # the camera's scenes at 1x: the machine to themselves
            waited = Stage.start()
            work.drain()
            stages.append(("waiting for the in-process runs", waited.end()))
        print(f"[patrol {level + 1}/{levels}] level {level}: {plan.scene(level).caption}", flush=True)
        stage = Stage.start()
        try:
            nav_map = map_job.result() if map_job is not None and level >= 3 else None
        except Exception as error:  # the worker's own error, whatever it is: said in one line
            print(f"subsumption experiment: building the map failed: {type(error).__name__}: {error}",
                  file=sys.stderr)
            return 1
        try:
            ros, local = run_level(level, out, plan, seed, work, nav_map)
        except RuntimeError as error:
            print(f"subsumption experiment: {error}", file=sys.stderr)
            return 1
        stages.append((f"level {level}", stage.end()))
        if local is not None:
            in_process[level] = local
        missing = scene_of(level, ros)
        if missing is not None:
            verdicts[level] = missing
            print(f"      {scene_line(level, missing)}", flush=True)
        rows.append((level, f"ros {min(plan.rate, plan.scene(level).max_rate):g}x", ros))
        print(f"      ros: {ros['collisions']} collisions, {ros['wall_time_s']:.1f} s wall ({stages[-1][1]})",
              flush=True)
    waited, busy = Stage.start(), work.busy()
    try:
        done = {level: future.result() for level, future in in_process.items()}
    except Exception as error:  # the worker's own error, whatever it is: said in one line, the rest kept
        print(f"subsumption experiment: an in-process run failed: {type(error).__name__}: {error}", file=sys.stderr)
        return 1
    if busy:
        stages.append(("waiting for the in-process runs", waited.end()))
    for level, (local, cpu) in done.items():
        rows.append((level, "local", local))
        print(f"      level {level} in-process, {local['sim_time_s']:.0f} s simulated: {local['collisions']} "
              f"collisions" + (f", {local['goals_reached']}/{local['goals_sent']} goals, {local['laps']} laps"
                               if level >= 3 else "") + f" ({cpu:.0f} CPU-s in the worker)", flush=True)
    rows.sort(key=lambda row: (row[0], row[1] == "local"))  # per level, the ROS run's row then the in-process one
    figure = figure_7(out, levels, plan)
    text = [summary_table(rows, plan), "", encounter_table(rows), "", *scene_lines(verdicts),
            *collect_media(out, levels)]
    left_out = [level for level in range(levels) if level not in plan.ros]
    if left_out:
        text.append(f"Level {', '.join(map(str, left_out))} left out of this form ({SHORT_FORM_LEAVES_OUT}).")
    missing = list(range(levels, 6))
    if missing:
        text.append(f"Levels {', '.join(map(str, missing))} are not in robots/patrol/patrol.yaml yet.")
    (out / "summary.md").write_text("\n".join(text) + "\n")
    print("\n".join(text))
    print("time per stage (wall, and CPU of the processes it ran): " + "; ".join(f"{name} {said}"
                                                                            for name, said in stages), flush=True)
    print(f"patrol experiment written to {out} ({figure.name}, summary.md, level0..level{levels - 1}/) in "
          f"{time.monotonic() - started:.0f} s", flush=True)
    failed = [level for level, missing in verdicts.items() if missing]
    if failed:
        for level in failed:
            print(f"subsumption experiment: {scene_line(level, verdicts[level])}", file=sys.stderr, flush=True)
        return SCENE_MISSED_EXIT
    return 0


SCENE_MISSED_EXIT = 3  # every run went through and everything is written, but a level's scene did not happen


def scene_line(level: int, missing: list[str]) -> str:
    """One line on whether `level`'s scene happened."""
    if not missing:
        return f"level {level}: the scene happened ({', '.join(what for what, _ in SCENE_EVENTS[level])})"
    return (f"level {level}: the scene did NOT happen, missing: {', '.join(missing)} (level{level}/metrics.json, "
            f"scene_missing)")


def scene_lines(verdicts: dict[int, list[str]]) -> list[str]:
    """summary.md's lines on the levels whose scenes have events (SCENE_EVENTS): whether each happened."""
    if not verdicts:
        return []
    return ["Scenes checked after the runs:", "", *(f"- {scene_line(level, missing)}"
                                                  for level, missing in sorted(verdicts.items())), ""]


def register_experiment(commands: argparse._SubParsersAction) -> None:
    cmd = commands.add_parser(
        "experiment", help="run one of the paper's experiments end to end (patrol: its Fig. 7, level by level)",
        description="The patrol robot's levels in the ping-pong room, each on the real ROS graph and in-process; "
                    "writes fig7_trajectories.png, summary.md and a folder per level. Exit status 3: everything "
                    "ran and is written, but a level's scene did not happen (summary.md says what is missing).")
    cmd.add_argument("name", choices=("patrol",), help="which experiment: patrol (the security robot, Fig. 7)")
    cmd.add_argument("--out", type=Path, required=True, help="folder for the figure, the table and the runs")
    cmd.add_argument("--quick", action="store_true",
                     help=f"the short form (ROS runs of {min(QUICK.ros.values()):g}-{max(QUICK.ros.values()):g} s, "
                          f"in-process runs of {max(QUICK.local.values()):g} s), as the test of every CI run uses it")
    cmd.add_argument("--seed", type=int, default=1, help="random seed of every run (default 1)")
    cmd.set_defaults(func=lambda args: main(args.out, QUICK if args.quick else FULL, args.seed))
