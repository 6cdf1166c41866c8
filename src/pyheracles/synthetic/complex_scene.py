"""A walled heritage complex with ground truth: cloud, GIS layers and reference labels.

The scene imitates the Kasepuhan palace of Cirebon (Indonesia), the heritage
complex of Murtiyoso (2020), chapter 5: an enclosure of low brick walls with
split gates (*candi bentar*) and roofed gates (*paduraksa*), an elevated
terrace (*Siti Inggil*) with open pavilions (*mande*, *pendopo*: columns under
hipped or pyramidal roofs), closed buildings, a main building around an inner
courtyard, a row of rooms sharing party walls, trees whose crowns overhang
roofs and walls, and street furniture, all on uneven ground (a slope plus
smooth hills, about 4 m of relief).

The layout is built as labelled surfaces
(:class:`~pyheracles.synthetic.scene.Scene`) and scanned through the one scan
simulator by an airborne LiDAR survey (:data:`KASEPUHAN_SURVEY`): roofs and
open ground at full density, facades and wall faces as the scan angle
shows them, nothing under closed roofs, several returns per pulse in the tree
crowns (porous foliage, with ground below them), no returns from the pond.
This makes the demo the ``layout="kasepuhan"`` member of the ``complex``
scene family (:mod:`pyheracles.synthetic.families.complex`).  The GIS layers
``building``, ``wall`` and ``gate`` are "roughly digitised": every outline is
shifted by 0.1-0.3 m, its vertices jittered by a few centimetres and
simplified, as if drawn on an orthophoto.

Known layout facts that the tests rely on:

* ``building`` holds a MultiPolygon (twin pavilions ``B08``), a polygon with
  a hole (main building around a courtyard ``B11``), a row of four buildings
  whose polygons touch (``B13``-``B16``), a demolished building with no point
  in the cloud (``B20``, now a pond: no returns inside and 1 m around it) and
  a building cut by the survey edge (``B19``, partly outside the cloud).
* ``gate`` holds MultiPolygons too (the two halves of each split gate).
* Internal walls abut the perimeter wall and the gates (touching polygons).

Scaling: the layout is fixed (about 140 m x 200 m); ``n_points`` only sets the
density (the strips are flown for it and the tile thinned to the exact
count), so ``n_points=10_000_000`` is the same complex at about 360 points
per m^2 (a dense drone survey).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import pyproj
import shapely
from numpy.typing import NDArray
from shapely import affinity
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.synthetic.families.complex_build import add_crown, add_terrain, plan_strips
from pyheracles.synthetic.families.simulation import Simulation
from pyheracles.synthetic.scanner import ScanResult, scan
from pyheracles.synthetic.scene import METAL, PLASTER, STONE, TIMBER, Scene

__all__ = [
    "KASEPUHAN_SURVEY",
    "ComplexScene",
    "ComplexSceneParams",
    "kasepuhan_scene",
    "kasepuhan_simulation",
    "write_scene",
]

#: Layers of the GIS, in instance-numbering order.
LAYERS = ("building", "wall", "gate")

# Surface kinds of the internal mesh (turned into part names and materials of the Scene).
_GROUND, _ROOF, _FACADE, _WALL, _GATE, _COLUMN, _FLOOR, _TREE, _CLUTTER = range(1, 10)

_EXTENT_M = (140.0, 200.0)  # survey extent (local x, y), metres
#: The airborne survey of the demo (its density set by ``n_points``): two strips flown
#: 8 deg north of east with 50 % side overlap and a +-30 deg scan, about 315 m above the
#: ground, so every point is seen from two sides; walls running east-west show both faces,
#: walls running north-south mostly their tops.  (8 deg, not 0: the scan lines of a
#: flight exactly parallel to a wall meet it at the same angles on every line.)
KASEPUHAN_SURVEY: dict[str, Any] = {
    "n_strips": 2, "overlap": 0.5, "heading_deg": 8.0, "half_fov_deg": 30.0,
}  # fmt: skip
_SURVEY = KASEPUHAN_SURVEY
_BURY_M = 0.3  # foundations reach this far below the lowest ground under a footprint


@dataclass(frozen=True)
class ComplexSceneParams:
    """Parameters of :func:`kasepuhan_scene`.

    Attributes
    ----------
    n_points
        Exact number of points in the cloud.  The layout is fixed, so this sets
        the density (400 000 points give about 14 points per m^2).
    noise_m
        Standard deviation of the range noise (along the laser beam), metres.
    seed
        Seed of the random generator (trees, clutter, digitising errors, scan).
    facade_weight, column_weight
        No longer used (still validated, so that old calls run): the airborne
        scan decides how densely facades and columns are seen (scan angle,
        occlusion under the eaves).
    crown_penetration
        Share of the pulses through a tree crown that reach what lies below
        (sets the share of opaque twigs among the leaves).
    digitising_offset_m
        Range of the shift of each digitised outline, metres (orthophoto
        misregistration plus drawing error).
    digitising_jitter_m
        Amplitude of the per-vertex drawing error, metres.
    simplify_m
        Tolerance of the simplification of the digitised outlines, metres.
    origin_en
        UTM 49S (EPSG:32749) easting and northing of the complex centre.
    base_height_m
        Ellipsoidal height of the lowest terrain, metres.
    """

    n_points: int = 400_000
    noise_m: float = 0.02
    seed: int = 0
    facade_weight: float = 0.35
    column_weight: float = 0.6
    crown_penetration: float = 0.3
    digitising_offset_m: tuple[float, float] = (0.1, 0.3)
    digitising_jitter_m: float = 0.04
    simplify_m: float = 0.1
    origin_en: tuple[float, float] = (215_000.0, 9_253_000.0)
    base_height_m: float = 6.0


@dataclass(frozen=True, eq=False)
class ComplexScene:
    """A generated complex: the cloud, its GIS layers and the reference labels.

    Attributes
    ----------
    cloud
        The point cloud in EPSG:32749.
    layers
        ``{"building", "wall", "gate"}`` -> GeoDataFrame (EPSG:32749) with the
        columns ``fid``, ``name``, ``function``, ``period`` and layer-specific ones.
    reference_instance
        ``(N,)`` int32 reference object of each point (0 = none: ground, trees,
        street furniture).
    reference_objects
        One row per GIS feature: ``instance`` (>= 1), ``layer``, ``fid``,
        ``feature_index`` (row in its layer), ``name``, ``n_points``.
    ground
        ``(N,)`` bool, True for points on the terrain.
    extent
        The surveyed area (EPSG:32749): no point lies outside it, and the
        building ``B19`` crosses its eastern edge.
    """

    cloud: PointCloud
    layers: dict[str, gpd.GeoDataFrame]
    reference_instance: NDArray[np.int32]
    reference_objects: pd.DataFrame
    ground: NDArray[np.bool_]
    extent: Polygon = field(default_factory=Polygon)


# ----------------------------------------------------------------------------- terrain
# (x, y, amplitude m, sigma m): the Siti Inggil terrace is a hill, plus undulations.
_HILLS = np.array(
    [
        [70.0, 166.0, 1.3, 16.0],
        [28.0, 60.0, 1.2, 22.0],
        [112.0, 118.0, -0.9, 18.0],
        [100.0, 30.0, 0.6, 14.0],
        [20.0, 150.0, 0.5, 10.0],
    ]
)


def ground_height(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Terrain height above the scene base at local ``(x, y)``, metres.

    A slope rising 2.4 m to the north and 0.7 m to the west plus Gaussian hills.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = 1.0 + 0.012 * y - 0.005 * x
    for hx, hy, amp, sig in _HILLS:
        z = z + amp * np.exp(-((x - hx) ** 2 + (y - hy) ** 2) / (2.0 * sig * sig))
    return z


# ----------------------------------------------------------------------------- meshes
def _with_z(ring_xy: NDArray[np.float64], z: float | NDArray[np.float64]) -> NDArray[np.float64]:
    ring_xy = np.asarray(ring_xy, dtype=np.float64)
    zz = np.broadcast_to(np.asarray(z, dtype=np.float64), (len(ring_xy),))
    return np.column_stack([ring_xy, zz])


def _band(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Triangles joining two closed rings of equal length (walls, roof slopes)."""
    lo1 = np.roll(lo, -1, axis=0)
    hi1 = np.roll(hi, -1, axis=0)
    t1 = np.stack([lo, lo1, hi1], axis=1)
    t2 = np.stack([lo, hi1, hi], axis=1)
    return np.concatenate([t1, t2])


def _fan(ring: NDArray[np.float64]) -> NDArray[np.float64]:
    """Triangles of a convex planar ring (box tops, floors)."""
    n = len(ring)
    i = np.arange(1, n - 1)
    return np.stack([np.repeat(ring[:1], n - 2, axis=0), ring[i], ring[i + 1]], axis=1)


def _rect(x0: float, y0: float, x1: float, y1: float) -> NDArray[np.float64]:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def _ridge_ring(rect: NDArray[np.float64], shrink: float) -> NDArray[np.float64]:
    """Inner ring of a hipped roof: the ridge (a degenerate ring) of an axis-aligned rectangle.

    ``shrink`` < 1 keeps a smaller rectangle instead (the base of a second roof tier).
    """
    (x0, y0), (x1, y1) = rect[0], rect[2]
    cx, cy, a, b = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2
    if shrink > 0:
        return _rect(cx - a * shrink, cy - b * shrink, cx + a * shrink, cy + b * shrink)
    if a >= b:
        r = a - b
        return np.array([[cx - r, cy], [cx + r, cy], [cx + r, cy], [cx - r, cy]])
    r = b - a
    return np.array([[cx, cy - r], [cx, cy - r], [cx, cy + r], [cx, cy + r]])


def _half_min_side(ring: NDArray[np.float64]) -> float:
    span = ring.max(axis=0) - ring.min(axis=0)
    return float(span.min() / 2)


class _Mesh:
    """Accumulates triangles with their owner, surface kind and occlusion group."""

    def __init__(self) -> None:
        self.tris: list[NDArray[np.float64]] = []
        self.owner: list[NDArray[np.int32]] = []
        self.kind: list[NDArray[np.uint8]] = []
        self.group: list[NDArray[np.int32]] = []
        self.n_groups = 0

    def add(self, tris: NDArray[np.float64], owner: int, kind: int) -> None:
        """Add triangles forming one surface (one occlusion group)."""
        self.n_groups += 1
        n = len(tris)
        self.tris.append(np.asarray(tris, dtype=np.float64).reshape(n, 3, 3))
        self.owner.append(np.full(n, owner, np.int32))
        self.kind.append(np.full(n, kind, np.uint8))
        self.group.append(np.full(n, self.n_groups, np.int32))

    def arrays(self) -> tuple[NDArray[Any], ...]:
        return (
            np.concatenate(self.tris),
            np.concatenate(self.owner),
            np.concatenate(self.kind),
            np.concatenate(self.group),
        )

    # -- building blocks ------------------------------------------------------
    def prism(
        self,
        ring: NDArray[np.float64],
        z_bottom: float,
        z_top: float,
        owner: int,
        kind: int,
        *,
        top: bool = True,
        top_kind: int | None = None,
        scale_top: float = 1.0,
    ) -> None:
        """Vertical (or tapered) sides of a ring extruded from ``z_bottom`` to ``z_top``."""
        c = ring.mean(axis=0)
        ring_top = c + (ring - c) * scale_top
        self.add(_band(_with_z(ring, z_bottom), _with_z(ring_top, z_top)), owner, kind)
        if top:
            self.add(_fan(_with_z(ring_top, z_top)), owner, top_kind or kind)

    def roof(
        self, rect: NDArray[np.float64], z_eave: float, style: str, owner: int, kind: int = _ROOF
    ) -> None:
        """Hipped, pyramidal, two-tier (joglo) or stacked (tumpang) roof over a rectangle.

        Pitches follow Javanese roofs: about 30 degrees for the lower tier, 45-50
        degrees for the upper one.
        """
        half = _half_min_side(rect)
        if style in ("hipped", "pyramid"):
            inner = _ridge_ring(rect, 0.0)
            self.add(_band(_with_z(rect, z_eave), _with_z(inner, z_eave + 0.9 * half)), owner, kind)
        elif style == "joglo":  # shallow lower tier, steep upper hipped roof
            mid = _ridge_ring(rect, 0.45)
            z_mid = z_eave + 0.55 * half * 0.6
            self.add(_band(_with_z(rect, z_eave), _with_z(mid, z_mid)), owner, kind)
            inner = _ridge_ring(mid, 0.0)
            top_half = _half_min_side(mid)
            self.add(
                _band(_with_z(mid, z_mid), _with_z(inner, z_mid + 1.2 * top_half)), owner, kind
            )
        elif style == "tumpang":  # two pyramids, the upper one raised on a short drum
            mid = _ridge_ring(rect, 0.5)
            z_mid = z_eave + 0.5 * half * 0.8
            self.add(_band(_with_z(rect, z_eave), _with_z(mid, z_mid)), owner, kind)
            upper = _ridge_ring(rect, 0.62)
            self.add(_band(_with_z(mid, z_mid), _with_z(mid, z_mid + 0.6)), owner, _FACADE)
            apex = _ridge_ring(upper, 0.0)
            z_up = z_mid + 0.6
            self.add(
                _band(_with_z(upper, z_up), _with_z(apex, z_up + 1.0 * _half_min_side(upper))),
                owner,
                kind,
            )
        else:  # pragma: no cover - internal layout table
            raise ValueError(f"unknown roof style {style!r}")

    def cone(self, ring: NDArray[np.float64], z_eave: float, height: float, owner: int) -> None:
        """Conical roof over any convex ring (round pavilion)."""
        apex = np.repeat(ring.mean(axis=0, keepdims=True), len(ring), axis=0)
        self.add(_band(_with_z(ring, z_eave), _with_z(apex, z_eave + height)), owner, _ROOF)

    def wall(
        self,
        line: NDArray[np.float64],
        thickness: float,
        height: float,
        owner: int,
        kind: int = _WALL,
        *,
        caps: bool = False,
        piece_m: float = 1.5,
    ) -> None:
        """A wall of constant height above the terrain along a polyline.

        Both faces and the top follow the terrain in pieces of ``piece_m``; corners
        are filled by extending inner legs by half the thickness; end caps only
        where the wall ends free (``caps``), not where it abuts a gate.
        """
        line = np.asarray(line, dtype=np.float64)
        n_legs = len(line) - 1
        for k in range(n_legs):  # loop over a few wall legs, not over points
            p, q = line[k].copy(), line[k + 1].copy()
            d = (q - p) / np.linalg.norm(q - p)
            if k > 0:
                p -= d * thickness / 2
            if k < n_legs - 1:
                q += d * thickness / 2
            length = float(np.linalg.norm(q - p))
            n_pieces = max(1, math.ceil(length / piece_m))
            s = np.linspace(0.0, 1.0, n_pieces + 1)[:, None]
            axis = p + s * (q - p)
            nrm = np.array([-d[1], d[0]]) * thickness / 2
            zg = ground_height(axis[:, 0], axis[:, 1])
            zb, zt = zg - _BURY_M, zg + height
            left, right = axis + nrm, axis - nrm
            for side in (left, right):
                lo, hi = _with_z(side, zb), _with_z(side, zt)
                quads = np.stack([lo[:-1], lo[1:], hi[1:], hi[:-1]], axis=1)
                self.add(_quads(quads), owner, kind)
            tl, tr = _with_z(left, zt), _with_z(right, zt)
            self.add(_quads(np.stack([tl[:-1], tl[1:], tr[1:], tr[:-1]], axis=1)), owner, kind)
            if caps and (k == 0 or k == n_legs - 1):
                for i in ([0] if k == 0 else []) + ([-1] if k == n_legs - 1 else []):
                    cap = np.array(
                        [
                            [*left[i], zb[i]],
                            [*right[i], zb[i]],
                            [*right[i], zt[i]],
                            [*left[i], zt[i]],
                        ]
                    )
                    self.add(_quads(cap[None]), owner, kind)


def _quads(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Split ``(n, 4, 3)`` quads into ``(2n, 3, 3)`` triangles."""
    return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def _ring_ground(ring: NDArray[np.float64]) -> tuple[float, float]:
    """(lowest ground under a footprint, ground at its centre)."""
    pts = np.vstack([ring, ring.mean(axis=0, keepdims=True)])
    z = ground_height(pts[:, 0], pts[:, 1])
    return float(z.min()), float(z[-1])


def _expand(rect: NDArray[np.float64], dx0: float, dy0: float, dx1: float, dy1: float):
    (x0, y0), (x1, y1) = rect[0], rect[2]
    return _rect(x0 - dx0, y0 - dy0, x1 + dx1, y1 + dy1)


# ----------------------------------------------------------------------------- layout
@dataclass(frozen=True)
class _Part:
    """One wing of a building: wall/platform rectangle and roof rectangle (local metres)."""

    rect: tuple[float, float, float, float]
    eave_height_m: float = 3.0
    roof: str = "hipped"
    eaves_m: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8)  # W, S, E, N


@dataclass(frozen=True)
class _Building:
    fid: str
    name: str
    function: str
    period: str
    kind: str  # "pendopo" (open, columns), "closed", "round", "demolished"
    parts: tuple[_Part, ...]


def _p(x0, y0, x1, y1, h=3.0, roof="hipped", eaves=(0.8, 0.8, 0.8, 0.8)) -> _Part:
    return _Part((x0, y0, x1, y1), h, roof, eaves)


# fmt: off
_BUILDINGS: tuple[_Building, ...] = (
    # Siti Inggil terrace: five open pavilions (mande)
    _Building("B01", "Mande Malang Semirang", "pavilion", "15th c.", "pendopo",
              (_p(67.0, 165.0, 73.0, 171.0, 2.6, "joglo"),)),
    _Building("B02", "Mande Pendawa Lima", "pavilion", "15th c.", "pendopo",
              (_p(53.5, 167.0, 58.5, 173.0, 2.5, "hipped"),)),
    _Building("B03", "Mande Semar Tinandu", "pavilion", "15th c.", "pendopo",
              (_p(81.5, 167.5, 86.5, 172.5, 2.5, "pyramid"),)),
    _Building("B04", "Mande Pangiring", "pavilion", "15th c.", "pendopo",
              (_p(54.0, 155.5, 58.0, 160.5, 2.4, "hipped"),)),
    _Building("B05", "Mande Karasemen", "pavilion", "15th c.", "pendopo",
              (_p(81.5, 156.0, 86.5, 160.0, 2.4, "hipped"),)),
    # outside the north wall, on the alun-alun side
    _Building("B06", "Pancaratna", "audience pavilion", "16th c.", "pendopo",
              (_p(36.0, 192.5, 44.0, 196.5, 2.8, "hipped"),)),
    _Building("B07", "Pancaniti", "audience pavilion", "16th c.", "pendopo",
              (_p(24.0, 134.0, 36.0, 144.0, 3.0, "joglo"),)),
    # twin pavilions: one feature, two parts (MultiPolygon)
    _Building("B08", "Bale Kembar", "guard pavilions", "18th c.", "pendopo",
              (_p(98.0, 138.0, 102.0, 142.0, 2.4, "pyramid"),
               _p(110.0, 138.0, 114.0, 142.0, 2.4, "pyramid"))),
    _Building("B09", "Langgar Alit", "prayer house", "16th c.", "closed",
              (_p(26.5, 76.5, 33.5, 83.5, 3.2, "tumpang"),)),
    _Building("B10", "Bangsal Prabayaksa", "audience hall", "17th c.", "pendopo",
              (_p(63.0, 98.0, 77.0, 106.0, 3.2, "joglo"),)),
    # main building around an inner courtyard (polygon with a hole)
    _Building("B11", "Dalem Arum Kedaton", "residence", "17th c.", "closed",
              (_p(50.0, 81.0, 90.0, 90.0, 3.6), _p(50.0, 60.0, 90.0, 69.0, 3.6),
               _p(50.0, 69.0, 60.0, 81.0, 3.4), _p(80.0, 69.0, 90.0, 81.0, 3.4))),
    _Building("B12", "Bangsal Pringgandani", "reception hall", "18th c.", "closed",
              (_p(96.0, 30.0, 116.0, 40.0, 3.4), _p(106.0, 40.0, 116.0, 52.0, 3.4))),
    # a row of rooms sharing party walls (touching polygons)
    _Building("B13", "Gedong Jinem", "storeroom", "18th c.", "closed",
              (_p(16.0, 30.0, 24.0, 36.5, 2.8, eaves=(0.8, 0.8, 0.8, 0.0)),)),
    _Building("B14", "Kaputran 1", "residence", "18th c.", "closed",
              (_p(16.0, 36.5, 24.0, 43.0, 3.2, eaves=(0.8, 0.0, 0.8, 0.0)),)),
    _Building("B15", "Kaputran 2", "residence", "18th c.", "closed",
              (_p(16.0, 43.0, 24.0, 49.5, 3.0, eaves=(0.8, 0.0, 0.8, 0.0)),)),
    _Building("B16", "Kaputran 3", "residence", "19th c.", "closed",
              (_p(16.0, 49.5, 24.0, 56.0, 3.4, eaves=(0.8, 0.0, 0.8, 0.8)),)),
    _Building("B17", "Museum Pusaka", "museum", "20th c.", "closed",
              (_p(30.0, 22.0, 46.0, 30.0, 3.6),)),
    _Building("B18", "Bale Bundar", "pavilion", "19th c.", "round",
              (_p(102.0, 77.0, 108.0, 83.0, 2.4),)),
    # cut by the eastern edge of the survey (partly outside the cloud)
    _Building("B19", "Gedong Lonceng", "warehouse", "20th c.", "closed",
              (_p(132.0, 55.0, 146.0, 67.0, 3.4),)),
    # demolished, still in the GIS; today a pond (no returns)
    _Building("B20", "Bangsal Kaputren", "residence (demolished)", "17th c.", "demolished",
              (_p(97.5, 158.0, 109.5, 166.0, 3.0),)),
)
# fmt: on


@dataclass(frozen=True)
class _WallRun:
    fid: str
    name: str
    function: str
    material: str
    period: str
    line: tuple[tuple[float, float], ...]
    thickness_m: float
    height_m: float
    free_ends: bool = False


_PERIM_T, _PERIM_H = 0.5, 2.5
_INNER_T, _INNER_H = 0.4, 1.8
# fmt: off
_WALLS: tuple[_WallRun, ...] = (
    _WallRun("W01", "Benteng lor-wetan", "perimeter wall", "red brick", "16th c.",
             ((73.0, 188.0), (128.0, 188.0), (128.0, 102.0)), _PERIM_T, _PERIM_H),
    _WallRun("W02", "Benteng kidul-wetan", "perimeter wall", "red brick", "16th c.",
             ((128.0, 98.0), (128.0, 12.0), (72.0, 12.0)), _PERIM_T, _PERIM_H),
    _WallRun("W03", "Benteng kulon", "perimeter wall", "red brick", "16th c.",
             ((68.0, 12.0), (12.0, 12.0), (12.0, 188.0), (67.0, 188.0)), _PERIM_T, _PERIM_H),
    _WallRun("W04", "Tembok Buk Bacem kulon", "internal wall", "plastered brick", "17th c.",
             ((12.25, 120.0), (68.0, 120.0)), _INNER_T, 2.2),
    _WallRun("W05", "Tembok Buk Bacem wetan", "internal wall", "plastered brick", "17th c.",
             ((72.0, 120.0), (127.75, 120.0)), _INNER_T, 2.2),
    _WallRun("W06", "Tembok Siti Inggil", "terrace wall", "red brick", "15th c.",
             ((73.0, 150.0), (95.0, 150.0), (95.0, 182.0), (45.0, 182.0), (45.0, 150.0),
              (67.0, 150.0)), _INNER_T, _INNER_H),
    _WallRun("W07", "Kelir", "screen wall", "plastered brick", "18th c.",
             ((67.0, 115.0), (73.0, 115.0)), 0.3, 2.0, free_ends=True),
)
# fmt: on


@dataclass(frozen=True)
class _Gate:
    fid: str
    name: str
    function: str
    gate_type: str  # "candi bentar" | "paduraksa"
    period: str
    centre: tuple[float, float]
    along_x: bool  # the wall runs along x at this gate
    opening_m: float = 2.8
    depth_m: float = 2.2
    width_m: float = 4.0  # paduraksa: size along the wall


# fmt: off
_GATES: tuple[_Gate, ...] = (
    _Gate("G01", "Gapura Adi", "main gate", "candi bentar", "15th c.", (70.0, 188.0), True),
    _Gate("G02", "Regol Pengada", "south gate", "paduraksa", "16th c.", (70.0, 12.0), True,
          depth_m=3.0),
    _Gate("G03", "Lawang Sanga", "river gate", "paduraksa", "16th c.", (128.0, 100.0), False,
          depth_m=3.0),
    _Gate("G04", "Pintu Buk Bacem", "inner gate", "paduraksa", "17th c.", (70.0, 120.0), True,
          depth_m=2.6),
    _Gate("G05", "Gapura Banteng", "terrace gate", "candi bentar", "15th c.", (70.0, 150.0),
          True, depth_m=1.8),
)
# fmt: on

# Trees placed so that their crowns overhang roofs and walls: (x, y, crown radius, trunk height)
_TREES_FIXED = np.array(
    [
        [50.5, 92.5, 5.0, 4.0],  # over the NW corner of B11
        [20.0, 185.0, 4.0, 3.0],  # over the perimeter wall
        [42.0, 176.0, 3.5, 3.0],  # over the Siti Inggil wall
        [62.0, 113.0, 4.0, 3.5],  # over the inner wall W04 and the kelir
        [27.0, 63.0, 3.5, 3.0],  # over the row buildings
        [118.0, 45.0, 4.5, 3.5],  # over B12
        [92.0, 150.0, 3.5, 3.0],  # over the terrace wall corner
        [126.0, 150.0, 4.0, 3.0],  # over the east perimeter wall
        [38.0, 146.5, 3.5, 3.5],  # over Pancaniti B07
        [110.0, 85.0, 3.0, 3.0],  # over the round pavilion B18
    ]
)


# ----------------------------------------------------------------------------- scene
def _build_buildings(mesh: _Mesh, owner_of: dict[str, int], rng: np.random.Generator):
    """Meshes of all buildings; returns the true (roof outline) footprint of each."""
    footprints: dict[str, Any] = {}
    for b in _BUILDINGS:  # a few dozen buildings, not points
        owner = owner_of[b.fid]
        roofs = []
        for part in b.parts:
            rect = _rect(*part.rect)
            w, s, e, n = part.eaves_m
            roof_rect = _expand(rect, w, s, e, n)
            roofs.append(box(*roof_rect[0], *roof_rect[2]))
            if b.kind == "demolished":
                continue
            z_low, z_mid = _ring_ground(roof_rect)
            if b.kind in ("pendopo", "round"):
                # raised platform (umpak), floor, columns, roof
                floor = z_mid + 0.45
                plat = _expand(rect, 0.3, 0.3, 0.3, 0.3)
                mesh.prism(plat, z_low - _BURY_M, floor, owner, _FACADE, top_kind=_FLOOR)
                z_eave = floor + part.eave_height_m
                (x0, y0), (x1, y1) = rect[0], rect[2]
                nx = max(2, round((x1 - x0) / 2.5) + 1)
                ny = max(2, round((y1 - y0) / 2.5) + 1)
                gx, gy = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
                edge = (gx == x0) | (gx == x1) | (gy == y0) | (gy == y1)
                gx, gy = gx[edge], gy[edge]
                octagon = 0.14 * np.column_stack(
                    [np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)]
                )
                rings = [octagon + np.array([cx, cy]) for cx, cy in zip(gx, gy, strict=True)]
                cols = [_band(_with_z(r, floor), _with_z(r, z_eave)) for r in rings]
                mesh.add(np.concatenate(cols), owner, _COLUMN)
                if b.kind == "round":
                    ang = np.arange(12) * np.pi / 6
                    c = rect.mean(axis=0)
                    ring = c + 4.8 * np.column_stack([np.cos(ang), np.sin(ang)])
                    mesh.cone(ring, z_eave, 3.0, owner)
                    roofs[-1] = Polygon(ring)
                else:
                    mesh.roof(roof_rect, z_eave, part.roof, owner)
            else:
                floor = z_mid + 0.3
                mesh.prism(
                    rect, z_low - _BURY_M, floor + part.eave_height_m, owner, _FACADE, top=False
                )
                mesh.roof(roof_rect, floor + part.eave_height_m, part.roof, owner)
        geom = unary_union(roofs)
        footprints[b.fid] = geom
    return footprints


def _gate_parts(g: _Gate) -> list[NDArray[np.float64]]:
    cx, cy = g.centre
    if g.gate_type == "candi bentar":
        half_w = 0.8
        offs = g.opening_m / 2 + half_w
        centres = [(-offs, 0.0), (offs, 0.0)]
        size = (half_w, g.depth_m / 2)
    else:
        centres = [(0.0, 0.0)]
        size = (g.width_m / 2, g.depth_m / 2)
    rects = []
    for ox, oy in centres:
        if g.along_x:
            rects.append(
                _rect(cx + ox - size[0], cy + oy - size[1], cx + ox + size[0], cy + oy + size[1])
            )
        else:
            rects.append(_rect(cx - size[1], cy + ox - size[0], cx + size[1], cy + ox + size[0]))
    return rects


def _build_gates(mesh: _Mesh, owner_of: dict[str, int]) -> dict[str, Any]:
    footprints: dict[str, Any] = {}
    for g in _GATES:
        owner = owner_of[g.fid]
        rects = _gate_parts(g)
        for rect in rects:
            z_low, z_mid = _ring_ground(rect)
            if g.gate_type == "candi bentar":
                # stepped, tapering half-towers
                levels = [
                    (0.0, 1.3, 1.0),
                    (1.3, 2.7, 0.86),
                    (2.7, 3.9, 0.72),
                    (3.9, 5.0, 0.56),
                    (5.0, 5.9, 0.38),
                ]
                c = rect.mean(axis=0)
                for z0, z1, s in levels:
                    ring = c + (rect - c) * s
                    zb = z_low - _BURY_M if z0 == 0.0 else z_mid + z0
                    mesh.prism(ring, zb, z_mid + z1, owner, _GATE)
            else:
                mesh.prism(rect, z_low - _BURY_M, z_mid + 3.2, owner, _GATE, top=False)
                roof_rect = _expand(rect, 0.3, 0.3, 0.3, 0.3)
                mesh.roof(roof_rect, z_mid + 3.2, "pyramid", owner, _GATE)
        footprints[g.fid] = unary_union([box(*r[0], *r[2]) for r in rects])
    return footprints


def _build_walls(mesh: _Mesh, owner_of: dict[str, int]) -> dict[str, Any]:
    footprints: dict[str, Any] = {}
    for w in _WALLS:
        line = np.array(w.line)
        mesh.wall(line, w.thickness_m, w.height_m, owner_of[w.fid], caps=w.free_ends)
        footprints[w.fid] = LineString(line).buffer(
            w.thickness_m / 2, cap_style="flat", join_style="mitre"
        )
    return footprints


def _place_trees(rng: np.random.Generator, obstacles: Any) -> NDArray[np.float64]:
    """Fixed trees plus random ones in open ground: rows (x, y, z_centre, r, r_z)."""
    cand = np.column_stack(
        [
            rng.uniform(3.0, _EXTENT_M[0] - 3.0, 80),
            rng.uniform(3.0, _EXTENT_M[1] - 3.0, 80),
            rng.uniform(2.5, 4.5, 80),
            rng.uniform(2.5, 4.0, 80),
        ]
    )
    free = ~shapely.intersects_xy(obstacles.buffer(2.0), cand[:, 0], cand[:, 1])
    extra = cand[free][:18]
    trees = np.vstack([_TREES_FIXED, extra])
    zg = ground_height(trees[:, 0], trees[:, 1])
    rz = 0.7 * trees[:, 2]
    return np.column_stack([trees[:, 0], trees[:, 1], zg + trees[:, 3] + rz, trees[:, 2], rz])


def _build_trunks(mesh: _Mesh, crowns: NDArray[np.float64]) -> None:
    ang = np.arange(8) * np.pi / 4
    unit = np.column_stack([np.cos(ang), np.sin(ang)])
    parts = []
    for cx, cy, cz, _r, rz in crowns:
        zg = float(ground_height(np.array([cx]), np.array([cy]))[0])
        ring = unit * 0.25 + (cx, cy)
        parts.append(_band(_with_z(ring, zg - _BURY_M), _with_z(ring, cz - 0.5 * rz)))
    mesh.add(np.concatenate(parts), 0, _TREE)


def _build_clutter(mesh: _Mesh, rng: np.random.Generator, obstacles: Any) -> None:
    """Benches, lamp posts, planters and a few parked cars in open ground."""
    n = 120
    xy = np.column_stack(
        [rng.uniform(2.0, _EXTENT_M[0] - 2.0, n), rng.uniform(2.0, _EXTENT_M[1] - 2.0, n)]
    )
    near = shapely.intersects_xy(obstacles.buffer(4.0), xy[:, 0], xy[:, 1])
    clear = ~shapely.intersects_xy(obstacles.buffer(1.2), xy[:, 0], xy[:, 1])
    # prefer spots close to (but not on) buildings and walls: where clutter confuses a clip
    keep = np.flatnonzero(near & clear)[:40]
    kinds = rng.integers(0, 4, len(keep))
    for (x, y), k in zip(xy[keep], kinds, strict=True):
        zg = float(ground_height(np.array([x]), np.array([y]))[0])
        if k == 0:  # bench
            ring, h = _rect(x - 0.8, y - 0.25, x + 0.8, y + 0.25), 0.45
        elif k == 1:  # lamp post
            ring, h = _rect(x - 0.08, y - 0.08, x + 0.08, y + 0.08), 3.5
        elif k == 2:  # planter
            ring, h = _rect(x - 0.5, y - 0.5, x + 0.5, y + 0.5), 0.8
        else:  # parked car
            ring, h = _rect(x - 2.2, y - 0.9, x + 2.2, y + 0.9), 1.0
        mesh.prism(ring, zg - 0.1, zg + h, 0, _CLUTTER)
        if k == 3:
            cab = _rect(x - 1.0, y - 0.8, x + 0.9, y + 0.8)
            mesh.prism(cab, zg + h, zg + h + 0.5, 0, _CLUTTER, scale_top=0.85)


def _digitise(
    footprints: dict[str, Any], params: ComplexSceneParams, rng: np.random.Generator
) -> dict[str, Any]:
    """Simulate digitising on an orthophoto: shift, per-vertex jitter, simplification.

    Features drawn together (the row of rooms, the walls with their gates)
    share one shift, and the jitter is a smooth function of position, so
    shared vertices move identically and touching outlines stay touching.
    """
    lo, hi = params.digitising_offset_m
    phase = rng.uniform(0, 2 * np.pi, 4)
    amp = params.digitising_jitter_m

    def shift() -> NDArray[np.float64]:
        ang = rng.uniform(0, 2 * np.pi)
        return rng.uniform(lo, hi) * np.array([np.cos(ang), np.sin(ang)])

    groups = {fid: fid for fid in footprints}
    for fid in ("B13", "B14", "B15", "B16"):
        groups[fid] = "row"
    for fid in [w.fid for w in _WALLS] + [g.fid for g in _GATES]:
        groups[fid] = "enclosure"
    shifts = {g: shift() for g in sorted(set(groups.values()))}
    out = {}
    for fid, geom in footprints.items():
        d = shifts[groups[fid]]

        def move(c: NDArray[np.float64], d: NDArray[np.float64] = d) -> NDArray[np.float64]:
            jx = (
                amp
                * np.sin(0.37 * c[:, 0] + 0.23 * c[:, 1] + phase[0])
                * np.cos(0.11 * c[:, 1] + phase[1])
            )
            jy = (
                amp
                * np.sin(0.29 * c[:, 1] - 0.31 * c[:, 0] + phase[2])
                * np.cos(0.13 * c[:, 0] + phase[3])
            )
            return c + d + np.column_stack([jx, jy])

        moved = shapely.transform(geom, move)
        out[fid] = shapely.simplify(moved, params.simplify_m, preserve_topology=True)
    return out


def _validate(params: ComplexSceneParams) -> None:
    seed = params.seed
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(
            f"seed must be a whole number >= 0, got {params.seed!r}", hint="e.g. --seed 0"
        )
    if params.n_points < 1000:
        raise InputError(f"n_points must be at least 1000, got {params.n_points}")
    if not (params.noise_m >= 0 and np.isfinite(params.noise_m)):
        raise InputError(f"noise_m must be finite and >= 0, got {params.noise_m}")
    for name in ("facade_weight", "column_weight", "crown_penetration"):
        v = getattr(params, name)
        if not 0 <= v <= 1:
            raise InputError(f"{name} must be in [0, 1], got {v}")


#: Part name, material and class (for owner 0) of each surface kind.
_KIND_REF = {
    _ROOF: ("roof", TIMBER),
    _FACADE: ("facade", PLASTER),
    _WALL: ("wall", STONE),
    _GATE: ("gate", STONE),
    _COLUMN: ("column", TIMBER),
    _FLOOR: ("platform", STONE),
    _TREE: ("trunk", TIMBER),
    _CLUTTER: ("clutter", METAL),
}


def _to_scene(
    mesh: _Mesh,
    layer_of: dict[int, str],
    crowns: NDArray[np.float64],
    pond: Any,
    params: ComplexSceneParams,
    rng: np.random.Generator,
) -> Scene:
    """The mesh as a labelled :class:`Scene`: terrain (a hole for the pond), objects, trees."""
    scene = Scene()
    for name in ("ground", *LAYERS, "tree", "clutter"):
        scene.class_code(name)
    add_terrain(scene, ground_height, (0.0, 0.0, *_EXTENT_M), cell_m=1.0, holes=pond)
    tris, owner, kind, _group = mesh.arrays()
    for o in np.unique(owner):  # a few dozen owners, each with a handful of kinds
        for k in np.unique(kind[owner == o]):
            sel = (owner == o) & (kind == k)
            part, material = _KIND_REF[int(k)]
            if o > 0:
                cls = layer_of[int(o)]
            else:
                cls = "tree" if k == _TREE else "clutter"
            scene.add_triangles(
                tris[sel], instance=int(o), class_name=cls, part=part, material=material
            )
    for cx, cy, cz, r, rz in crowns:
        add_crown(scene, (cx, cy, cz), r, rz, rng, penetration=params.crown_penetration)
    return scene


def _survey(
    scene: Scene, params: ComplexSceneParams, rng: np.random.Generator
) -> tuple[ScanResult, dict[str, Any]]:
    """Airborne strips over the extent; exactly ``params.n_points`` points of the tile.

    The strips are flown for slightly more first returns than points wanted
    (the multiple returns in the crowns add more) and the tile is thinned at
    random to the exact count (the points keep their acquisition order).
    """
    bounds = (0.0, 0.0, *_EXTENT_M)
    x1, y1 = _EXTENT_M

    def fly(density: float) -> tuple[ScanResult, dict[str, Any]]:
        sv, plan = plan_strips(bounds, noise_m=params.noise_m, density_per_m2=density,
                               **_SURVEY)  # fmt: skip
        res = scan(scene, sv, rng=rng)
        x, y = res.xyz[:, 0], res.xyz[:, 1]
        return res.subset((x >= 0) & (x < x1) & (y >= 0) & (y < y1)), plan

    density = 1.02 * params.n_points / (x1 * y1)
    for _attempt in range(4):  # flies again, denser, in the unlikely case it fell short
        res, plan = fly(density)
        if len(res) >= params.n_points:
            break
        density *= 1.05 * params.n_points / max(len(res), 1)
    else:  # pragma: no cover - the first flight gives a few per cent more points
        raise RuntimeError("could not fly enough points")
    keep = np.zeros(len(res), bool)
    keep[rng.choice(len(res), params.n_points, replace=False)] = True
    plan = {**plan, "flown_density_per_m2": density, "points_flown": len(res)}
    return res.subset(keep), plan


def _kasepuhan_world(params: ComplexSceneParams) -> tuple[NDArray[np.float64], pyproj.CRS]:
    offset = np.array(
        [
            params.origin_en[0] - _EXTENT_M[0] / 2,
            params.origin_en[1] - _EXTENT_M[1] / 2,
            params.base_height_m,
        ]
    )
    return offset, pyproj.CRS("EPSG:32749")


def kasepuhan_simulation(params: ComplexSceneParams | None = None) -> Simulation:
    """The demo complex as a member of the ``complex`` scene family.

    Builds the fixed layout as labelled surfaces and scans them with the
    airborne simulator (:data:`KASEPUHAN_SURVEY`); see :func:`kasepuhan_scene`
    for what the layout holds.  ``draw(seed, layout="kasepuhan")`` of
    :mod:`pyheracles.synthetic.families.complex` returns this.

    Returns
    -------
    Simulation
        Family ``complex``, the seed of ``params``, one cloud ``"cloud"`` of
        exactly ``params.n_points`` points (local frame; EPSG:32749 with
        ``sim.offset``) and ``extras`` as the family's (``layers``,
        ``reference_objects``, ``extent``, ``write_extras``).
    """
    from pyheracles.synthetic.families.complex import write_layers

    params = params or ComplexSceneParams()
    _validate(params)
    rng = np.random.default_rng(params.seed)

    # instance numbering: building, wall, gate features in layer order
    layer_fids = {
        "building": [b.fid for b in _BUILDINGS],
        "wall": [w.fid for w in _WALLS],
        "gate": [g.fid for g in _GATES],
    }
    fids = [fid for name in LAYERS for fid in layer_fids[name]]
    owner_of = {fid: i + 1 for i, fid in enumerate(fids)}
    layer_of = {owner_of[fid]: name for name in LAYERS for fid in layer_fids[name]}

    mesh = _Mesh()
    fp = _build_buildings(mesh, owner_of, rng)
    fp.update(_build_walls(mesh, owner_of))
    fp.update(_build_gates(mesh, owner_of))
    # trees and clutter keep off the pond where the demolished B20 stood (water: no returns)
    obstacles = unary_union([*fp.values(), fp["B20"].buffer(4.5)])
    crowns = _place_trees(rng, obstacles)
    _build_trunks(mesh, crowns)
    _build_clutter(mesh, rng, obstacles)
    digitised = _digitise(fp, params, rng)
    pond = digitised["B20"].buffer(1.0)
    scene = _to_scene(mesh, layer_of, crowns, pond, params, rng)
    res, plan = _survey(scene, params, rng)

    offset, crs = _kasepuhan_world(params)
    layers, objects = _layers(digitised, offset[:2], crs, owner_of, res.instance)
    for name, inst in owner_of.items():
        scene.objects.append(
            {
                "instance": inst,
                "class": layer_of[inst],
                "fid": name,
                "footprint": shapely.to_wkt(fp[name], rounding_precision=3),
            }
        )
    extent = affinity.translate(box(0, 0, *_EXTENT_M), offset[0], offset[1])
    extras = {
        "layers": layers,
        "reference_objects": objects,
        "extent": extent,
        "survey": plan,
        "write_extras": lambda outdir: write_layers(layers, objects, outdir),
    }
    survey = {f"survey_{k}": v for k, v in plan.items()}
    sim_params = {"layout": "kasepuhan", **asdict(params), **survey}
    return Simulation(
        "complex", params.seed, scene, {"cloud": res}, {"cloud": np.eye(4)}, sim_params,
        extras, "EPSG:32749", (float(offset[0]), float(offset[1]), float(offset[2])),
    )  # fmt: skip


def kasepuhan_scene(params: ComplexSceneParams | None = None) -> ComplexScene:
    """Generate the walled complex: cloud, GIS layers and reference labels.

    The layout is built as labelled surfaces and scanned by the airborne
    simulator (:func:`kasepuhan_simulation`, the ``complex`` family's
    ``layout="kasepuhan"`` member; :data:`KASEPUHAN_SURVEY`): walls running
    east-west show both faces, walls running north-south mostly their tops;
    tree crowns give several returns per pulse; the pond gives none.

    Parameters
    ----------
    params
        Density, noise, seed and survey/digitising settings.

    Returns
    -------
    ComplexScene
        Cloud in EPSG:32749 with exactly ``params.n_points`` points (in
        acquisition order: strip by strip, pulse by pulse; attributes
        ``intensity``, ``return_number``, ``number_of_returns``,
        ``point_source_id``, ``gps_time``), the three GIS layers, per-point
        reference object ids (0 = none) and ground mask.

    Examples
    --------
    >>> scene = kasepuhan_scene(ComplexSceneParams(n_points=20_000, seed=1))
    >>> len(scene.cloud), sorted(scene.layers)
    (20000, ['building', 'gate', 'wall'])
    """
    sim = kasepuhan_simulation(params)
    res = sim.clouds["cloud"]
    attributes = {
        "intensity": res.intensity,
        "return_number": res.return_number,
        "number_of_returns": res.number_of_returns,
        "point_source_id": res.point_source_id,
        "gps_time": res.gps_time,
    }
    cloud = PointCloud(
        xyz=res.xyz, offset=np.asarray(sim.offset), crs=pyproj.CRS(sim.crs),
        attributes=attributes, scale=np.full(3, 0.001), source="synthetic:kasepuhan",
    )  # fmt: skip
    ground = res.class_id == sim.scene.class_code("ground")
    layers, objects = sim.extras["layers"], sim.extras["reference_objects"]
    return ComplexScene(cloud, layers, res.instance.astype(np.int32), objects, ground,
                        sim.extras["extent"])  # fmt: skip


def _layers(
    digitised: dict[str, Any],
    offset_xy: NDArray[np.float64],
    crs: pyproj.CRS,
    owner_of: dict[str, int],
    ref_inst: NDArray[np.int32],
) -> tuple[dict[str, gpd.GeoDataFrame], pd.DataFrame]:
    """GeoDataFrames of the digitised features (world coordinates) and the objects table."""

    def world(fid: str) -> Any:
        g = affinity.translate(digitised[fid], offset_xy[0], offset_xy[1])
        return shapely.make_valid(g) if not g.is_valid else g

    rows = {
        "building": [
            {
                "fid": b.fid,
                "name": b.name,
                "function": b.function,
                "period": b.period,
                "roof": "cone" if b.kind == "round" else b.parts[0].roof,
                "open": b.kind in ("pendopo", "round"),
                "status": "demolished" if b.kind == "demolished" else "extant",
                "geometry": world(b.fid),
            }
            for b in _BUILDINGS
        ],
        "wall": [
            {
                "fid": w.fid,
                "name": w.name,
                "function": w.function,
                "period": w.period,
                "material": w.material,
                "height_m": w.height_m,
                "thickness_m": w.thickness_m,
                "geometry": world(w.fid),
            }
            for w in _WALLS
        ],
        "gate": [
            {
                "fid": g.fid,
                "name": g.name,
                "function": g.function,
                "period": g.period,
                "gate_type": g.gate_type,
                "geometry": world(g.fid),
            }
            for g in _GATES
        ],
    }
    layers = {name: gpd.GeoDataFrame(r, geometry="geometry", crs=crs) for name, r in rows.items()}
    counts = np.bincount(ref_inst, minlength=len(owner_of) + 1)
    obj = []
    for name in LAYERS:
        for i, row in layers[name].iterrows():
            inst = owner_of[row["fid"]]
            obj.append(
                {
                    "instance": inst,
                    "layer": name,
                    "fid": row["fid"],
                    "feature_index": int(i),
                    "name": row["name"],
                    "n_points": int(counts[inst]),
                }
            )
    objects = pd.DataFrame(obj).astype({"instance": np.int32})
    return layers, objects


def write_scene(scene: ComplexScene, outdir: str | Path) -> dict[str, Path]:
    """Write a scene: ``cloud.laz``, one GeoPackage per layer, ``reference_objects.csv``.

    ``cloud.laz`` (LAS 1.4, EPSG:32749) carries the extra dimension
    ``reference_instance`` (int32) and ASPRS classification 2 on the reference
    ground (1 elsewhere).  Every file is written atomically.

    Returns
    -------
    dict
        ``{"cloud": ..., "building": ..., "wall": ..., "gate": ..., "objects": ...}``.
    """
    from pyheracles.io import atomic_path, write_cloud

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {}
    classification = np.where(scene.ground, 2, 1).astype(np.uint8)
    cloud = scene.cloud.with_attributes(classification=classification)
    paths["cloud"] = write_cloud(
        cloud, out / "cloud.laz", extra_dims={"reference_instance": scene.reference_instance}
    )
    for name, gdf in scene.layers.items():
        from pyheracles.io.vector import write_gpkg

        # GeoPackage 1.2 (read by GDAL 3.6 without a warning); key "ogc_fid", our ids in "fid"
        paths[name] = write_gpkg(gdf, out / f"{name}.gpkg", layer=name)
    target = out / "reference_objects.csv"
    with atomic_path(target) as tmp:
        scene.reference_objects.to_csv(tmp, index=False)
    paths["objects"] = target
    return paths
