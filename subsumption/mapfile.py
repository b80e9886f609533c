"""Occupancy maps in ROS map_server format (a YAML file naming a PGM/PNG image), so any map a ROS user has works.

This is the one reader and writer of map files in the project: the simulator loads its worlds with it, the
map builder saves what it built with it, and the localizer and planner load that back. It knows nothing of
what uses a map.

The image is read exactly as map_server reads it in ``trinary`` mode: a pixel's occupancy probability is
``(255 - v) / 255`` (or ``v / 255`` with ``negate: 1``); above ``occupied_thresh`` it is occupied, below
``free_thresh`` free, otherwise unknown. Files are written as map_saver writes them (PGM: 0 occupied, 254
free, 205 unknown).

Grids are stored with row 0 at the *bottom* (lowest y), the layout of nav_msgs/OccupancyGrid, so cell
``(row, col)`` covers ``x = origin_x + col * resolution`` and ``y = origin_y + row * resolution``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from . import yamlfile
from .errors import InputFileError

FREE, OCCUPIED, UNKNOWN = 0, 100, -1
MAX_CELLS = 64_000_000  # 8000 x 8000: 400 m square at 5 cm; larger images are refused before decoding


MapError = InputFileError  # the one bad-input-file error, under this module's name


@dataclass
class OccupancyMap:
    """An occupancy grid with its place in the world: what a map_server file and a nav_msgs/OccupancyGrid hold."""

    occupancy: np.ndarray  # int8 (rows, cols): 0 free, 100 occupied, -1 unknown; row 0 = lowest y
    resolution: float  # metres per cell
    origin: tuple[float, float]  # world coordinates of the lower-left corner of cell (0, 0)
    source: str = ""  # where it came from, for error messages and the plot title

    def __post_init__(self) -> None:
        self.occupancy = np.ascontiguousarray(self.occupancy, dtype=np.int8)

    @property
    def shape(self) -> tuple[int, int]:
        """Rows and columns of the grid."""
        return self.occupancy.shape  # type: ignore[return-value]

    @property
    def width_m(self) -> float:
        """The map's width in metres."""
        return self.shape[1] * self.resolution

    @property
    def height_m(self) -> float:
        """The map's height in metres."""
        return self.shape[0] * self.resolution

    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) in metres, as matplotlib's imshow wants it."""
        x0, y0 = self.origin
        return x0, x0 + self.width_m, y0, y0 + self.height_m

    def grey_levels(self) -> np.ndarray:
        """The grid as a picture's grey levels (0-1, row 0 at the bottom), as map_server's image draws it: free
        white, occupied black, unknown grey."""
        image = np.full(self.shape, 0.8)
        image[self.occupancy == FREE] = 1.0
        image[self.occupancy == OCCUPIED] = 0.0
        return image

    def draw(self, ax, image: np.ndarray | None = None, **style: Any) -> None:
        """Show the grid on a matplotlib axis over its extent in metres, in :meth:`grey_levels` or as `image` (an
        array over the same cells, e.g. RGB); `style` goes to ``imshow`` (e.g. ``alpha``)."""
        if image is None:
            ax.imshow(self.grey_levels(), cmap="gray", vmin=0, vmax=1, origin="lower", extent=self.extent(),
                      interpolation="nearest", **style)
        else:
            ax.imshow(image, origin="lower", extent=self.extent(), interpolation="nearest", **style)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell containing world point (x, y); may lie outside the grid."""
        return (int(np.floor((y - self.origin[1]) / self.resolution)),
                int(np.floor((x - self.origin[0]) / self.resolution)))

    def centre_of(self, row: int, col: int) -> tuple[float, float]:
        """World (x, y) of the centre of cell (row, col)."""
        return (self.origin[0] + (col + 0.5) * self.resolution, self.origin[1] + (row + 0.5) * self.resolution)


def _require(meta: dict[str, Any], key: str, path: Path, kind: type | tuple[type, ...]) -> Any:
    if key not in meta:
        raise MapError.at(path, key, "missing")
    value = meta[key]
    if isinstance(value, bool) or not isinstance(value, kind):
        raise MapError.at(path, key, f"expected {getattr(kind, '__name__', 'a number')}, got {yamlfile.brief(value)}")
    if isinstance(value, float) and not np.isfinite(value):
        raise MapError.at(path, key, f"expected a finite number, got {value!r}")
    return value


def _number(meta: dict[str, Any], key: str, path: Path, default: float | None = None) -> float:
    if key not in meta and default is not None:
        return default
    return float(_require(meta, key, path, (int, float)))


def read_map_file(yaml_path: str | Path) -> OccupancyMap:
    """Read a map_server YAML file and its image. Raises MapError naming the file and the faulty field."""
    path = Path(yaml_path)
    try:
        meta = yamlfile.load(path, "map file")
    except yamlfile.YamlFileError as exc:
        raise MapError.at(path, "(file)", f"line {exc.line}: {exc.problem}" if exc.line else exc.problem) from None
    if not isinstance(meta, dict):
        raise MapError.at(path, "(file)", "expected a mapping of map_server fields")

    image_name = _require(meta, "image", path, str)
    resolution = _number(meta, "resolution", path)
    if not resolution > 0:
        raise MapError.at(path, "resolution", f"must be > 0, got {resolution}")
    origin = meta.get("origin")
    if (not isinstance(origin, (list, tuple)) or len(origin) != 3
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in origin)):
        raise MapError.at(path, "origin", f"expected [x, y, yaw] (finite numbers), got {yamlfile.brief(origin)}")
    if origin[2] != 0:
        raise MapError.at(path, "origin", f"a rotated map (yaw {origin[2]}) is not supported; use yaw 0")
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapError.at(path, "negate", f"expected 0 or 1, got {yamlfile.brief(negate)}")
    occupied_thresh = _number(meta, "occupied_thresh", path, 0.65)
    free_thresh = _number(meta, "free_thresh", path, 0.196)
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise MapError.at(path, "free_thresh" if not 0 <= free_thresh <= 1 else "occupied_thresh",
                          f"need 0 <= free_thresh ({free_thresh}) <= occupied_thresh ({occupied_thresh}) <= 1")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapError.at(path, "mode", f"expected trinary, scale or raw, got {yamlfile.brief(mode)}")

    image_path = (path.parent / image_name) if not Path(image_name).is_absolute() else Path(image_name)
    pixels = _read_image(path, image_path)
    occupancy = occupancy_from_pixels(pixels, bool(negate), occupied_thresh, free_thresh)
    if not (occupancy == FREE).any():
        raise MapError.at(path, "image", f"{str(image_path)!r} has no free cell (every pixel reads as occupied or "
                                      f"unknown with negate {negate}, free_thresh {free_thresh})")
    return OccupancyMap(occupancy, resolution, (float(origin[0]), float(origin[1])), str(path))


def _read_image(path: Path, image_path: Path) -> np.ndarray:
    """The map's image, its size checked from the header before anything is decoded (a PGM header may claim
    any size), every failure a MapError on field 'image'."""
    from PIL import Image

    try:
        with Image.open(image_path) as header:
            width, height = header.size
    except FileNotFoundError:
        raise MapError.at(path, "image", f"no such file {str(image_path)!r}") from None
    except Exception as exc:  # PIL raises many kinds (SyntaxError for a bad PGM header, DecompressionBombError)
        raise MapError.at(path, "image", f"cannot read image {str(image_path)!r}: {type(exc).__name__}: "
                                      f"{' '.join(str(exc).split())[:120]}") from None
    if width * height > MAX_CELLS or not (width and height):
        raise MapError.at(path, "image", f"{str(image_path)!r} is {width} x {height} pixels; a map may have "
                                      f"1 to {MAX_CELLS} cells")
    try:
        pixels = cv2.imread(str(image_path), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise MapError.at(path, "image", f"cannot read image {str(image_path)!r}: {str(exc).strip().splitlines()[-1]}"
                       ) from None
    if pixels is None or pixels.size == 0:
        raise MapError.at(path, "image", f"cannot read image {str(image_path)!r}")
    return pixels


def occupancy_from_pixels(pixels: np.ndarray, negate: bool, occupied_thresh: float,
                          free_thresh: float) -> np.ndarray:
    """map_server's trinary interpretation of an image (top row first) as a bottom-row-first int8 grid."""
    if pixels.ndim == 3:  # colour: map_server averages the colour channels and ignores alpha
        pixels = pixels[..., :3].mean(axis=2)
    value = pixels.astype(np.float64)
    if pixels.dtype == np.uint16:
        value = value / 257.0
    p = value / 255.0 if negate else (255.0 - value) / 255.0
    grid = np.full(p.shape, UNKNOWN, dtype=np.int8)
    grid[p > occupied_thresh] = OCCUPIED
    grid[p < free_thresh] = FREE
    return np.ascontiguousarray(np.flipud(grid))


def save_map(grid: OccupancyMap | np.ndarray, yaml_path: str | Path, resolution: float = 0.05,
             origin: tuple[float, float] = (0.0, 0.0)) -> Path:
    """Write a grid as map_saver does (PGM: 0 occupied, 254 free, 205 unknown) plus its YAML."""
    if isinstance(grid, OccupancyMap):
        occupancy, resolution, origin = grid.occupancy, grid.resolution, grid.origin
    else:
        occupancy = np.asarray(grid)
    path = Path(yaml_path)
    image = np.full(occupancy.shape, 205, dtype=np.uint8)
    image[occupancy == FREE] = 254
    image[occupancy == OCCUPIED] = 0
    pgm = path.with_suffix(".pgm")
    cv2.imwrite(str(pgm), np.flipud(image))
    meta = {"image": pgm.name, "resolution": float(resolution), "origin": [float(origin[0]), float(origin[1]), 0.0],
            "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
    import yaml

    path.write_text(yaml.safe_dump(meta, sort_keys=False))
    return path


__all__ = ["FREE", "OCCUPIED", "UNKNOWN", "MapError", "OccupancyMap", "read_map_file", "occupancy_from_pixels",
           "save_map"]
