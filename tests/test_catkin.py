"""The package in a catkin workspace: Debian's catkin builds and installs it, and a node runs from the install
space in a shell that has neither the project's environment on PATH nor the checkout on ROS_PACKAGE_PATH."""
from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import ROOT

NODES = {p.name for p in (ROOT / "nodes").iterdir()}  # module, suppressor, ..., and nothing from bench/


def bare_shell(home: Path, **extra: str) -> dict[str, str]:
    """What a fresh login shell has: system PATH only (no venv), no ROS variables."""
    return {"PATH": "/usr/bin:/bin", "HOME": str(home), "LANG": "C.UTF-8", **extra}


@pytest.fixture(scope="module")
def install_space(tmp_path_factory) -> Path:
    workspace = tmp_path_factory.mktemp("catkin_ws")
    (workspace / "src").mkdir()
    (workspace / "src" / "subsumption").symlink_to(ROOT)
    build = subprocess.run(["catkin_make", "install", f"-DSUBSUMPTION_PYTHON={sys.executable}"], cwd=workspace,
                           env=bare_shell(workspace), capture_output=True, text=True, timeout=240)
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    assert "lacks packages" not in build.stderr  # the configure-time check found every pinned package
    return workspace / "install"


def test_install_rules(install_space):
    assert {p.name for p in (install_space / "lib" / "subsumption").iterdir()} == NODES  # no bench scripts
    for node in NODES:
        assert (install_space / "lib" / "subsumption" / node).read_text().startswith(f"#!{sys.executable}\n")
    share = install_space / "share" / "subsumption"
    assert (share / "package.xml").exists() and (share / "launch" / "wander_sim.launch").exists()
    assert (share / "subsim" / "maps" / "corridors_world.yaml").exists() and (share / "subsim" / "maps" /
                                                                           "corridors.pgm").exists()
    assert (share / "robots" / "wander" / "wander.yaml").exists()
    packages = install_space / "lib" / "python3" / "dist-packages"
    assert {"subsumption", "subsim", "robots", "experiments"} <= {p.name for p in packages.iterdir()}
    assert (packages / "subsim" / "maps" / "room.pgm").exists()  # package data with the Python packages


@pytest.mark.timeout(90)
def test_node_runs_from_the_install_space(install_space, ros_master, tmp_path):
    """rosrun finds the installed node; it imports numpy (the level-2 Look module) and this package from the
    install space, and writes its parameters' defaults to the parameter server."""
    setup = install_space / "setup.bash"
    env = bare_shell(tmp_path, ROS_MASTER_URI=ros_master["ROS_MASTER_URI"], ROS_HOSTNAME="127.0.0.1",
                     ROS_HOME=str(tmp_path / "ros_home"))
    log = tmp_path / "look.log"
    node = subprocess.Popen(["bash", "-c", f"source {setup} && exec rosrun subsumption module __name:=look "
                             f"_class:=robots.wander.level2:Look"], env=env, stdout=log.open("w"),
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 30  # wall clock: a process starting
        width = None
        while time.monotonic() < deadline and node.poll() is None:
            got = subprocess.run(["bash", "-c", f"source {setup} && rosparam get /look/width"], env=env,
                                 capture_output=True, text=True)
            if got.returncode == 0:
                width = got.stdout.strip()
                break
            time.sleep(0.5)
        assert width == "0.6", log.read_text()
        version = subprocess.run(["bash", "-c", f"source {setup} && subsumption --version"], env=env,
                                 capture_output=True, text=True)
        manifest = (Path(__file__).resolve().parent.parent / "package.xml").read_text()
        assert version.stdout.strip() == "subsumption " + re.search(r"<version>([^<]+)</version>", manifest).group(1), \
            version.stderr
    finally:
        node.terminate()
        node.wait(10)
    assert f"subsumption from {install_space}/lib/python3/dist-packages/subsumption" in log.read_text()
