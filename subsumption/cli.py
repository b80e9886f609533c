"""The ``subsumption`` command: check, graph, launch and info, plus whatever installed packages add.

Robots and simulators extend the command without the core knowing them: any distribution may declare an
entry point in the group ``subsumption.commands`` naming a function ``register(subparsers)`` that adds its
subparser and sets a ``func`` default (called with the parsed arguments, returning an exit status)::

    [project.entry-points."subsumption.commands"]
    run = "robots.cli:register_run"
"""
from __future__ import annotations

import argparse
import signal
import sys
import time
from importlib.metadata import entry_points
from typing import Callable, Sequence

from . import arguments

ENTRY_POINT_GROUP = "subsumption.commands"


_level = arguments.level  # every command's values are checked in one place (subsumption.arguments)


def _add_network_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="network file (YAML, see docs/networks.md)")
    parser.add_argument("--level", "-l", type=_level, default=None,
                        help="run levels 0..N only (default: every level)")


def cmd_check(args: argparse.Namespace) -> int:
    """``subsumption check``: print every error of a network file (``FILE:LINE: what``) or a summary; exit status 1 on
    errors."""
    from .network.check import check_file
    result = check_file(args.file, args.level)
    for error in result.errors:
        print(error, file=sys.stderr)
    if result.errors:
        print(f"{args.file}: {len(result.errors)} error{'s' if len(result.errors) != 1 else ''}", file=sys.stderr)
        return 1
    print(result.summary())
    return 0


def _loaded_wiring(args: argparse.Namespace):
    """The network and its wiring, or None after printing every problem (as check would)."""
    from .network.check import check_file
    result = check_file(args.file, args.level)
    if result.errors:
        for error in result.errors:
            print(error, file=sys.stderr)
        return None
    return result.network, result.wiring


def cmd_graph(args: argparse.Namespace) -> int:
    """``subsumption graph``: draw a network file as the paper's figures do (SVG, PNG or PDF by the suffix)."""
    from .network.graph import draw
    loaded = _loaded_wiring(args)
    if loaded is None:
        return 1
    print(draw(loaded[1], args.output))
    return 0


def add_groups_arg(parser: argparse.ArgumentParser) -> None:
    """--groups: which modules and arbiters share a process under ROS (subsumption.network.groups)."""
    parser.add_argument("--groups", choices=("file", "level", "none"), default="file",
                        help="module groups, one ROS node process each with in-process wires inside: as the network "
                             "file's group: keys say (file, the default), one per level (level), or one process "
                             "per module and arbiter (none); see docs/ros.md")


def cmd_launch(args: argparse.Namespace) -> int:
    """``subsumption launch``: write the roslaunch XML for levels 0..N and run it until Ctrl-C (or only write it)."""
    from .ros.launch import launch, write_launch
    loaded = _loaded_wiring(args)
    if loaded is None:
        return 1
    network = loaded[0]
    if args.write_only:
        if not args.xml:
            print("subsumption launch: --write-only needs --xml OUT.launch", file=sys.stderr)
            return 2
        print(write_launch(network, args.level, args.xml, args.namespace, args.groups))
        return 0
    running = launch(network, args.level, namespace=args.namespace, xml=args.xml, groups=args.groups)
    print(f"subsumption launch: roslaunch {running.path} (pid {running.pid})", flush=True)

    # The handler only takes note: stopping means waiting for roslaunch, which must not happen inside a
    # signal handler that interrupted a wait on the same process.
    requested: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, _frame: requested.append(signum))
    signal.signal(signal.SIGTERM, lambda signum, _frame: requested.append(signum))
    while running.running() and not requested:
        time.sleep(0.1)
    return running.stop()


def cmd_info(args: argparse.Namespace) -> int:
    """``subsumption info``: describe a module class (ports, parameters) and an AFSM's states; ``--dot`` draws the
    states."""
    from .afsm import AFSM
    from .loading import ClassPathError, load_module_class
    try:
        module_class = load_module_class(args.cls)
    except ClassPathError as error:
        print(f"subsumption info: {error}", file=sys.stderr)
        return 1
    if args.markdown:
        from .params import ports_table
        print(ports_table(module_class))
        return 0
    print(module_class.describe())
    is_machine = issubclass(module_class, AFSM)
    if is_machine:
        print(module_class.describe_machine())
    if args.dot:
        if not is_machine:
            print(f"subsumption info: {args.cls} is not an AFSM: it has no state diagram", file=sys.stderr)
            return 1
        import graphviz

        from .network.graph import render
        print(render(graphviz.Source(module_class.to_dot()), args.dot))
    return 0


def cmd_params(args: argparse.Namespace) -> int:
    """Print the parameters of a module class or of every module of a network file (exit 2 on bad input)."""
    from .loading import ClassPathError, load_module_class
    from .params import markdown_table, text_table
    table = markdown_table if args.markdown else text_table
    if ":" in args.target and not args.target.endswith((".yaml", ".yml")):
        try:
            module_class = load_module_class(args.target)
        except ClassPathError as error:
            print(f"subsumption params: {error}", file=sys.stderr)
            return 2
        name = f"{module_class.__module__}:{module_class.__qualname__}"
        print(table(module_class) if args.markdown else f"{name}\n{table(module_class)}")
        return 0
    from .network.check import check_file
    result = check_file(args.target)
    if result.errors:
        for error in result.errors:
            print(error, file=sys.stderr)
        return 2
    blocks = []
    for module in result.network.modules():
        if module.is_node:
            about = f"an existing ROS node ({module.node}): its parameters are its own"
            blocks.append(f"### `{module.name}` (level {module.level})\n\n{about}" if args.markdown
                          else f"{module.name} (level {module.level}): {about}")
            continue
        module_class = load_module_class(module.class_path)  # check_file has imported it already
        if args.markdown:
            blocks.append(f"### `{module.name}` (level {module.level}, `{module.class_path}`)\n\n"
                          f"{table(module_class, module.params)}")
        else:
            blocks.append(f"{module.name} (level {module.level}, {module.class_path})\n"
                          f"{table(module_class, module.params)}")
    print(("\n\n" if args.markdown else "\n").join(blocks))
    return 0


def cmd_watch(args: argparse.Namespace) -> int:
    """``subsumption watch``: show a network running on the ROS master live (health, arbiter holders, rates)."""
    from .ros.watch import NoMonitor, master_answers, running_network, watch
    if args.file is None:  # the running monitor knows which network runs (its ~network_file and ~level)
        if not master_answers():
            return watch(None, args.namespace, args.once, args.period)  # its one line: no master
        try:
            args.file, level, args.namespace = running_network(args.namespace)
        except NoMonitor as error:
            print(error, file=sys.stderr)
            return 2
        args.level = level if args.level is None else args.level
        print(f"subsumption watch: {args.file}, levels 0..{args.level}, namespace {args.namespace} "
              f"(from the running monitor)", file=sys.stderr)
    loaded = _loaded_wiring(args)
    if loaded is None:
        return 1
    return watch(loaded[1], args.namespace, args.once, args.period)


def cmd_doctor(args: argparse.Namespace) -> int:
    """``subsumption doctor``: check a running robot's topics against its profile (one line per problem); exit status 2
    on a bad profile."""
    from .profile import ProfileError, load_profile
    try:
        profile = load_profile(args.profile)
    except ProfileError as error:
        print(f"subsumption doctor: {error}", file=sys.stderr)
        return 2
    from .ros.doctor import doctor
    return doctor(profile, args.robot, args.level, args.listen)


def cmd_goals(args: argparse.Namespace) -> int:
    """``subsumption goals FILE``: save the poses given with rviz's "2D Nav Goal" into a patrol goals file; exit status
    2 on a bad path."""
    from pathlib import Path

    from .ros.goals import record
    path = Path(args.file)
    if not path.parent.is_dir():
        print(f"subsumption goals: {args.file}: no such folder {str(path.parent)!r}", file=sys.stderr)
        return 2
    return record(path, args.topic)


def cmd_replay(args: argparse.Namespace) -> int:
    """``subsumption replay``: play a bag's sensors into a network and compare its answers with the recording."""
    from .ros.replay import main_replay
    return main_replay(args)


def cmd_tf(args: argparse.Namespace) -> int:
    """`subsumption tf SOURCE TARGET`: print the transform as tf_echo does (Debian ships no tf_echo)."""
    from .ros.tf_echo import main_tf
    return main_tf(args.source, args.target, args.once, args.period, args.timeout)


def cmd_reconfigure(args: argparse.Namespace) -> int:
    """``subsumption reconfigure``: show or set a running node's dynamic_reconfigure parameters."""
    from .ros.reconfigure import main_reconfigure
    return main_reconfigure(args.node, args.assignments, args.timeout)


_assignment = arguments.assignment


def _fraction(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, got {value}")
    return value


_positive = arguments.number(0.0, False, "a number > 0")


def version() -> str:
    """The installed distribution's version (pip or catkin), else the package.xml beside this checkout."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed_version
    try:
        return installed_version("subsumption")
    except PackageNotFoundError:
        import re
        from pathlib import Path
        manifest = Path(__file__).resolve().parent.parent / "package.xml"
        found = re.search(r"<version>([^<]+)</version>", manifest.read_text()) if manifest.exists() else None
        return found.group(1) if found else "unknown"


def build_parser(plugins: bool = True, command: str | None = None) -> argparse.ArgumentParser:
    """The ``subsumption`` argument parser: the core's commands, plus the installed plugins' unless `plugins` is
    false. With `command` (the command about to run) only the plugin of that name is loaded, if any: a plugin's
    entry point is named after the command it adds, and loading one imports its package (the simulator,
    matplotlib, ...), which costs seconds that `subsumption check` need not spend."""
    parser = arguments.OneLineParser(prog="subsumption", description="Brooks' subsumption architecture on ROS 1: "
                                     "check, draw and run network files; describe modules; watch, tune and "
                                     "replay a running network.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}",
                        help="print the version and exit")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                     parser_class=arguments.OneLineParser)

    check = commands.add_parser("check", help="validate a network file (every error as FILE:LINE: what)")
    _add_network_args(check)
    check.set_defaults(func=cmd_check)

    graph = commands.add_parser("graph", help="draw a network like the paper's figures (SVG, PNG, PDF)")
    _add_network_args(graph)
    graph.add_argument("-o", "--output", required=True, help="OUT.svg or OUT.png (the suffix picks the format)")
    graph.set_defaults(func=cmd_graph)

    launch = commands.add_parser("launch", help="write the roslaunch XML for levels 0..N and run it")
    _add_network_args(launch)
    launch.add_argument("--xml", help="write the launch file here (default: a temporary file)")
    launch.add_argument("--namespace", "--ns", default="", help="run the robot in this namespace")
    launch.add_argument("--write-only", action="store_true", help="write --xml and do not run roslaunch")
    add_groups_arg(launch)
    launch.set_defaults(func=cmd_launch)

    info = commands.add_parser("info", help="describe a module class (and an AFSM's states)")
    info.add_argument("cls", metavar="package.module:Class", help="the module class, e.g. "
                      "subsumption.examples.avoid:Avoid")
    info.add_argument("--dot", metavar="OUT.svg|png", help="draw an AFSM's state diagram")
    info.add_argument("--markdown", action="store_true", help="print the module's topics as a Markdown table (the "
                      "tables of docs/; `subsumption params` prints its parameters)")
    info.set_defaults(func=cmd_info)

    params = commands.add_parser(
        "params", help="list the parameters of a module class or of each module of a network file",
        description="Print every parameter a module class declares (name, type, default, bounds, what it does "
                    "and its unit), or those of each module of a network file with the values the file sets. "
                    "--markdown prints the tables docs/ shows.")
    params.add_argument("target", metavar="MODULE|NETWORK",
                        help="a module class (package.module:Class) or a network file (YAML)")
    params.add_argument("--markdown", action="store_true", help="print Markdown tables instead of plain text")
    params.set_defaults(func=cmd_params)

    watch = commands.add_parser("watch", help="show a running network live: module states, arbiter holders, "
                                "message rates per wire", description="Show a network running on the ROS master "
                                "at ROS_MASTER_URI, refreshed every second: each module's health and AFSM state, "
                                "which line holds each arbiter, messages per second of ROS time on every wire.")
    watch.add_argument("file", nargs="?", default=None,
                       help="network file (YAML); default: the one the running network monitor names")
    watch.add_argument("--level", "-l", type=_level, default=None,
                       help="watch levels 0..N only (default: every level, or the running monitor's)")
    watch.add_argument("--namespace", "--ns", default="/", help="the namespace the network runs in (default /)")
    watch.add_argument("--once", type=float, metavar="SECONDS", default=None,
                       help="listen this many seconds, print the view once and exit (for scripts)")
    watch.add_argument("--period", type=_positive, default=1.0, help="seconds between refreshes (default 1)")
    watch.set_defaults(func=cmd_watch)

    doctor = commands.add_parser(
        "doctor", help="check a robot's drivers before anything drives: missing, mistyped, silent, slow, stale "
                       "topics, wrong frames, a clock that does not move",
        description="Listen to what the chosen robot's network needs from the base (the robot profile's topics, "
                    "profiles/*.yaml) on the master at ROS_MASTER_URI and say, one line each, what is missing, of "
                    "the wrong type, in the wrong frame, silent, slow, stale, or on a clock that does not move. "
                    "Exit status 0 when all is there, 1 when something is not, 2 without a master or profile. "
                    "See docs/robots.md.")
    doctor.add_argument("--profile", default="sim", help="sim, turtlebot2, turtlebot3, generic, or a profile file "
                                                         "(default sim)")
    doctor.add_argument("--robot", choices=("wander", "patrol"), default="wander", help="whose needs (default wander)")
    doctor.add_argument("--level", "-l", type=_level, default=2, help="up to which level (default 2)")
    doctor.add_argument("--listen", type=_positive, default=3.0, help="wall seconds to listen (default 3)")
    doctor.set_defaults(func=cmd_doctor)

    goals = commands.add_parser(
        "goals", help="save rviz's 2D Nav Goal clicks into a patrol goals file",
        description="Append every pose published on /move_base_simple/goal (rviz's 2D Nav Goal, fixed frame map) "
                    "to FILE as [x, y, yaw] under goals:, the patrol robot's goals format; Ctrl-C ends.")
    goals.add_argument("file", help="the goals file to write (rewritten after every goal)")
    goals.add_argument("--topic", default="/move_base_simple/goal", help="where the goals come from")
    goals.set_defaults(func=cmd_goals)

    replay = commands.add_parser(
        "replay", help="play a bag's sensor topics into a network and compare its answers with the recording",
        description="Play the sensor topics of a recorded bag on simulated time into levels 0..N of a network "
                    "and compare, topic by topic, what its modules and arbiters publish with what the bag "
                    "recorded. Exit status 0 when every compared topic matches, 1 when one differs, 2 on an "
                    "error. See docs/ros.md.")
    replay.add_argument("bag", help="a bag recorded while the network ran (rosbag record -a, subsumption run --bag)")
    replay.add_argument("--level", "-l", type=_level, required=True,
                        help="run levels 0..N (the level the recording ran)")
    replay.add_argument("--network", default=None, help="network file (default: the wander robot's)")
    replay.add_argument("--runtime", choices=("ros", "local"), default="ros",
                        help="ros: nodes on a private master, the bag played with rosbag play --clock "
                             "(default); local: in-process, deterministic and fast")
    replay.add_argument("--isolated", action="store_true",
                        help="feed every module and arbiter its own recorded inputs (not only the sensors), so "
                             "a difference shows where it arises instead of everywhere downstream")
    replay.add_argument("--rate", type=_positive, default=1.0,
                        help="ros: rosbag play's rate (simulated s per wall s, default 1)")
    replay.add_argument("--seed", type=arguments.seed, default=None,
                        help="the seed the recording ran with (given to every module with a seed parameter)")
    replay.add_argument("--param", type=_assignment, action="append", metavar="MODULE.NAME=VALUE",
                        help="a module parameter over the network file's (repeatable)")
    replay.add_argument("--time-tolerance", type=_positive, default=0.25,
                        help="seconds between a recorded message and its replayed match (default 0.25)")
    replay.add_argument("--value-tolerance", type=float, default=1e-6,
                        help="relative tolerance on numbers (default 1e-6)")
    replay.add_argument("--min-match", type=_fraction, default=0.95,
                        help="share of a topic's messages that must match for it to pass (default 0.95)")
    replay.set_defaults(func=cmd_replay)

    reconfigure = commands.add_parser(
        "reconfigure", help="show or change a running node's parameters (dynamic_reconfigure)",
        description="Read or set the dynamic_reconfigure parameters of a running module or arbiter node, as "
                    "rqt_reconfigure does (Debian's dynparam cannot find its package).")
    reconfigure.add_argument("node", help="the node, e.g. /wander")
    reconfigure.add_argument("assignments", nargs="*", type=_assignment, metavar="NAME=VALUE",
                             help="values to set (none: print the current ones)")
    reconfigure.add_argument("--timeout", type=_positive, default=5.0,
                             help="seconds to wait for the node's reconfigure service (default 5)")
    reconfigure.set_defaults(func=cmd_reconfigure)

    tf = commands.add_parser("tf", help="print a transform from /tf and /tf_static, as tf_echo does",
                             description="tf_echo (Debian 12 packages neither tf nor tf2_tools): the pose of frame "
                                         "TARGET in frame SOURCE, every --period s of ROS time.")
    tf.add_argument("source", help="the frame the transform is expressed in, e.g. map")
    tf.add_argument("target", help="the frame whose pose is printed, e.g. base_link")
    tf.add_argument("--once", action="store_true", help="print one transform and exit (1: none within --timeout)")
    tf.add_argument("--period", type=_positive, default=1.0, help="seconds of ROS time between prints (default 1)")
    tf.add_argument("--timeout", type=_positive, default=5.0,
                    help="seconds of ROS time to wait for the transform (default 5)")
    tf.set_defaults(func=cmd_tf)

    if plugins and command is None:
        _register_plugins(commands)  # every command, for the usage and --help
    elif plugins and command not in commands.choices:
        _register_plugins(commands, only=command)
        if command not in commands.choices:  # no plugin of that name either: every command, for the usage error
            _register_plugins(commands)
    return parser


def _register_plugins(commands: argparse._SubParsersAction, only: str | None = None) -> None:
    """Subcommands from the ``subsumption.commands`` entry points (`only`: just the one of that name); a broken
    one is reported, not fatal."""
    for entry_point in entry_points(group=ENTRY_POINT_GROUP):
        if only is not None and entry_point.name != only:
            continue
        try:
            register: Callable[[argparse._SubParsersAction], None] = entry_point.load()
            register(commands)
        except Exception as error:  # a plugin must not take the built-in commands down with it
            print(f"subsumption: ignoring command plugin {entry_point.name} ({entry_point.value}): "
                  f"{type(error).__name__}: {error}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``subsumption`` command with `argv` (default: the process's arguments); returns the exit status."""
    import os

    from .ros.launch import with_own_package

    with_own_package(os.environ)  # the package is found without `source setup.bash` (here and in every child)
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((word for word in argv if not word.startswith("-")), None)  # the core's options take no value
    args = build_parser(command=command).parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
