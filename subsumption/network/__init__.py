"""Network files: a robot's levels, modules and arbiters in YAML, checked, wired, drawn and run.

- :func:`load` reads a file into a :class:`Network` (plain dataclasses with line numbers);
- :func:`check_file` / :func:`check` report every problem as ``FILE:LINE: what``;
- :func:`wire` computes, for "up to level N", every module's remaps and parameters and every arbiter's topics
  and time constant in seconds: the one wiring the graph, the in-process builder and roslaunch all follow;
- :func:`build_local` runs a network in a :class:`~subsumption.local.LocalRuntime`;
- :func:`subsumption.network.graph.draw` draws it like the paper's figures;
- :mod:`subsumption.ros.launch` writes and runs the equivalent roslaunch file.

The format is described in docs/networks.md.
"""
from .check import CheckResult, check, check_file
from .loader import load, parse
from .local import LocalNetwork, build_local
from .spec import (ArbiterSpec, ExternalSpec, InputSpec, LevelSpec, ModuleSpec, Network, NetworkError,
                   NetworkInvalid, OutputSpec, Where)
from .wiring import ArbiterWiring, End, ModuleWiring, Wire, Wiring, wire

__all__ = [
    "ArbiterSpec", "ArbiterWiring", "CheckResult", "End", "ExternalSpec", "InputSpec", "LevelSpec", "LocalNetwork",
    "ModuleSpec", "ModuleWiring", "Network", "NetworkError", "NetworkInvalid", "OutputSpec", "Where", "Wire",
    "Wiring", "build_local", "check", "check_file", "load", "parse", "wire",
]
