"""A robot spread over two hosts: network namespaces joined by a virtual ethernet link, as two machines on a LAN.

Host "robot" (10.213.0.1) runs the master and the avoid_demo network's level 0 (feelforce, runaway, turn) with the
suppressor on turn's input; host "upper" (10.213.0.2) runs level 1 (wander, avoid) and a user of the master
(`rosnode list`). Every process has ROS_MASTER_URI pointing at the robot host and ROS_IP set to its own address,
as on real machines. The wiring comes from the network file (subsumption.network.wiring), as `subsumption
launch` would do it; each node is started on its host with `ip netns exec`.

Then the link is cut (`ip link set ... down`): level 1's heading no longer reaches the suppressor, so the lower
line (runaway's heading) takes the output within the time constant and turn keeps commanding the motors from
level 0. The link is restored: level 1 takes the output again. Times are printed (pytest -s), not asserted.

Needs root and `ip netns` (iproute2); skipped, saying why, where either is missing. Only addresses inside the
two namespaces the test made are used, and the namespaces (with their link) are removed when it ends.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from conftest import ROOT, ProcessGroup, output_of, ros_env

from subsumption.network import load
from subsumption.network.wiring import wire

HERE = Path(__file__).resolve()
EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"
ADDRESS = {"robot": "10.213.0.1", "upper": "10.213.0.2"}
PORT = 11311
T = 1.0  # s: the suppressor's time constant here (avoid_demo's is 2 s); wander speaks every 0.3 s
DEADLINE = 40.0


def _ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=15)


@pytest.fixture
def hosts():
    """Two namespaces, {host: namespace}, joined by a veth pair; removed (with the link) at the end."""
    if shutil.which("ip") is None:
        pytest.skip("two-host test: no `ip` command (iproute2)")
    if os.geteuid() != 0:
        pytest.skip("two-host test: network namespaces need root")
    tag = str(os.getpid())
    names = {"robot": f"sub_robot_{tag}", "upper": f"sub_upper_{tag}"}
    links = {"robot": f"svr{tag}"[:15], "upper": f"svu{tag}"[:15]}
    made: list[str] = []
    try:
        for host, name in names.items():
            done = _ip("netns", "add", name)
            if done.returncode != 0:
                pytest.skip(f"two-host test: `ip netns add` failed here: {done.stderr.strip()}")
            made.append(name)
        commands = [
            ("link", "add", links["robot"], "netns", names["robot"], "type", "veth", "peer", "name", links["upper"],
             "netns", names["upper"])]
        for host, name in names.items():
            commands += [("-n", name, "link", "set", "lo", "up"),
                         ("-n", name, "addr", "add", f"{ADDRESS[host]}/30", "dev", links[host]),
                         ("-n", name, "link", "set", links[host], "up")]
        for command in commands:
            done = _ip(*command)
            if done.returncode != 0:
                pytest.skip(f"two-host test: `ip {' '.join(command)}` failed: {done.stderr.strip()}")
        yield names, links
    finally:
        for name in made:
            _ip("netns", "del", name)  # deletes the veth pair with it


def _observe() -> None:
    """On the robot host: follows the suppressor's ~status and turn's commands; cuts and restores the link when
    the test says so (stdin), and prints what it saw as JSON."""
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import Twist

    rospy.init_node("observer", disable_signals=True)
    lock = threading.Lock()
    holders: list[tuple[float, str]] = []
    commands: list[tuple[float, float]] = []

    def on_status(msg: DiagnosticStatus) -> None:
        with lock:
            holders.append((time.monotonic(), {kv.key: kv.value for kv in msg.values}["in_control"]))

    def on_command(msg: Twist) -> None:
        with lock:
            commands.append((time.monotonic(), msg.angular.z))

    rospy.Subscriber("/suppressor_turn_heading/status", DiagnosticStatus, on_status, queue_size=100)
    rospy.Subscriber("/cmd_vel", Twist, on_command, queue_size=100)

    def wait_holder(holder: str, since: float, deadline: float = DEADLINE) -> float | None:
        end = time.monotonic() + deadline
        while time.monotonic() < end:
            with lock:
                hit = next((t for t, h in holders if t >= since and h == holder), None)
            if hit is not None:
                return hit - since
            time.sleep(0.05)
        return None

    result: dict = {"upper_at_start": wait_holder("upper", 0.0, 3 * DEADLINE) is not None}  # nodes starting
    print("ready", flush=True)
    sys.stdin.readline()  # the test has cut the link
    cut = time.monotonic()
    result["lower_after_cut_s"] = wait_holder("lower", cut)
    time.sleep(4.0)  # the link stays down: level 0 alone drives
    with lock:
        during = [z for t, z in commands if cut + T + 0.5 <= t <= time.monotonic()]
        result["upper_during_cut"] = any(h == "upper" for t, h in holders if t >= cut + T + 0.5)
    result["commands_during_cut"] = len(during)
    result["runaway_commands_during_cut"] = sum(1 for z in during if abs(z - 1.5707963) < 1e-3)
    print("cut", flush=True)
    sys.stdin.readline()  # the test has restored the link
    restored = time.monotonic()
    result["upper_after_restore_s"] = wait_holder("upper", restored)
    print(json.dumps(result), flush=True)


@pytest.mark.timeout(240)
def test_robot_over_two_hosts_survives_a_cut_link(hosts, tmp_path):
    names, links = hosts
    master_uri = f"http://{ADDRESS['robot']}:{PORT}/"

    def env(host: str) -> dict[str, str]:
        e = ros_env(master_uri)
        e.pop("ROS_HOSTNAME", None)
        e["ROS_IP"] = ADDRESS[host]
        e["ROS_HOME"] = str(tmp_path / f"ros_home_{host}")
        return e

    def on(host: str, args: list[str], **kwargs) -> subprocess.Popen:
        group.env = env(host)
        return group.start(["ip", "netns", "exec", names[host], *args], **kwargs)

    group = ProcessGroup(env("robot"), tmp_path)
    try:
        on("robot", ["rosmaster", "--core", "-p", str(PORT), "-w", "3"])
        wiring = wire(load(EXAMPLE), 1)
        started = []
        for module in wiring.modules:
            params = dict(module.params, **({"period": 0.3} if module.name == "wander" else {}))
            args = [sys.executable, str(ROOT / "nodes" / "module"), f"__name:={module.name}",
                    f"_class:={module.spec.class_path}"]
            args += [f"{source}:={target}" for source, target in module.remaps.items()]
            args += [f"_{name}:={value}" for name, value in params.items()]
            started.append(on("robot" if module.spec.level == 0 else "upper", args))
        for arbiter in wiring.arbiters:  # on the input of a level-0 module: part of the robot
            started.append(on("robot", [sys.executable, str(ROOT / "nodes" / arbiter.kind), f"__name:={arbiter.name}",
                                        f"upper:={arbiter.upper}", f"lower:={arbiter.lower}",
                                        f"output:={arbiter.output}", f"_time_constant:={T}",
                                        f"_type:={arbiter.line_type}"]))
        observer = on("robot", [sys.executable, str(HERE)], stdin=subprocess.PIPE, stdout=subprocess.PIPE)

        # the master's user on the other host sees the whole robot
        wanted = {"/feelforce", "/runaway", "/turn", "/wander", "/avoid", "/suppressor_turn_heading"}
        end, listed = time.monotonic() + DEADLINE, set()
        while time.monotonic() < end and not wanted <= listed:
            group.env = env("upper")
            listed = set(subprocess.run(["ip", "netns", "exec", names["upper"], "rosnode", "list"], env=group.env,
                                        capture_output=True, text=True, timeout=20).stdout.split())
            time.sleep(0.5)
        assert wanted <= listed, (listed, [output_of(p) for p in started])

        assert observer.stdout.readline().strip() == "ready"
        assert _ip("-n", names["robot"], "link", "set", links["robot"], "down").returncode == 0
        observer.stdin.write("cut\n")
        observer.stdin.flush()
        assert observer.stdout.readline().strip() == "cut"
        assert _ip("-n", names["robot"], "link", "set", links["robot"], "up").returncode == 0
        observer.stdin.write("restored\n")
        observer.stdin.flush()
        out, _ = observer.communicate(timeout=DEADLINE + 20)
        result = json.loads(out.strip().splitlines()[-1])
        print(f"\ntwo hosts: lower line held {result['lower_after_cut_s']:.2f} s after the cut (T {T} s); "
              f"{result['commands_during_cut']} commands from level 0 while cut; level 1 back "
              f"{result['upper_after_restore_s']:.2f} s after the link came up")
        assert result["upper_at_start"]                     # level 1, on the other host, held the output
        assert result["lower_after_cut_s"] is not None      # cut: the lower line took over
        assert not result["upper_during_cut"]
        assert result["runaway_commands_during_cut"] >= 3   # ... and level 0 kept commanding the motors
        assert result["runaway_commands_during_cut"] == result["commands_during_cut"]
        assert result["upper_after_restore_s"] is not None  # restored: level 1 is back in control
        assert all(p.poll() is None for p in started), "a node died"
    finally:
        group.stop_all()


if __name__ == "__main__":
    _observe()
