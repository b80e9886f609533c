"""The simulator's camera makes only what someone reads (LocalRuntime): no colour image rendered, no JPEG
encoded and no depth image converted for nobody; and the run does not depend on who watches."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

import subsim
import subsim.local
from subsumption.local import LocalRuntime


def run(topics: dict[str, type], seconds: float = 0.5):
    runtime = LocalRuntime()
    bridge = subsim.local.attach(runtime, subsim.world_path("pingpong"))
    calls = {"rgb": 0, "depth_only": 0}
    render = bridge.sim.render

    def counting(robot, rgb=True):
        calls["rgb" if rgb else "depth_only"] += 1
        return render(robot, rgb)

    bridge.sim.render = counting
    got: dict[str, list] = {topic: [] for topic in topics}
    node = runtime.node("listener")
    for topic, kind in topics.items():
        node.subscribe(topic, kind, lambda msg, topic=topic: got[topic].append(msg))
    runtime.run_for(seconds)
    return bridge, got, calls, runtime


def test_depth_alone_renders_no_colour():
    _, got, calls, runtime = run({"/camera/depth/image_raw": Image, "/camera/depth/camera_info": CameraInfo})
    assert len(got["/camera/depth/image_raw"]) >= 10 and calls["rgb"] == 0 and calls["depth_only"] >= 10
    assert runtime.topics["/camera/rgb/image_raw"].published == 0
    assert runtime.topics["/camera/rgb/image_raw/compressed"].published == 0


def test_colour_without_jpeg_or_depth_readers():
    _, got, calls, runtime = run({"/camera/rgb/image_raw": Image})
    assert len(got["/camera/rgb/image_raw"]) >= 10 and calls["depth_only"] == 0
    assert runtime.topics["/camera/rgb/image_raw/compressed"].published == 0  # no JPEG made for nobody
    assert runtime.topics["/camera/depth/image_raw"].published == 0


def test_the_same_depth_whoever_watches():
    """Depth noise draws from the simulation's generator whether or not colour is rendered: the frames (and so
    every run) are the same with and without a colour reader."""
    topics = {"/camera/depth/image_raw": Image}
    _, alone, _, _ = run(topics)
    _, watched, _, _ = run(topics | {"/camera/rgb/image_raw/compressed": CompressedImage})
    assert watched["/camera/rgb/image_raw/compressed"]
    for a, b in zip(alone["/camera/depth/image_raw"], watched["/camera/depth/image_raw"]):
        assert np.array_equal(np.frombuffer(a.data, np.uint8), np.frombuffer(b.data, np.uint8))
