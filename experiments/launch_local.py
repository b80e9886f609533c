"""The one way a run starts in-process: a world in the simulator and networks built on one LocalRuntime.

Every in-process run (``subsumption run``, ``map``, ``navigate``, the localization runs, the mapping recordings)
is the same recipe: a :class:`~subsumption.LocalRuntime`, the simulator attached to it, what must listen from the
first message (a map server, a recorder), the networks built from their files (:func:`build_local`, as the ROS
runtime launches the same files), what watches the built modules, then the clock run until a time or a condition,
timed. Callers differ only in their networks, their observers and their stop condition; the order of building is
the same for all, so a run is reproducible to the bit for a seed.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import subsim.local
from subsim.bridge import SimBridge
from subsumption import LocalRuntime
from subsumption.module import Module
from subsumption.network.local import LocalNetwork, build_local
from subsumption.network.spec import Network

Networks = Sequence[tuple[Network, int | None]]  # (network, its highest level; None: every level)


@dataclass
class LocalRun:
    """What an in-process run made and what it cost."""

    runtime: LocalRuntime
    bridge: SimBridge
    built: list[LocalNetwork] = field(default_factory=list)  # one per network, in the order given
    prepared: Any = None  # what `setup` returned
    observed: Any = None  # what `observe` returned
    wall: float = 0.0  # s of wall time the clock ran (wall clock on purpose: what the run cost)
    cpu: float = 0.0  # s of this process's CPU time meanwhile

    def module(self, name: str) -> Module:
        """The built module called `name` (in the first network that has one); KeyError names what there is."""
        for built in self.built:
            if name in built.modules:
                return built.modules[name]
        raise KeyError(f"no module {name!r} in the run; it has {sorted(m for b in self.built for m in b.modules)}")


def launch_local(world: Path, networks: Networks, until: float, seed: int = 0,
                 simulator: dict[str, Any] | None = None,
                 setup: Callable[[LocalRuntime], Any] | None = None,
                 observe: Callable[[LocalRuntime, list[LocalNetwork]], Any] | None = None,
                 stop: Callable[[LocalRun], bool] | None = None, step: float = 1.0) -> LocalRun:
    """Run `networks` in the simulator's `world` until simulated time `until`, or sooner when `stop` says so.

    In order: the simulator (seeded; `simulator` are :func:`subsim.local.attach`'s options such as
    ``map_to_odom`` and ``publish_map``), ``setup(runtime)`` (what must hear every message from the first: a map
    server, a passive recorder), each network through :func:`build_local`, ``observe(runtime, built)`` (what needs
    the built modules or their wiring). Without `stop` the clock runs to `until` at once; with it, `stop(run)` is
    asked before every `step` simulated seconds. Wall and CPU time cover the clock's running only."""
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, world, seed=seed, record=False, **(simulator or {}))
    run = LocalRun(runtime, bridge)
    run.prepared = setup(runtime) if setup is not None else None
    run.built = [build_local(network, runtime, level) for network, level in networks]
    run.observed = observe(runtime, run.built) if observe is not None else None
    started, cpu = time.monotonic(), time.process_time()  # wall clock on purpose: the run's cost
    if stop is None:
        runtime.run_until(until)
    else:
        while runtime.now() < until and not stop(run):
            runtime.run_until(min(until, runtime.now() + step))
    run.wall, run.cpu = time.monotonic() - started, time.process_time() - cpu
    return run


__all__ = ["LocalRun", "Networks", "launch_local"]
