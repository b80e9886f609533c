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

ENTRY_POINT_GROUP = "subsumption.commands"


def _level(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"level must be >= 0, got {value}")
    return value


def _add_network_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="network file (YAML, see docs/networks.md)")
    parser.add_argument("--level", "-l", type=_level, default=None,
                        help="run levels 0..N only (default: every level)")


def cmd_check(args: argparse.Namespace) -> int:
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
    from .network.graph import draw
    loaded = _loaded_wiring(args)
    if loaded is None:
        return 1
    print(draw(loaded[1], args.output))
    return 0


def cmd_launch(args: argparse.Namespace) -> int:
    from .ros.launch import launch, write_launch
    loaded = _loaded_wiring(args)
    if loaded is None:
        return 1
    network = loaded[0]
    if args.write_only:
        if not args.xml:
            print("subsumption launch: --write-only needs --xml OUT.launch", file=sys.stderr)
            return 2
        print(write_launch(network, args.level, args.xml, args.namespace))
        return 0
    running = launch(network, args.level, namespace=args.namespace, xml=args.xml)
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
    from .afsm import AFSM
    from .loading import ClassPathError, load_module_class
    try:
        module_class = load_module_class(args.cls)
    except ClassPathError as error:
        print(f"subsumption info: {error}", file=sys.stderr)
        return 1
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


def build_parser(plugins: bool = True) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="subsumption", description="Brooks' subsumption architecture on ROS 1: "
                                     "check, draw and run network files; describe modules.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

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
    launch.set_defaults(func=cmd_launch)

    info = commands.add_parser("info", help="describe a module class (and an AFSM's states)")
    info.add_argument("cls", metavar="package.module:Class")
    info.add_argument("--dot", metavar="OUT.svg|png", help="draw an AFSM's state diagram")
    info.set_defaults(func=cmd_info)

    if plugins:
        _register_plugins(commands)
    return parser


def _register_plugins(commands: argparse._SubParsersAction) -> None:
    """Subcommands from the ``subsumption.commands`` entry points; a broken one is reported, not fatal."""
    for entry_point in entry_points(group=ENTRY_POINT_GROUP):
        try:
            register: Callable[[argparse._SubParsersAction], None] = entry_point.load()
            register(commands)
        except Exception as error:  # a plugin must not take the built-in commands down with it
            print(f"subsumption: ignoring command plugin {entry_point.name} ({entry_point.value}): "
                  f"{type(error).__name__}: {error}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
