"""The simulator node on a private ROS graph with one listening process, for the benches that time the simulator
under ROS (`bench.sim_speed`, `bench.camera_speed`).

A rosmaster is started on a free port, then the listener (a rospy script given as text, which prints ``ready``
once subscribed and, at the end, one JSON line of what it heard), then the simulator node for a number of
simulated seconds; exactly those processes are stopped afterwards, by process id.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def run_simulator(world: Path, seconds: float, rate: float, listener: str,
                  listener_timeout: float = 60.0) -> tuple[float, float, Any]:
    """(simulated s, wall s, the listener's JSON) of the simulator node running `world` for `seconds` simulated
    seconds at `rate` x real time (0: as fast as it can), heard by the rospy script `listener`."""
    from subsumption.ros.master import start_master, stop_process

    master = start_master()
    env = dict(os.environ, ROS_MASTER_URI=master.uri, ROS_HOSTNAME="127.0.0.1", PYTHONUNBUFFERED="1")
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    env["ROS_HOME"] = tempfile.mkdtemp(prefix="ros_home_")
    processes: list[subprocess.Popen] = []
    try:
        heard = subprocess.Popen([sys.executable, "-c", listener], env=env, stdout=subprocess.PIPE, text=True,
                                 start_new_session=True)
        processes.append(heard)
        assert heard.stdout is not None
        if heard.stdout.readline().strip() != "ready":
            raise RuntimeError("the listener did not start")
        sim = subprocess.Popen([sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={world}",
                                f"_rate:={rate}", f"_duration:={seconds}"], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, start_new_session=True)
        processes.append(sim)
        out, _ = sim.communicate(timeout=600)
        line = next((x for x in out.splitlines() if x.startswith("simulator: simulated")), None)
        if line is None:
            raise RuntimeError(f"the simulator failed:\n{out}")
        words = line.split()  # "simulator: simulated S s in W s wall: ..."
        answer = json.loads(heard.communicate(timeout=listener_timeout)[0].strip().splitlines()[-1])
        return float(words[2]), float(words[5]), answer
    finally:
        for process in processes:  # exactly the processes started here, by pid
            stop_process(process, signal.SIGTERM, timeout=5)
        master.stop()
