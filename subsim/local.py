"""Run the simulator inside the in-process LocalRuntime, in lockstep with the modules.

    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.world_path("room"), seed=1)
    runtime.add_module(...)
    runtime.run_for(60.0)
    plot_run(bridge.sim.map, bridge.trajectories(), bridge.collision_points(), "run.png")

The physics is one more timer on the runtime's queue, so a run is reproducible to the bit from its seed.
"""
from __future__ import annotations

from pathlib import Path

from subsumption.local import LocalRuntime

from .bridge import SimBridge
from .sim import Simulation
from .world import World


def attach(runtime: LocalRuntime, world: World | str | Path | Simulation, seed: int | None = 0,
           physics_rate: float = 50.0, sensor_rate: float = 10.0, node_name: str = "simulator",
           record: bool = True, map_to_odom: bool = True, publish_map: bool = True) -> SimBridge:
    """Create the simulation (unless one is given), a node for it and the timer that steps it.
    `map_to_odom` and `publish_map` off: see :class:`~subsim.bridge.SimBridge` (a robot that localizes or
    maps itself)."""
    sim = world if isinstance(world, Simulation) else Simulation(world, seed=seed, record=record)
    node = runtime.node(node_name)
    bridge = SimBridge(node, sim, physics_rate, sensor_rate, start_time=runtime.now(), map_to_odom=map_to_odom,
                       publish_map=publish_map)
    bridge.timer = node.call_every(bridge.physics_dt, bridge.step)  # type: ignore[attr-defined]
    return bridge
