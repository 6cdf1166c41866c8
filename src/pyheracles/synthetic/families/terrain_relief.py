"""Relief of the ``terrain`` family: a heightfield with slopes, crests, steps and a river cut.

The terrain is built on a regular grid (``z[i, j]`` at ``(x[j], y[i])``, metres, local
frame) as a sum of landforms, each drawn by :mod:`pyheracles.synthetic.families.terrain`:

* a regional plane (``regional_slope_deg``) and smooth hills from band-limited noise whose
  slope reaches ``max_slope_deg`` (99.5th percentile of the cell slopes);
* ridges with a sharp crest (triangular profile, flank slope up to 45 deg);
* terraces: the relief quantised in steps of ``terrace_step_m`` with steep risers, over a
  half-plane of the area;
* embankments: trapezoidal dikes / road banks (1-4 m high);
* platforms: raised flat pads (cut and fill with a steep batter);
* a river cut: a meandering channel, ``river_depth_m`` deep, with its water level.

Besides the heights, :func:`terrain_tags` gives per grid vertex bit flags naming the
landforms that ground filters find hard (steep slope, crest, breakline, platform top, river
bank); the benchmark scores the ground rejected on each of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

__all__ = [
    "TAGS",
    "Relief",
    "RiverCut",
    "add_embankment",
    "add_platform",
    "add_ridge",
    "add_terraces",
    "band_limited_hills",
    "carve_river",
    "heightfield_triangles",
    "mark_discs",
    "slope_deg",
    "terrain_tags",
]

Array = NDArray[np.float64]

#: Bit flags of :func:`terrain_tags` (name -> bit value).
TAGS: dict[str, int] = {
    "steep": 1,  # slope 30-45 deg (and more)
    "crest": 2,  # convex: 0.5 m or more above the mean of a 15 m window
    "breakline": 4,  # slope over 45 deg: terrace risers, embankment sides, batters, banks
    "platform": 8,  # top of a raised flat pad
    "river_bank": 16,  # within 3 m of the water or the channel edge
    "terrace": 32,  # inside the terraced half-plane
    "embankment": 64,  # on a dike / road bank
    "vegetated": 128,  # under a tree crown or a shrub
}


@dataclass
class RiverCut:
    """A meandering channel: its centreline, widths and water level per grid vertex."""

    centreline: Array  # (M, 2) polyline, metres
    width_m: float  # width of the channel floor
    depth_m: float  # floor below the banks
    bank_deg: float  # bank slope
    water_z: Array  # (ny, nx) water level at each vertex (NaN = no water there)
    floor_z: Array  # (M,) floor height along the centreline


@dataclass
class Relief:
    """The drawn terrain on its grid."""

    x: Array
    y: Array
    z: Array
    tags: NDArray[np.uint16] = field(default_factory=lambda: np.zeros(0, np.uint16))
    river: RiverCut | None = None

    @property
    def cell_m(self) -> float:
        """Grid spacing, metres."""
        return float(self.x[1] - self.x[0])

    def height(self, xy: Array) -> Array:
        """Terrain height at ``(K, 2)`` positions (bilinear; clamped to the grid)."""
        p = np.atleast_2d(np.asarray(xy, float))
        c = self.cell_m
        fx = np.clip((p[:, 0] - self.x[0]) / c, 0, len(self.x) - 1.000001)
        fy = np.clip((p[:, 1] - self.y[0]) / c, 0, len(self.y) - 1.000001)
        j, i = np.floor(fx).astype(int), np.floor(fy).astype(int)
        u, v = fx - j, fy - i
        z = self.z
        return (
            (1 - u) * (1 - v) * z[i, j]
            + u * (1 - v) * z[i, j + 1]
            + (1 - u) * v * z[i + 1, j]
            + u * v * z[i + 1, j + 1]
        )

    def footprint_range(self, xy: Array) -> tuple[float, float]:
        """Lowest and highest terrain height over a polygon's vertices and interior samples."""
        z = self.height(xy)
        return float(z.min()), float(z.max())


def slope_deg(z: Array, cell_m: float) -> Array:
    """Slope of a grid, degrees."""
    gy, gx = np.gradient(z, cell_m)
    return np.rad2deg(np.arctan(np.hypot(gx, gy)))


def band_limited_hills(
    shape: tuple[int, int],
    cell_m: float,
    wavelength_m: float,
    slope_tan: float,
    rng: np.random.Generator,
) -> Array:
    """Smooth random hills whose 99.5th-percentile slope is ``slope_tan`` (rise / run).

    Gaussian noise filtered in the Fourier domain to wavelengths of ``wavelength_m`` and
    longer (a 1 / k^2 amplitude fall-off past it), then scaled.
    """
    ny, nx = shape
    noise = rng.normal(size=shape)
    ky = np.fft.fftfreq(ny, cell_m)[:, None]
    kx = np.fft.rfftfreq(nx, cell_m)[None, :]
    k = np.hypot(kx, ky) * wavelength_m
    filt = 1.0 / (1.0 + k**2) ** 1.5
    filt[0, 0] = 0.0
    field_ = np.fft.irfft2(np.fft.rfft2(noise) * filt, s=shape)
    if slope_tan <= 0:
        return np.zeros(shape)
    gy, gx = np.gradient(field_, cell_m)
    g = np.percentile(np.hypot(gx, gy), 99.5)
    return field_ * (slope_tan / max(g, 1e-12))


def _line_coords(X: Array, Y: Array, p: Array, direction_rad: float) -> tuple[Array, Array]:
    """Along- and across-line coordinates of grid points for a line through ``p``."""
    u = np.array([np.cos(direction_rad), np.sin(direction_rad)])
    dx, dy = X - p[0], Y - p[1]
    return dx * u[0] + dy * u[1], -dx * u[1] + dy * u[0]


def add_ridge(
    z: Array,
    X: Array,
    Y: Array,
    p: Array,
    direction_rad: float,
    height_m: float,
    flank_deg: float,
    length_m: float,
) -> Array:
    """A ridge with a sharp crest: triangular profile, tapered at both ends."""
    s, d = _line_coords(X, Y, p, direction_rad)
    half_w = height_m / np.tan(np.deg2rad(flank_deg))
    taper = np.clip((length_m / 2 - np.abs(s)) / (0.25 * length_m), 0, 1)
    return z + height_m * taper * np.clip(1 - np.abs(d) / half_w, 0, 1)


def add_terraces(
    z: Array,
    X: Array,
    Y: Array,
    cell_m: float,
    p: Array,
    direction_rad: float,
    step_m: float,
    riser_deg: float,
) -> tuple[Array, NDArray[np.bool_]]:
    """Quantise the relief in steps on the side ``d > 0`` of a line (flat treads, steep risers).

    Returns the new heights and the mask of the terraced region.
    """
    _, d = _line_coords(X, Y, p, direction_rad)
    gy, gx = np.gradient(z, cell_m)
    g = ndimage.uniform_filter(np.hypot(gx, gy), size=max(3, int(10 / cell_m)))
    riser = np.clip(g / np.tan(np.deg2rad(riser_deg)), 0.03, 0.95)
    q = z / step_m
    frac = q - np.floor(q)
    ramp = np.clip((frac - (1 - riser)) / riser, 0, 1)
    terraced = step_m * (np.floor(q) + ramp)
    w = np.clip(d / 8.0, 0, 1)  # blend over 8 m across the region's edge
    return z + w * (terraced - z), d > 0


def add_embankment(
    z: Array,
    X: Array,
    Y: Array,
    p: Array,
    direction_rad: float,
    height_m: float,
    top_m: float,
    side_deg: float,
) -> tuple[Array, NDArray[np.bool_]]:
    """A dike / road bank across the area: trapezoidal profile on the terrain."""
    _, d = _line_coords(X, Y, p, direction_rad)
    side_w = height_m / np.tan(np.deg2rad(side_deg))
    prof = height_m * np.clip((top_m / 2 + side_w - np.abs(d)) / side_w, 0, 1)
    return z + prof, prof > 0


def add_platform(
    z: Array,
    X: Array,
    Y: Array,
    centre: Array,
    size_m: tuple[float, float],
    heading_rad: float,
    height_m: float,
    batter_deg: float,
) -> tuple[Array, NDArray[np.bool_], float]:
    """A raised flat pad: level top ``height_m`` above the mean terrain under it.

    Cut and fill with a constant batter slope outside the rectangle.  Returns the new
    heights, the mask of the top, and the top's height.
    """
    s, d = _line_coords(X, Y, centre, heading_rad)
    ex = np.maximum(np.abs(s) - size_m[0] / 2, 0)
    ey = np.maximum(np.abs(d) - size_m[1] / 2, 0)
    dist = np.hypot(ex, ey)
    top = dist == 0
    top_z = float(z[top].mean()) + height_m if top.any() else float(z.mean())
    lim = dist * np.tan(np.deg2rad(batter_deg))
    return top_z + np.clip(z - top_z, -lim, lim), top, top_z


def carve_river(
    z: Array,
    X: Array,
    Y: Array,
    rng: np.random.Generator,
    *,
    width_m: float,
    depth_m: float,
    bank_deg: float,
    water_depth_m: float,
    meander_m: float,
    direction_rad: float,
) -> tuple[Array, RiverCut]:
    """Cut a meandering channel across the area and give its water level.

    The channel floor follows the smoothed terrain along the centreline, ``depth_m`` below
    it, and never rises downstream (where the terrain rises it cuts a gorge); the banks
    rise at ``bank_deg`` from the floor's edge until they meet the terrain.
    """
    x0, x1, y0, y1 = X.min(), X.max(), Y.min(), Y.max()
    c = np.array([(x0 + x1) / 2, (y0 + y1) / 2]) + rng.uniform(-0.2, 0.2, 2) * (x1 - x0)
    half = 0.75 * np.hypot(x1 - x0, y1 - y0)
    cell = float(X[0, 1] - X[0, 0])
    s = np.linspace(-half, half, int(2 * half / (0.4 * cell)) + 1)
    wave = rng.uniform(60, 160)
    phase = rng.uniform(0, 2 * np.pi)
    off = meander_m * np.sin(2 * np.pi * s / wave + phase)
    u = np.array([np.cos(direction_rad), np.sin(direction_rad)])
    n = np.array([-u[1], u[0]])
    line = c + s[:, None] * u + off[:, None] * n
    dist, idx = _nearest_on_line(line, X, Y, cell)
    # terrain along the line, smoothed over ~60 m, gives the floor level
    zs = ndimage.uniform_filter(z, size=max(3, int(30 / cell)), mode="nearest")
    fx = np.clip((line[:, 0] - x0) / cell, 0, X.shape[1] - 1).astype(int)
    fy = np.clip((line[:, 1] - y0) / cell, 0, X.shape[0] - 1).astype(int)
    inside = (line[:, 0] >= x0) & (line[:, 0] <= x1) & (line[:, 1] >= y0) & (line[:, 1] <= y1)
    along = zs[fy, fx]
    if inside.any():
        along[~inside] = np.interp(np.flatnonzero(~inside), np.flatnonzero(inside), along[inside])
    floor = ndimage.uniform_filter1d(along, size=max(3, int(60 / (s[1] - s[0]))), mode="nearest")
    # a river runs downhill: the floor never rises downstream (through a hill: a gorge)
    if floor[0] < floor[-1]:
        floor = np.minimum.accumulate(floor[::-1])[::-1]
    else:
        floor = np.minimum.accumulate(floor)
    floor = floor - depth_m
    fz = floor[idx]
    channel = fz + np.maximum(dist - width_m / 2, 0) * np.tan(np.deg2rad(bank_deg))
    carved = np.minimum(z, channel)
    water = fz + water_depth_m
    water = np.where(
        (dist < width_m / 2 + depth_m / np.tan(np.deg2rad(bank_deg))) & (carved < water),
        water,
        np.nan,
    )
    return carved, RiverCut(line, width_m, depth_m, bank_deg, water, floor)


def _nearest_on_line(
    line: Array, X: Array, Y: Array, cell: float
) -> tuple[Array, NDArray[np.intp]]:
    """Distance from each grid vertex to a densely sampled polyline, and the nearest sample.

    The samples are snapped to the grid and a Euclidean distance transform finds the
    nearest one (O(grid) whatever the line's length); the distance is then measured to
    that sample exactly.
    """
    ny, nx = X.shape
    jj = np.round((line[:, 0] - X[0, 0]) / cell).astype(int)
    ii = np.round((line[:, 1] - Y[0, 0]) / cell).astype(int)
    ok = (jj >= 0) & (jj < nx) & (ii >= 0) & (ii < ny)
    lab = np.full((ny, nx), -1, np.intp)
    lab[ii[ok], jj[ok]] = np.flatnonzero(ok)
    _, (ri, rj) = ndimage.distance_transform_edt(lab < 0, return_indices=True)
    idx = lab[ri, rj]
    return np.hypot(X - line[idx, 0], Y - line[idx, 1]), idx


def terrain_tags(relief: Relief, extra: dict[str, NDArray[np.bool_]]) -> NDArray[np.uint16]:
    """Bit flags (:data:`TAGS`) per grid vertex, from the slope, convexity and landforms."""
    z, c = relief.z, relief.cell_m
    sl = slope_deg(z, c)
    tags = np.zeros(z.shape, np.uint16)
    tags[sl >= 30] |= TAGS["steep"]
    brk = ndimage.binary_dilation(sl >= 45, iterations=max(1, round(1.0 / c)))
    tags[brk] |= TAGS["breakline"]
    mean = ndimage.uniform_filter(z, size=max(3, int(15 / c)), mode="nearest")
    tags[z - mean >= 0.5] |= TAGS["crest"]
    for name, mask in extra.items():
        tags[mask] |= TAGS[name]
    if relief.river is not None:
        wet = np.isfinite(relief.river.water_z)
        near = ndimage.binary_dilation(wet, iterations=max(1, round(3.0 / c))) & ~wet
        tags[near] |= TAGS["river_bank"]
    return tags


def mark_discs(relief: Relief, centres: Array, radii: Array) -> NDArray[np.bool_]:
    """Grid vertices within ``radii[k]`` of ``centres[k]`` (``(K, 2)``), as a mask."""
    out = np.zeros(relief.z.shape, bool)
    c = relief.cell_m
    ny, nx = out.shape
    for (cx, cy), r in zip(centres, radii, strict=True):
        j0, j1 = (
            max(0, int((cx - r - relief.x[0]) / c)),
            min(nx, int((cx + r - relief.x[0]) / c) + 2),
        )
        i0, i1 = (
            max(0, int((cy - r - relief.y[0]) / c)),
            min(ny, int((cy + r - relief.y[0]) / c) + 2),
        )
        if j0 >= j1 or i0 >= i1:
            continue
        gx, gy = relief.x[j0:j1], relief.y[i0:i1]
        out[i0:i1, j0:j1] |= (gx[None, :] - cx) ** 2 + (gy[:, None] - cy) ** 2 <= r * r
    return out


def heightfield_triangles(
    x: Array, y: Array, z: Array, keep: NDArray[np.bool_] | None = None
) -> Array:
    """Triangles ``(T, 3, 3)`` of a grid (as :meth:`Scene.add_heightfield`), cells ``keep`` only.

    ``keep`` is ``(ny - 1, nx - 1)``: the cells to build (None = all).
    """
    X, Y = np.meshgrid(x, y)
    P = np.stack([X, Y, z], -1)
    a, b, c, d = P[:-1, :-1], P[:-1, 1:], P[1:, 1:], P[1:, :-1]
    if keep is not None:
        a, b, c, d = a[keep], b[keep], c[keep], d[keep]
    return np.concatenate(
        [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
    )
