"""The RGB-D camera of a robot: its pinhole model, the scene it sees, and frames rendered from the simulation.

:class:`Scene` is built once per simulation from the world: a height and a colour per map cell (walls at the
scene's wall height, boxes such as tables at their own), and every picture (PNG) as a stack of mip levels.
:class:`Camera` renders one robot's view from the simulation's current state (the same state the laser and the
sonars see in that step) with :func:`subsim.render.render`: other robots and agents are upright cylinders,
pictures on agents are cards on their rim, pictures in the scene hang where the world file says.

The camera is level (a TurtleBot's Kinect is): rows are straight lines of constant slope, which is what makes
one 2D ray per column enough. The pinhole is ``fx = fy = (width / 2) / tan(hfov / 2)``, principal point at the
image centre ``((width - 1) / 2, (height - 1) / 2)``; a 640x480 image with 57 degrees across is about 44
degrees high.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from numba import njit

from subsumption.pinhole import Pinhole

from . import render as kernel
from .world import BoxSpec, CameraSpec, PictureSpec, World, box_cells

MAX_PICTURE_PX = 512  # larger pictures are shrunk once: a 0.5 m card never spans more at 0.5 m


@lru_cache(maxsize=64)
def _mip_levels(path: str) -> tuple[np.ndarray, ...]:
    """A picture file as RGB uint8 at full size (at most MAX_PICTURE_PX) and halved LEVELS-1 times."""
    bgr = cv2.imread(path, cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"{path}: cannot read as an image")
    rgb = np.ascontiguousarray(bgr[:, :, ::-1])
    big = max(rgb.shape[:2])
    if big > MAX_PICTURE_PX:
        scale = MAX_PICTURE_PX / big
        rgb = cv2.resize(rgb, (max(1, round(rgb.shape[1] * scale)), max(1, round(rgb.shape[0] * scale))),
                         interpolation=cv2.INTER_AREA)
    levels = [rgb]
    for _ in range(kernel.LEVELS - 1):
        last = levels[-1]
        size = (max(1, last.shape[1] // 2), max(1, last.shape[0] // 2))
        levels.append(cv2.resize(last, size, interpolation=cv2.INTER_AREA) if size != last.shape[1::-1] else last)
    return tuple(levels)


class Scene:
    """What every camera of a simulation shares: cell heights and colours, the pictures, the hung cards."""

    def __init__(self, world: World) -> None:
        grid, spec = world.map, world.scene
        self.ceiling = float(spec.wall_height)
        self.height = np.where(grid.solid > 0, np.float32(spec.wall_height), np.float32(0.0)).astype(np.float32)
        self.colour = np.zeros((*grid.shape, 3), np.uint8)
        self.colour[grid.solid > 0] = spec.wall_colour
        for box in spec.boxes:
            self._add_box(world, box)
        self.floor_rgb = np.array(spec.floor_colour, np.float64)
        self.ceiling_rgb = np.array(spec.ceiling_colour, np.float64)
        self.max_dist = math.hypot(grid.width_m, grid.height_m)
        files = sorted({p.file for p in spec.pictures} |
                       {a.picture.file for a in world.agents if a.picture is not None})
        self.texture_index = {path: i for i, path in enumerate(files)}
        self.aspect = {}  # width / height of each picture
        self.atlas, self.tex_size = self._atlas(files)
        self.static_cards = np.array([self.card(p, *p.at, p.yaw) for p in spec.pictures], np.float64).reshape(-1, 6)
        self.static_tex = np.array([self.texture_index[p.file] for p in spec.pictures], np.int64)

    def _add_box(self, world: World, box: BoxSpec) -> None:
        cells = box_cells(world.map, box.rect)
        if cells is not None:
            self.height[cells] = box.height
            self.colour[cells] = box.colour

    def _atlas(self, files: list[str]) -> tuple[np.ndarray, np.ndarray]:
        stacks = [_mip_levels(path) for path in files]
        if not stacks:
            return np.zeros((1, kernel.LEVELS, 1, 1, 3), np.uint8), np.ones((1, kernel.LEVELS, 2), np.int64)
        for path, stack in zip(files, stacks):
            self.aspect[path] = stack[0].shape[1] / stack[0].shape[0]
        h = max(s[0].shape[0] for s in stacks)
        w = max(s[0].shape[1] for s in stacks)
        atlas = np.zeros((len(stacks), kernel.LEVELS, h, w, 3), np.uint8)
        sizes = np.zeros((len(stacks), kernel.LEVELS, 2), np.int64)
        for i, stack in enumerate(stacks):
            for level, pixels in enumerate(stack):
                atlas[i, level, :pixels.shape[0], :pixels.shape[1]] = pixels
                sizes[i, level] = pixels.shape[:2]
        return atlas, sizes

    def card(self, picture: PictureSpec, x: float, y: float, facing: float) -> tuple[float, ...]:
        """(left x, y, right x, y, bottom, top) of an upright picture centred at (x, y) facing `facing`."""
        half = picture.height * self.aspect[picture.file] / 2.0
        rx, ry = -math.sin(facing), math.cos(facing)  # the viewer's right, looking at the front
        bottom = picture.centre - picture.height / 2.0
        return (x - rx * half, y - ry * half, x + rx * half, y + ry * half, bottom, bottom + picture.height)


@dataclass
class CameraFrame:
    """One rendered frame: depth (rows, width) float32 metres (NaN: no reading) for image rows [row0, row0 +
    rows), and the RGB (rows, width, 3) uint8 when colour was rendered."""

    time: float
    depth: np.ndarray
    rgb: np.ndarray | None
    row0: int = 0


class Camera:
    """One robot's camera: renders what it sees in a simulation now."""

    def __init__(self, spec: CameraSpec, scene: Scene) -> None:
        self.spec, self.scene = spec, scene
        self.pinhole = Pinhole.from_fov(spec.width, spec.height, math.radians(spec.hfov_deg))
        self.depth_only = spec.mode == "depth_band"
        self.rows = self.pinhole.band(spec.band_rows) if self.depth_only else (0, spec.height)
        # column-major drawing buffers, kept: fresh ones would cost their page faults every frame
        rows = self.rows[1] - self.rows[0]
        self._depth_scratch = np.empty((spec.width, rows), np.float32)
        self._rgb_scratch = np.empty((spec.width, rows, 3), np.uint8)

    def pose(self, x: float, y: float, theta: float) -> tuple[float, float, float]:
        """World (x, y, yaw) of the camera on a robot at pose (x, y, theta)."""
        c, s = math.cos(theta), math.sin(theta)
        return x + c * self.spec.x - s * self.spec.y, y + s * self.spec.x + c * self.spec.y, theta + self.spec.yaw

    def render(self, sim, robot: str, rng: np.random.Generator | None = None, rgb: bool = True) -> CameraFrame:
        """The frame of `robot`'s camera in simulation `sim` as it is now; depth noise (if the spec has any)
        from `rng`. `rgb` False: depth only (nobody reads the colour image), the shading left out."""
        body = sim.robots[robot]
        cam_x, cam_y, cam_yaw = self.pose(body.x, body.y, body.theta)
        circles, circle_rgb, cards, card_tex = self._bodies(sim, robot)
        row0, row1 = self.rows
        depth, rgb = self._depth_scratch, None if self.depth_only or not rgb else self._rgb_scratch
        p, scene, m = self.pinhole, self.scene, sim.map
        kernel.render(m.solid, m.wall_distance, scene.height, scene.colour, m.origin[0], m.origin[1], m.resolution,
                      cam_x, cam_y, cam_yaw, self.spec.z, p.fx, p.fy, p.cx, p.cy, p.width, row0, row1,
                      scene.max_dist, scene.ceiling, scene.floor_rgb, scene.ceiling_rgb, self.spec.min_range,
                      self.spec.max_range, circles, circle_rgb, cards, card_tex, scene.atlas, scene.tex_size,
                      rgb is not None, rgb if rgb is not None else _NO_RGB, depth)
        depth = cv2.transpose(depth)
        if rgb is not None:
            rgb = cv2.transpose(rgb)
        if self.spec.noise > 0 and rng is not None:
            # structured-light noise: std grows with the square of the depth
            depth += (rng.standard_normal(depth.shape, dtype=np.float32) * np.float32(self.spec.noise)) * depth * depth
        return CameraFrame(sim.time, depth, rgb, row0)

    def _bodies(self, sim, robot: str):
        rows, colours, cards, tex = [], [], [], []
        for name, other in sim.robots.items():
            if name != robot:
                rows.append((other.x, other.y, other.radius, other.spec.body_height))
                colours.append(other.spec.colour)
        for agent in sim.agents.values():
            rows.append((agent.x, agent.y, agent.radius, agent.spec.height))
            colours.append(agent.spec.colour)
            picture = agent.spec.picture
            if picture is not None:
                facing = agent.theta + picture.yaw
                reach = agent.radius + 0.01
                cards.append(self.scene.card(picture, agent.x + reach * math.cos(facing),
                                             agent.y + reach * math.sin(facing), facing))
                tex.append(self.scene.texture_index[picture.file])
        scene = self.scene
        all_cards = np.concatenate([scene.static_cards, np.array(cards, np.float64).reshape(-1, 6)])
        all_tex = np.concatenate([scene.static_tex, np.array(tex, np.int64)])
        return (np.array(rows, np.float64).reshape(-1, 4), np.array(colours, np.float64).reshape(-1, 3),
                all_cards, all_tex)


_NO_RGB = np.zeros((1, 1, 3), np.uint8)


@njit(cache=True)
def _millimetres(depth_m: np.ndarray) -> np.ndarray:  # pragma: no cover - numba
    out = np.zeros(depth_m.shape, np.uint16)
    for i in range(depth_m.shape[0]):
        for j in range(depth_m.shape[1]):
            z = depth_m[i, j]
            if z == z and z > 0.0:  # NaN (no reading) stays 0, as OpenNI marks it
                out[i, j] = np.uint16(min(z * 1000.0 + 0.5, 65535.0))
    return out


def depth_pixels(depth_m: np.ndarray, encoding: str) -> np.ndarray:
    """A frame's depth (float32 metres, NaN: no reading) as the pixels of a depth image in `encoding`: ``32FC1``
    as it is, ``16UC1`` rounded to millimetres with 0 for no reading (OpenNI's camera/depth/image_raw: half the
    bytes of 32FC1 for every subscriber; numba, about 1 ms a 640x480 frame where numpy's masks take 2)."""
    if encoding == "32FC1":
        return depth_m
    if encoding == "16UC1":
        return _millimetres(depth_m)
    raise ValueError(f"depth encoding must be 16UC1 or 32FC1, got {encoding!r}")


__all__ = ["Pinhole", "Scene", "Camera", "CameraFrame", "depth_pixels"]
