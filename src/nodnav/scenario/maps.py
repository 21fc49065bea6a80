"""Occupancy-grid maps in the ROS map_server format: reading them, their walls, writing them.

A map is a YAML file naming an image (PGM or PNG, read with pillow) and saying how to read it:
``resolution`` (m per cell), ``origin`` ``[x, y, yaw]`` (the lower-left cell's corner; yaw must be
0), ``negate``, ``occupied_thresh``, ``free_thresh`` and ``mode`` (``trinary``, the default,
``scale`` or ``raw``). As map_server does, a pixel's shade ``s`` in [0, 1] (the mean of its colour
channels) gives the occupancy ``p = 1 - s`` (``p = s`` with ``negate``); a cell is free when
``p < free_thresh``, occupied when ``p > occupied_thresh`` and unknown otherwise. In ``scale``
mode a pixel that is not opaque is unknown; in ``raw`` mode the pixel's value ``v = round(255 s)``
is the occupancy in percent (values above 100 are unknown) and the cell is free when
``v < 100 free_thresh``. **Unknown cells are walls**, like occupied ones: nodnav knows only free
space and the rest.

Walls are axis-aligned boxes covering every non-free cell (:func:`wall_boxes`: a greedy cover,
O(cells)), so that every geometry kernel keeps its fast path and its interface. Free pockets too
small for any robot (:data:`MIN_FREE_AREA`) are filled first: SLAM maps are full of them and
each would cost boxes. Time and memory are bounded by refusing a map of more than
:data:`MAX_MAP_CELLS` cells or whose walls need more than :data:`MAX_MAP_WALLS` boxes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from nodnav.compiled import compiled
from nodnav.errors import shown, shown_path
from nodnav.scenario.fields import ScenarioError, fail, mapping, number

MAX_MAP_CELLS = 4_000_000
"""Most cells of a map image (e.g. 2000 x 2000). Loading and finding passages hold about 60 bytes
per cell at once (the grid, its distance transform, medial axis and labels: about 240 MB at the
bound) and take time linear in the cells (docs/maps.md: 1.1 million cells in 1.8 s, 3.2 million
in 5.9 s). The image's size is read from its header and checked before its pixels are decoded."""

MAX_MAP_WALLS = 20_000
"""Most wall boxes a map's grid may need. The world's clearance queries, the planners' visibility,
the controller's rows and the contact counts look only at the walls near each query through a
bucket index of them (:class:`nodnav.wall_grid.WallGrid`; docs/maps.md, "How fast on maps"), but
the visibility graph has vertices at the boxes' corners and the PRM planner's compiled joint
checks still loop over every wall."""

MIN_FREE_AREA = 0.05
"""Free pockets of less than this area (m^2) are walls: no robot fits (a disc of radius 0.13 m
already needs it); SLAM maps hold hundreds of such specks."""

MODES = ("trinary", "scale", "raw")
_MAP_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A map's free cells and where they are: ``free[i, j]`` is the cell whose lower-left corner
    is ``origin + (j, i) resolution`` (row 0 at the bottom, unlike the image's)."""

    path: str
    """The map's YAML file."""
    free: np.ndarray
    """Free cells ``(rows, columns)`` bool, row 0 the lowest (read-only)."""
    resolution: float
    """Side of a cell (m)."""
    origin: tuple[float, float]
    """Lower-left corner of the lower-left cell (m)."""

    @property
    def shape(self) -> tuple[int, int]:
        """Rows and columns."""
        return self.free.shape

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """The map's extent ``(x_min, y_min, x_max, y_max)`` (m)."""
        rows, cols = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution

    def cell_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of the cell holding each point (clipped to the grid)."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        j = np.floor((p[:, 0] - self.origin[0]) / self.resolution).astype(int)
        i = np.floor((p[:, 1] - self.origin[1]) / self.resolution).astype(int)
        return np.clip(i, 0, self.shape[0] - 1), np.clip(j, 0, self.shape[1] - 1)

    def centre_of(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Centres ``(..., 2)`` of the cells ``(i, j)`` (m)."""
        return np.stack([self.origin[0] + (np.asarray(j) + 0.5) * self.resolution,
                         self.origin[1] + (np.asarray(i) + 0.5) * self.resolution], axis=-1)

    def cropped(self, bounds: tuple[float, float, float, float]) -> "OccupancyMap":
        """The cells that meet the box ``bounds``: a scenario on part of a big map keeps only the
        walls it can reach (the controller and the compiled kernels loop over every wall)."""
        x0, y0 = self.origin
        r = self.resolution
        rows, cols = self.shape
        j0, j1 = max(int(math.floor((bounds[0] - x0) / r)), 0), min(int(math.ceil((bounds[2] - x0) / r)), cols)
        i0, i1 = max(int(math.floor((bounds[1] - y0) / r)), 0), min(int(math.ceil((bounds[3] - y0) / r)), rows)
        if (i0, i1, j0, j1) == (0, rows, 0, cols):
            return self
        free = np.ascontiguousarray(self.free[i0:max(i1, i0 + 1), j0:max(j1, j0 + 1)])
        free.setflags(write=False)
        return OccupancyMap(path=self.path, free=free, resolution=r, origin=(x0 + j0 * r, y0 + i0 * r))

    @cached_property
    def walls(self) -> tuple[tuple[float, float, float, float], ...]:
        """The wall boxes ``(x_min, y_min, x_max, y_max)`` covering every non-free cell (m)."""
        cells = wall_boxes(~self.free)
        x0, y0 = self.origin
        r = self.resolution
        return tuple((x0 + c0 * r, y0 + r0 * r, x0 + c1 * r, y0 + r1 * r) for c0, r0, c1, r1 in cells.tolist())


def map_beside(raw: Any, folder: Path) -> Any:
    """A scenario's parsed YAML with a relative ``world.map`` made relative to ``folder`` (the
    scenario file's): a map path in a scenario file is relative to that file, not to the
    working directory."""
    if isinstance(raw, dict) and isinstance(raw.get("world"), dict) and isinstance(raw["world"].get("map"), str):
        where = Path(raw["world"]["map"]).expanduser()
        if not where.is_absolute():
            raw = {**raw, "world": {**raw["world"], "map": str((folder / where).resolve())}}
    return raw


def _image_shade(path: Path, key: str, mode: str) -> tuple[np.ndarray, np.ndarray | None]:
    """The image's shade in [0, 1] (mean of its colour channels), rows top first, and its alpha
    (None without one). Its size is checked before its pixels are decoded."""
    from PIL import Image, UnidentifiedImageError

    label = shown_path(path)
    try:
        img = Image.open(path)
    except FileNotFoundError:
        raise fail(key, f"the map's image {label} does not exist; check 'image' in the map's YAML") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise fail(key, f"cannot read the map's image {label} ({type(exc).__name__}); give a PGM or PNG "
                        f"image") from None
    with img:
        cols, rows = img.size
        if rows * cols > MAX_MAP_CELLS:
            raise fail(key, f"the map's image {label} has {cols} x {rows} = {rows * cols} cells, more than "
                            f"{MAX_MAP_CELLS}; crop it or save it at a coarser resolution")
        if rows == 0 or cols == 0:
            raise fail(key, f"the map's image {label} is empty")
        try:
            img.load()
            if img.mode.startswith("I"):  # 16-bit grey (a PGM of maxval 65535)
                arr = np.asarray(img, dtype=float)
                return np.clip(arr / 65535.0, 0.0, 1.0), None
            has_alpha = "A" in img.getbands() or (img.mode == "P" and "transparency" in img.info)
            rgba = np.asarray(img.convert("RGBA"), dtype=float) / 255.0
        except (OSError, ValueError, SyntaxError) as exc:
            raise fail(key, f"cannot read the map's image {label} ({type(exc).__name__}: {exc}); "
                            f"give a PGM or PNG image") from None
    channels = rgba[..., :3] if img.mode not in ("L", "LA", "I", "F", "1") else rgba[..., :1]
    return channels.mean(axis=-1), (rgba[..., 3] if has_alpha else None)


def _flag(value: Any, where: str) -> bool:
    if isinstance(value, bool) or value in (0, 1):
        return bool(value)
    raise fail(where, f"expected 0 or 1, got {shown(value)}")


def free_cells(shade: np.ndarray, alpha: np.ndarray | None, negate: bool, occupied: float, free: float,
               mode: str) -> np.ndarray:
    """map_server's reading of each pixel, reduced to free (True) or not (occupied or unknown)."""
    if mode == "raw":
        value = np.rint(shade * 255.0)
        return value < 100.0 * free  # values above 100 are unknown, never below 100 free_thresh <= 100
    p = shade if negate else 1.0 - shade
    out = p < free
    if mode == "scale" and alpha is not None:
        out &= alpha >= 1.0
    return out


def read_map(path: str | Path, key: str = "world.map") -> OccupancyMap:
    """Read a map_server YAML file and its image; every problem is one line starting with ``key``."""
    return _read_map_cached(str(Path(path).resolve()), key)


@lru_cache(maxsize=8)
def _read_map_cached(path_text: str, key: str) -> OccupancyMap:
    from nodnav.scenario.files import read_yaml

    path = Path(path_text)
    try:
        data = read_yaml(path, "map")
    except ScenarioError as exc:
        raise fail(key, str(exc)) from None
    label = shown_path(path)
    data = mapping(data, f"{key} ({label})")
    for k in ("image", "resolution", "origin"):
        if k not in data:
            raise fail(key, f"the map {label} has no '{k}'; a map_server YAML gives image, resolution and origin")
    where = f"{key} ({label})"
    image = data["image"]
    if not isinstance(image, str) or not image.strip():
        raise fail(f"{where}.image", f"expected the image's file name, got {shown(image)}")
    resolution = number(data["resolution"], f"{where}.resolution")
    if resolution <= 0.0:
        raise fail(f"{where}.resolution", f"must be above 0 (metres per cell), got {shown(data['resolution'])}")
    origin = data["origin"]
    if not isinstance(origin, list) or len(origin) not in (2, 3):
        raise fail(f"{where}.origin", f"expected [x, y, yaw], got {shown(origin)}")
    ox, oy = (number(v, f"{where}.origin") for v in origin[:2])
    if len(origin) == 3 and number(origin[2], f"{where}.origin") != 0.0:
        raise fail(f"{where}.origin", f"a turned map (yaw {origin[2]}) is not supported; give yaw 0")
    negate = _flag(data.get("negate", 0), f"{where}.negate")
    occupied = number(data.get("occupied_thresh", 0.65), f"{where}.occupied_thresh")
    free = number(data.get("free_thresh", 0.196), f"{where}.free_thresh")
    if not 0.0 <= free <= occupied <= 1.0:
        raise fail(f"{where}.free_thresh", f"need 0 <= free_thresh <= occupied_thresh <= 1, got {free:g} and "
                                          f"{occupied:g}")
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        raise fail(f"{where}.mode", f"expected one of {', '.join(MODES)}, got {shown(mode)}")
    shade, alpha = _image_shade((path.parent / image), key, mode)
    grid = free_cells(shade, alpha, negate, occupied, free, mode)[::-1]
    if not grid.any():
        raise fail(key, f"the map {label} has no free cell (free means occupancy below free_thresh {free:g}); "
                        f"check negate and the thresholds")
    grid = fill_small_pockets(grid, MIN_FREE_AREA / (resolution * resolution))
    if not grid.any():
        raise fail(key, f"the map {label} has no free region of at least {MIN_FREE_AREA:g} m^2")
    grid = np.ascontiguousarray(grid)
    grid.setflags(write=False)
    m = OccupancyMap(path=str(path), free=grid, resolution=resolution, origin=(ox, oy))
    if len(m.walls) > MAX_MAP_WALLS:
        raise fail(key, f"the map {label} needs {len(m.walls)} wall boxes, more than {MAX_MAP_WALLS}; "
                        f"clean its speckle or give a coarser resolution")
    return m


def fill_small_pockets(free: np.ndarray, min_cells: float) -> np.ndarray:
    """``free`` without its 8-connected free components of fewer than ``min_cells`` cells."""
    from scipy import ndimage

    labels, n = ndimage.label(free, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        return free
    sizes = np.bincount(labels.ravel())
    keep = sizes >= min_cells
    keep[0] = False
    return keep[labels]


@compiled
def wall_boxes(wall: np.ndarray) -> np.ndarray:
    """Boxes ``(B, 4)`` of cell indices ``(col_min, row_min, col_max, row_max)`` (ends exclusive)
    whose union is exactly the cells where ``wall`` is True.

    Greedy: the first cell not yet covered (rows, then columns) starts a run as far right as
    uncovered wall goes, which grows upward while every cell above it is wall (covered or not:
    boxes may overlap, which keeps them fewer). Each cell is visited a bounded number of times
    per box that touches it; in practice linear in the cells.
    """
    rows, cols = wall.shape
    done = np.zeros((rows, cols), dtype=np.bool_)
    out = np.empty((rows * cols // 2 + 1, 4), dtype=np.int64)
    n = 0
    for i in range(rows):
        for j in range(cols):
            if wall[i, j] and not done[i, j]:
                j1 = j
                while j1 + 1 < cols and wall[i, j1 + 1] and not done[i, j1 + 1]:
                    j1 += 1
                i1 = i
                while i1 + 1 < rows:
                    full = True
                    for k in range(j, j1 + 1):
                        if not wall[i1 + 1, k]:
                            full = False
                            break
                    if not full:
                        break
                    i1 += 1
                done[i:i1 + 1, j:j1 + 1] = True
                if n == out.shape[0]:
                    bigger = np.empty((2 * n, 4), dtype=np.int64)
                    bigger[:n] = out
                    out = bigger
                out[n, 0], out[n, 1], out[n, 2], out[n, 3] = j, i, j1 + 1, i1 + 1
                n += 1
    return out[:n].copy()


def write_map(world: Any, path: str | Path, resolution: float) -> Path:
    """Rasterise a :class:`~nodnav.scenario.world.World` into ``path`` (a YAML file) and a PGM
    image beside it, as ROS's map_saver writes them: free 254, walls 0, thresholds 0.65 / 0.196.

    A cell is a wall when its centre is inside a wall or on its boundary (clearance <= 0), so walls
    on the grid's lines come out exactly."""
    from PIL import Image

    path = Path(path)
    x0, y0, x1, y1 = world.bounds
    cols, rows = int(round((x1 - x0) / resolution)), int(round((y1 - y0) / resolution))
    if not (math.isclose(cols * resolution, x1 - x0) and math.isclose(rows * resolution, y1 - y0)):
        raise ValueError(f"the world's bounds {world.bounds} are not a whole number of {resolution} m cells")
    jj, ii = np.meshgrid(np.arange(cols), np.arange(rows))
    centres = np.stack([x0 + (jj + 0.5) * resolution, y0 + (ii + 0.5) * resolution], axis=-1)
    free = world.clearance(centres) > 0.0
    pixels = np.where(free, 254, 0).astype(np.uint8)[::-1]
    image = path.with_suffix(".pgm")
    Image.fromarray(pixels, mode="L").save(image)
    path.write_text(f"image: {image.name}\nresolution: {resolution!r}\norigin: [{x0!r}, {y0!r}, 0.0]\n"
                    f"negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")
    return path
