"""Walls of a building cloud: vertical planes, thickness, outlines with openings.

Step 2 (DESIGN.md), after M_HERACLES ``wallSeg``, ``intersectMultPlanes`` and
``meshSnap``.  :func:`segment_walls` finds the vertical planar faces of a cloud
(TLS inside or outside, or a step-1 object), pairs parallel faces a wall
thickness apart into one wall (thickness measured where both faces are seen),
draws each wall's outline on its plane with the openings (windows, doors) as
holes, and joins walls that meet at their plane intersection.

Method
------
1. Detection sample: one point per ``voxel_m`` cube; normals by local PCA
   (k = 16); candidates are points whose normal is within ``max_tilt_deg`` of
   horizontal.
2. Faces: peaks of a histogram of the candidates' (normal azimuth, offset);
   each peak is refitted by least squares (inliers within ``distance_m`` and
   ``normal_angle_deg``), split into connected parts along the plane, and kept
   when at least ``min_length_m`` long, ``min_height_m`` high and
   ``min_area_m2`` in area.
3. Walls: two parallel faces (``parallel_deg``) whose offsets differ by
   ``min_thickness_m`` to ``max_thickness_m`` and which overlap along the
   plane form one wall (mid-plane, thickness = their separation); a face
   alone is a wall seen on one face (thickness NaN, said in ``notes``).
4. Outline: the faces' points on a ``cell_m`` grid of the wall plane
   ``(u, z)``; the envelope spans each column from the wall's foot to its top.
   Empty parts of the envelope are openings when they are large enough and
   the points through them lie in the wall (reveals, glass, doors' leaves) or
   beyond it, rather than in front (an occluder's shadow is not an opening).
   Openings reaching the foot are doors, the others windows.
5. Joins: the ends of walls that meet are moved to the least-squares
   intersection of the planes meeting there (:func:`intersect_planes`,
   ``intersectMultPlanes``) when within ``snap_m`` (vertex snapping,
   ``meshSnap``).

Examples
--------
>>> import numpy as np
>>> from pyheracles.walls import intersect_planes
>>> intersect_planes([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [1.0, 2.0, 3.0]).round(6).tolist()
[1.0, 2.0, 3.0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError
from pyheracles.labels import Segmentation

__all__ = [
    "WALL_CLASS",
    "WALL_CLASS_ID",
    "Opening",
    "Wall",
    "WallFace",
    "WallParams",
    "WallResult",
    "intersect_planes",
    "merge_lights",
    "segment_walls",
]

Array = NDArray[np.float64]

WALL_CLASS = "wall"
WALL_CLASS_ID = 1


@dataclass(frozen=True)
class WallParams:
    """Parameters of :func:`segment_walls` (metres, degrees).

    Attributes
    ----------
    voxel_m
        Detection sample: one point per cube of this size (0.06 m; None = from the
        point spacing, at least 2 cm).
    distance_m
        Largest distance of a face point from its plane (0.03 m).
    normal_angle_deg
        Largest angle between a point's normal and its face's (20 deg).
    max_tilt_deg
        Largest tilt of a wall from the vertical (10 deg).
    min_length_m, min_height_m, min_area_m2
        Smallest face kept (1 m long, 1.5 m high, 2 m2): pews, gravestones and
        window reveals are smaller.
    parallel_deg
        Largest angle between the two faces of one wall (3 deg).
    min_thickness_m, max_thickness_m
        Range of wall thickness for pairing faces (0.08 to 2.0 m).
    cell_m
        Grid of the outline on the wall plane (0.05 m).
    min_opening_m, min_opening_area_m2
        Smallest opening: 0.25 m wide and high, 0.1 m2.
    max_mullion_m
        Lights of one window side by side (or one above the other) separated by
        mullions or transoms up to this width are one opening (the wall's void that
        a window with its tracery fills in a BIM model); 0 (the default) keeps each
        light an opening of its own, as the stone between them is wall.
    snap_m
        Largest move of a wall end to a plane intersection (1.0 m).
    assumed_thickness_m
        Thickness given to a wall seen on one face where a solid is needed
        (IFC export; 0.3 m); never reported as measured.
    """

    voxel_m: float | None = 0.06
    distance_m: float = 0.03
    normal_angle_deg: float = 20.0
    max_tilt_deg: float = 10.0
    min_length_m: float = 1.0
    min_height_m: float = 1.5
    min_area_m2: float = 2.0
    parallel_deg: float = 3.0
    min_thickness_m: float = 0.08
    max_thickness_m: float = 2.0
    cell_m: float = 0.05
    min_opening_m: float = 0.25
    min_opening_area_m2: float = 0.1
    max_mullion_m: float = 0.0
    snap_m: float = 1.0
    assumed_thickness_m: float = 0.3

    def __post_init__(self) -> None:
        positive = ("distance_m", "min_length_m", "min_height_m", "min_area_m2", "cell_m",
                    "min_opening_m", "min_opening_area_m2", "max_thickness_m",
                    "assumed_thickness_m")  # fmt: skip
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number of metres, got {v!r}")
        if self.voxel_m is not None and not (math.isfinite(self.voxel_m) and self.voxel_m > 0):
            raise ValueError(f"voxel_m must be positive or None, got {self.voxel_m!r}")
        for name in ("normal_angle_deg", "max_tilt_deg", "parallel_deg"):
            v = getattr(self, name)
            if not (0 < v < 90):
                raise ValueError(f"{name} must be between 0 and 90 degrees, got {v!r}")
        if not 0 <= self.min_thickness_m < self.max_thickness_m:
            raise ValueError("min_thickness_m must be >= 0 and below max_thickness_m")
        if self.snap_m < 0:
            raise ValueError(f"snap_m must be >= 0, got {self.snap_m!r}")
        if not (math.isfinite(self.max_mullion_m) and self.max_mullion_m >= 0):
            raise ValueError(f"max_mullion_m must be >= 0, got {self.max_mullion_m!r}")


@dataclass(frozen=True)
class WallFace:
    """One fitted face: unit ``normal`` (horizontal-ish), offset ``d`` (n . x = d, local
    frame), its points (indices into the input), RMS distance (m)."""

    normal: Array
    d: float
    indices: NDArray[np.int64]
    rms_m: float


@dataclass(frozen=True)
class Opening:
    """An opening of a wall, in the wall's ``(u, z)`` plane coordinates (metres).

    ``kind`` is ``"door"`` (reaches the wall's foot) or ``"window"``; ``polygon`` is
    its outline ``(K, 2)``; ``width_m``/``height_m`` its bounding box; ``n_lights``
    the lights it was merged from (see :func:`merge_lights`).
    """

    kind: str
    u_min: float
    u_max: float
    z_min: float
    z_max: float
    polygon: Array
    n_lights: int = 1

    @property
    def width_m(self) -> float:
        return self.u_max - self.u_min

    @property
    def height_m(self) -> float:
        return self.z_max - self.z_min


@dataclass(frozen=True)
class Wall:
    """A wall: its plane, faces, thickness, outline and openings.

    The plane (``normal``, ``d``; local frame) is the mid-plane of two faces or
    the face itself; ``origin`` + ``u_axis`` span it with z up; ``outline`` is the
    envelope ``(K, 2)`` in ``(u, z)``; ``thickness_m`` is NaN when one face was seen,
    and ``material_side`` (+1 / -1 along ``normal``) says on which side of a lone
    face the wall lies (0 unknown).
    """

    instance: int
    normal: Array
    d: float
    origin: Array
    u_axis: Array
    faces: tuple[WallFace, ...]
    thickness_m: float
    outline: Array
    openings: tuple[Opening, ...]
    u_range: tuple[float, float]
    z_range: tuple[float, float]
    rms_m: float
    n_points: int
    material_side: int = 0
    joined: tuple[str, ...] = ()

    @property
    def length_m(self) -> float:
        return self.u_range[1] - self.u_range[0]

    @property
    def height_m(self) -> float:
        return self.z_range[1] - self.z_range[0]

    def to_3d(self, uz: ArrayLike, depth: float = 0.0) -> Array:
        """Points ``(K, 2)`` of the plane's ``(u, z)`` in 3D (local frame), ``depth``
        along ``normal``."""
        q = np.asarray(uz, dtype=np.float64).reshape(-1, 2)
        return (self.origin + q[:, :1] * self.u_axis + q[:, 1:] * np.array([0.0, 0.0, 1.0])
                + depth * self.normal)  # fmt: skip


@dataclass(frozen=True)
class WallResult:
    """Result of :func:`segment_walls`: per-point ``labels`` (wall instance, 0 = none),
    the walls, notes (bad input said in words) and the parameters used."""

    labels: NDArray[np.int32]
    walls: tuple[Wall, ...]
    params: WallParams
    notes: tuple[str, ...] = ()
    timings: dict[str, float] = field(default_factory=dict)

    def objects_table(self, offset: ArrayLike | None = None) -> pd.DataFrame:
        """One row per wall (world frame with ``offset``): plane, thickness, size, openings."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        rows = []
        for w in self.walls:
            centre = w.to_3d([[0.5 * sum(w.u_range), 0.5 * sum(w.z_range)]])[0] + off
            rows.append({
                "instance": w.instance, "class": WALL_CLASS, "n_points": w.n_points,
                "n_faces": len(w.faces),
                "normal_x": w.normal[0], "normal_y": w.normal[1], "normal_z": w.normal[2],
                "d": w.d + float(w.normal @ off),
                "thickness_m": w.thickness_m, "length_m": w.length_m, "height_m": w.height_m,
                "n_openings": len(w.openings),
                "n_windows": sum(o.kind == "window" for o in w.openings),
                "n_doors": sum(o.kind == "door" for o in w.openings),
                "fit_rms_m": w.rms_m,
                "x": centre[0], "y": centre[1], "z_min": w.z_range[0] + off[2],
                "z_max": w.z_range[1] + off[2],
            })  # fmt: skip
        cols = ["instance", "class", "n_points", "n_faces", "normal_x", "normal_y", "normal_z",
                "d", "thickness_m", "length_m", "height_m", "n_openings", "n_windows",
                "n_doors", "fit_rms_m", "x", "y", "z_min", "z_max"]  # fmt: skip
        return pd.DataFrame(rows, columns=cols)

    def to_segmentation(self, offset: ArrayLike | None = None) -> Segmentation:
        """The result as a :class:`~pyheracles.labels.Segmentation` (class ``wall``)."""
        return Segmentation(
            instance=self.labels,
            class_id=np.where(self.labels > 0, WALL_CLASS_ID, 0).astype(np.uint8),
            classes={WALL_CLASS_ID: WALL_CLASS},
            objects=self.objects_table(offset),
            warnings=self.notes,
        )

    def to_json(self, offset: ArrayLike | None = None) -> dict[str, Any]:
        """Walls with faces, frames, outlines and openings, world frame (``walls.json``)."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        walls = []
        for w in self.walls:
            walls.append({
                "instance": w.instance,
                "normal": w.normal.tolist(), "d": w.d + float(w.normal @ off),
                "origin": (w.origin + off).tolist(), "u_axis": w.u_axis.tolist(),
                "thickness_m": None if math.isnan(w.thickness_m) else w.thickness_m,
                "thickness_measured": not math.isnan(w.thickness_m),
                "material_side": w.material_side,
                "assumed_thickness_m": self.params.assumed_thickness_m,
                "length_m": w.length_m, "height_m": w.height_m,
                "u_range": list(w.u_range), "z_range": [w.z_range[0] + off[2],
                                                        w.z_range[1] + off[2]],
                "fit_rms_m": w.rms_m, "n_points": w.n_points,
                "faces": [{"normal": f.normal.tolist(), "d": f.d + float(f.normal @ off),
                           "n_points": len(f.indices), "rms_m": f.rms_m} for f in w.faces],
                "outline_uz": (w.outline + [0.0, off[2]]).tolist(),
                "outline_xyz": (w.to_3d(w.outline) + off).tolist(),
                "openings": [{"kind": o.kind, "u_min": o.u_min, "u_max": o.u_max,
                              "z_min": o.z_min + off[2], "z_max": o.z_max + off[2],
                              "width_m": o.width_m, "height_m": o.height_m,
                              "n_lights": o.n_lights,
                              "polygon_uz": (o.polygon + [0.0, off[2]]).tolist()}
                             for o in w.openings],
                "joined": list(w.joined),
            })  # fmt: skip
        return {"walls": walls, "notes": list(self.notes)}


def intersect_planes(normals: ArrayLike, ds: ArrayLike) -> Array:
    """Least-squares intersection point of planes ``n_i . x = d_i`` (``intersectMultPlanes``).

    Minimum-norm solution when the planes do not fix a point (two planes: the point of
    their line nearest the origin; vertical planes only: z = 0).
    """
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(ds, dtype=np.float64).reshape(-1)
    if len(n) != len(d) or len(n) < 1:
        raise InputError("intersect_planes needs as many offsets as normals (at least one)")
    x, *_ = np.linalg.lstsq(n, d, rcond=None)
    return x


# ---------------------------------------------------------------------------- helpers


def _voxel_sample(xyz: Array, size: float) -> NDArray[np.int64]:
    """Index of one point per occupied cube (the first in input order)."""
    key = np.floor((xyz - xyz.min(axis=0)) / size).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)


def _fit_vertical(p: Array) -> tuple[Array, float, float]:
    """Plane of points by least squares (3D PCA); normal with a deterministic sign."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    n = vt[-1]
    big = int(np.argmax(np.abs(n[:2])))
    if n[big] < 0:
        n = -n
    res = (p - c) @ n
    return n, float(n @ c), float(np.sqrt(np.mean(res**2)))


def _frame(n: Array, d: float) -> tuple[Array, Array]:
    """Origin on the plane (above the local origin) and the horizontal in-plane axis."""
    h = np.array([n[0], n[1], 0.0])
    h /= np.linalg.norm(h)
    u = np.array([-h[1], h[0], 0.0])
    origin = h * d / max(float(n @ h), 1e-9)
    return origin, u


def _components(mask: NDArray[np.bool_], grow: int) -> tuple[NDArray[np.int32], int]:
    from scipy import ndimage

    m = ndimage.binary_dilation(mask, iterations=grow) if grow else mask
    lab, k = ndimage.label(m)
    lab[~mask] = 0
    return lab, k


def _find_faces(
    xyz: Array, sample: NDArray[np.int64], normals: Array, p: WallParams
) -> list[tuple[Array, float, NDArray[np.int64]]]:
    """Faces on the sample: (normal, d, sample-point indices into ``xyz``)."""
    nz_max = math.sin(math.radians(p.max_tilt_deg))
    cand = np.flatnonzero(np.abs(normals[:, 2]) <= nz_max)
    if len(cand) < 3:
        return []
    pts = xyz[sample[cand]]
    nrm = normals[cand]
    theta = np.mod(np.arctan2(nrm[:, 1], nrm[:, 0]), np.pi)
    h = np.c_[np.cos(theta), np.sin(theta)]
    off = np.einsum("ij,ij->i", pts[:, :2], h)
    alive = np.ones(len(cand), dtype=bool)
    cos_n = math.cos(math.radians(p.normal_angle_deg))
    spacing = p.voxel_m or 0.06
    min_pts = max(30, int(0.25 * p.min_area_m2 / spacing**2))
    faces: list[tuple[Array, float, NDArray[np.int64]]] = []
    dbin = 2 * p.distance_m
    lo, hi = off.min() - dbin, off.max() + dbin
    abins = np.linspace(0, np.pi, 181)
    dbins = np.arange(lo, hi + dbin, dbin)
    for _ in range(200):
        idx = np.flatnonzero(alive)
        if len(idx) < min_pts:
            break
        hist, _, _ = np.histogram2d(theta[idx], off[idx], bins=(abins, dbins))
        # neighbouring bins together (azimuth wraps at 180 deg)
        from scipy import ndimage

        smooth = ndimage.uniform_filter(hist, size=3, mode=("wrap", "constant")) * 9
        a, b = np.unravel_index(int(np.argmax(smooth)), smooth.shape)
        if smooth[a, b] < min_pts:
            break
        t0 = 0.5 * (abins[a] + abins[a + 1])
        d0 = 0.5 * (dbins[b] + dbins[b + 1])
        dt = np.abs(np.angle(np.exp(2j * (theta[idx] - t0)))) / 2
        seed = idx[(dt <= math.radians(2.0)) & (np.abs(off[idx] - d0) <= 1.5 * dbin)]
        # the bin may sit across the wrap at 0/180 deg: flip the offsets of the far side
        if len(seed) < 3:
            alive[idx[(dt <= math.radians(1.0)) & (np.abs(off[idx] - d0) <= dbin)]] = False
            continue
        n, d, _ = _fit_vertical(pts[seed])
        inl = seed
        for _ in range(3):
            dist = np.abs(pts[idx] @ n - d)
            ok = (dist <= p.distance_m) & (np.abs(nrm[idx] @ n) >= cos_n)
            inl = idx[ok]
            if len(inl) < 3:
                break
            n, d, _ = _fit_vertical(pts[inl])
        alive[seed] = False
        if len(inl) < min_pts:
            continue
        alive[inl] = False
        if abs(n[2]) > nz_max:
            continue
        # split into connected parts along the plane
        origin, u = _frame(n, d)
        q = pts[inl] - origin
        uz = np.c_[q @ u, q[:, 2]]
        cell = 0.2
        ij = np.floor((uz - uz.min(axis=0)) / cell).astype(np.int64)
        grid = np.zeros(ij.max(axis=0) + 1, dtype=bool)
        grid[ij[:, 0], ij[:, 1]] = True
        lab, k = _components(grid, 2)
        plab = lab[ij[:, 0], ij[:, 1]]
        for c in range(1, k + 1):
            part = inl[plab == c]
            if len(part) < min_pts:
                continue
            puz = uz[plab == c]
            length, height = np.ptp(puz[:, 0]), np.ptp(puz[:, 1])
            comp = lab == c
            area = np.count_nonzero(comp) * cell**2
            if length < p.min_length_m or height < p.min_height_m or area < p.min_area_m2:
                continue
            # a wall is solid over most of its length: rows of pew ends, railings are not
            col_h = comp.sum(axis=1)[comp.any(axis=1)] * cell
            if np.mean(col_h >= p.min_height_m) < 0.5:
                continue
            faces.append((n, d, sample[cand[part]]))
    return faces


def _face_points(
    xyz: Array, n: Array, d: float, seeds: NDArray[np.int64], p: WallParams
) -> NDArray[np.int64]:
    """All input points of a face: near its plane and within its seeds' footprint."""
    origin, u = _frame(n, d)
    sq = xyz[seeds] - origin
    suz = np.c_[sq @ u, sq[:, 2]]
    lo = suz.min(axis=0) - p.cell_m
    hi = suz.max(axis=0) + p.cell_m
    box = np.all((xyz >= np.minimum(xyz[seeds].min(axis=0), xyz[seeds].max(axis=0))
                  - p.distance_m - 0.1), axis=1)  # fmt: skip
    box &= np.all(xyz <= xyz[seeds].max(axis=0) + p.distance_m + 0.1, axis=1)
    idx = np.flatnonzero(box)
    idx = idx[np.abs(xyz[idx] @ n - d) <= p.distance_m]
    q = xyz[idx] - origin
    uz = np.c_[q @ u, q[:, 2]]
    inside = np.all((uz >= lo) & (uz <= hi), axis=1)
    idx, uz = idx[inside], uz[inside]
    cell = max(2 * (p.voxel_m or 0.06), p.cell_m)
    ij = np.floor((suz - lo) / cell).astype(np.int64)
    shape = np.floor((hi - lo) / cell).astype(np.int64) + 2
    from scipy import ndimage

    grid = np.zeros(shape, dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    grid = ndimage.binary_dilation(grid, iterations=1)
    pij = np.clip(np.floor((uz - lo) / cell).astype(np.int64), 0, shape - 1)
    return idx[grid[pij[:, 0], pij[:, 1]]]


def _pair_faces(xyz: Array, faces: list[WallFace], p: WallParams) -> list[tuple[int, ...]]:
    """Groups of face indices: pairs forming one wall, singles."""
    cos_par = math.cos(math.radians(p.parallel_deg))
    cands = []
    for i in range(len(faces)):
        for j in range(i + 1, len(faces)):
            fi, fj = faces[i], faces[j]
            c = float(fi.normal @ fj.normal)
            if abs(c) < cos_par:
                continue
            s = math.copysign(1.0, c)
            sep = abs(fi.d - s * fj.d)
            if not p.min_thickness_m <= sep <= p.max_thickness_m:
                continue
            _, u = _frame(fi.normal, fi.d)
            ui, uj = xyz[fi.indices] @ u, xyz[fj.indices] @ u
            zi, zj = xyz[fi.indices, 2], xyz[fj.indices, 2]
            ov_u = min(ui.max(), uj.max()) - max(ui.min(), uj.min())
            ov_z = min(zi.max(), zj.max()) - max(zi.min(), zj.min())
            short_u = min(np.ptp(ui), np.ptp(uj))
            short_z = min(np.ptp(zi), np.ptp(zj))
            if ov_u < 0.3 * short_u or ov_z < 0.3 * short_z:
                continue
            cands.append((sep, i, j))
    # a face between two faces of one wall is inside it (glass, door leaves): no wall face
    inner: set[int] = set()
    for _, i, j in cands:
        for _, k, m in cands:
            shared = {i, j} & {k, m}
            if len(shared) != 1:
                continue
            mid = shared.pop()
            a, b = ({i, j} - {mid}).pop(), ({k, m} - {mid}).pop()
            if a == b:
                continue
            n = faces[mid].normal
            da = faces[a].d * math.copysign(1.0, float(n @ faces[a].normal)) - faces[mid].d
            db = faces[b].d * math.copysign(1.0, float(n @ faces[b].normal)) - faces[mid].d
            if da * db < 0 and abs(da - db) <= p.max_thickness_m:
                inner.add(mid)
    cands = [c for c in cands if c[1] not in inner and c[2] not in inner]
    used: set[int] = set(inner)
    groups: list[tuple[int, ...]] = []
    for _, i, j in sorted(cands):
        if i in used or j in used:
            continue
        used |= {i, j}
        groups.append((i, j))
    groups += [(i,) for i in range(len(faces)) if i not in used]
    return groups


def _material_side(xyz: Array, tree: Any, face: WallFace, p: WallParams) -> int:
    """Side (+1/-1 along the face normal) where the wall's material lies, for a lone face:
    the floor or ground runs up to the foot of a face on the seen side only."""
    pts = xyz[face.indices]
    z0 = np.percentile(pts[:, 2], 1)
    foot = pts[pts[:, 2] <= z0 + 0.3]
    if len(foot) > 400:
        foot = foot[np.linspace(0, len(foot) - 1, 400).astype(np.int64)]
    counts = []
    for s in (1.0, -1.0):
        probe = foot + s * 0.25 * face.normal
        probe[:, 2] = z0
        counts.append(sum(len(v) for v in tree.query_ball_point(probe, 0.12)))
    if counts[0] == counts[1]:
        return 0
    return -1 if counts[0] > counts[1] else 1  # material away from the floor


def _outline(w_uz: Array, depth_all: Array, uz_all: Array, near: NDArray[np.bool_],
             behind: NDArray[np.bool_], front: NDArray[np.bool_],
             p: WallParams) -> tuple[Array, list[Opening], tuple[float, float],
                                     tuple[float, float]]:  # fmt: skip
    """Envelope and openings of one wall from its face points ``w_uz`` (``(u, z)``)."""
    from scipy import ndimage

    c = p.cell_m
    lo = w_uz.min(axis=0)
    ij = np.floor((w_uz - lo) / c).astype(np.int64)
    shape = ij.max(axis=0) + 1
    occ = np.zeros(shape, dtype=bool)
    occ[ij[:, 0], ij[:, 1]] = True
    occ = ndimage.binary_closing(occ, iterations=1, border_value=0) | occ
    cols = np.flatnonzero(occ.any(axis=1))
    nu = shape[0]
    top = np.full(nu, -1)
    bot = np.full(nu, shape[1])
    for arr, fn in ((top, np.max), (bot, np.min)):
        rows = np.where(occ, np.arange(shape[1])[None, :], -1 if fn is np.max else shape[1])
        arr[:] = fn(rows, axis=1)
    keep = np.zeros(nu, dtype=bool)
    keep[cols.min() : cols.max() + 1] = True
    have = occ.any(axis=1)
    idx = np.arange(nu)
    top = np.interp(idx, idx[have], top[have]).round().astype(int)
    bot = np.interp(idx, idx[have], bot[have]).round().astype(int)
    win = max(3, round(2.5 / c))
    bot = ndimage.minimum_filter1d(bot, win, mode="nearest")
    top = ndimage.maximum_filter1d(top, max(1, round(0.3 / c)), mode="nearest")
    rows = np.arange(shape[1])[None, :]
    env = keep[:, None] & (rows >= bot[:, None]) & (rows <= top[:, None])
    holes = env & ~occ
    lab, k = ndimage.label(holes)
    openings: list[Opening] = []
    if k:
        # points through the wall plane, on the grid
        pij = np.floor((uz_all - lo) / c).astype(np.int64)
        inside = np.all((pij >= 0) & (pij < shape), axis=1)
        slices = ndimage.find_objects(lab)
        for m, sl in enumerate(slices, start=1):
            if sl is None:
                continue
            region = lab[sl] == m
            w = (sl[0].stop - sl[0].start) * c
            h = (sl[1].stop - sl[1].start) * c
            if w < p.min_opening_m or h < p.min_opening_m:
                continue
            if region.sum() * c * c < p.min_opening_area_m2:
                continue
            if sl[0].start == 0 or sl[0].stop == nu or sl[1].stop >= shape[1]:
                continue  # open to the wall's end or top: not enclosed
            at_foot = bool(np.any(sl[1].start <= bot[sl[0]] + 1))
            grown = ndimage.binary_dilation(lab == m, iterations=1)
            z_lo = sl[1].start + (2 if at_foot else 0)
            sel = np.zeros(len(uz_all), dtype=bool)
            sel[inside] = grown[pij[inside, 0], pij[inside, 1]] & (pij[inside, 1] >= z_lo)
            n_behind = int(np.count_nonzero(sel & behind & near))
            n_front = int(np.count_nonzero(sel & front & near))
            if n_behind < 3 or n_behind < 0.5 * n_front:
                continue  # a shadow: what is seen through it stands in front of the wall
            u0, u1 = lo[0] + sl[0].start * c, lo[0] + sl[0].stop * c
            z0, z1 = lo[1] + sl[1].start * c, lo[1] + sl[1].stop * c
            # the jambs: rows where the hole is (nearly) at its full width, below any
            # round or pointed head (refining the sides in the head narrowed such windows)
            # (doors keep their upper part: shadows merged at the foot widen them)
            widths = region.sum(axis=0)
            full = np.flatnonzero(widths >= widths.max() - 1)
            jambs = None if at_foot else (lo[1] + (sl[1].start + full.min()) * c,
                                          lo[1] + (sl[1].start + full.max() + 1) * c)
            u0, u1, z0, z1 = _refine_edges(w_uz, u0, u1, z0, z1, c, at_foot, jambs)
            poly = _mask_polygon(region, lo + np.array([sl[0].start, sl[1].start]) * c, c)
            openings.append(Opening("door" if at_foot else "window", float(u0), float(u1),
                                    float(z0), float(z1), poly))  # fmt: skip
    openings = merge_lights(openings, p.max_mullion_m)
    a, b = int(cols.min()), int(cols.max()) + 1
    us = lo[0] + np.arange(a, b + 1) * c
    tz = lo[1] + (top[np.r_[a:b, b - 1]] + 1) * c
    bz = lo[1] + bot[np.r_[a:b, b - 1]] * c
    outline = np.r_[np.c_[us, bz], np.c_[us[::-1], tz[::-1]]]
    outline = _simplify(outline, c)
    return outline, openings, (float(us[0]), float(us[-1])), (float(bz.min()), float(tz.max()))


def merge_lights(openings: list[Opening], max_mullion_m: float,
                 min_overlap: float = 0.6) -> list[Opening]:  # fmt: skip
    """Openings separated by a mullion or transom no wider than ``max_mullion_m``, as one.

    Two windows merge when the gap between their boxes along one axis is at most
    ``max_mullion_m`` and they overlap along the other by ``min_overlap`` of the
    smaller one (lights of one window share their sill and springing).  The merged
    outline is the union of the lights closed over the gap (the mullions belong to
    the window).  Doors are left alone.
    """
    import shapely

    wins = [o for o in openings if o.kind == "window"]
    rest = [o for o in openings if o.kind != "window"]
    if max_mullion_m <= 0 or len(wins) < 2:
        return openings
    parent = list(range(len(wins)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def overlap(a0: float, a1: float, b0: float, b1: float) -> float:
        return max(0.0, min(a1, b1) - max(a0, b0)) / max(min(a1 - a0, b1 - b0), 1e-9)

    for i, a in enumerate(wins):
        for j in range(i + 1, len(wins)):
            b = wins[j]
            gap_u = max(a.u_min, b.u_min) - min(a.u_max, b.u_max)
            gap_z = max(a.z_min, b.z_min) - min(a.z_max, b.z_max)
            side = 0 <= gap_u <= max_mullion_m and overlap(a.z_min, a.z_max, b.z_min,
                                                            b.z_max) >= min_overlap
            stacked = 0 <= gap_z <= max_mullion_m and overlap(a.u_min, a.u_max, b.u_min,
                                                               b.u_max) >= min_overlap
            if side or stacked:
                parent[root(j)] = root(i)
    groups: dict[int, list[Opening]] = {}
    for i, o in enumerate(wins):
        groups.setdefault(root(i), []).append(o)
    merged = []
    for g in groups.values():
        if len(g) == 1:
            merged.append(g[0])
            continue
        half = max_mullion_m / 2 + 1e-3
        union = shapely.union_all([shapely.Polygon(o.polygon).buffer(0) for o in g])
        closed = union.buffer(half, join_style="mitre").buffer(-half, join_style="mitre")
        if closed.geom_type != "Polygon":  # not bridged: the boxes' hull
            closed = shapely.convex_hull(union)
        ring = np.asarray(closed.exterior.coords)[:-1]
        merged.append(Opening("window", min(o.u_min for o in g), max(o.u_max for o in g),
                              min(o.z_min for o in g), max(o.z_max for o in g), ring,
                              sum(o.n_lights for o in g)))  # fmt: skip
    return sorted([*merged, *rest], key=lambda o: (o.u_min, o.z_min))


def _refine_edges(
    uz: Array, u0: float, u1: float, z0: float, z1: float, c: float, at_foot: bool,
    jambs: tuple[float, float] | None = None,
) -> tuple[float, float, float, float]:
    """Edges of an opening from the face points around it (finer than the grid): the
    nearest face points left and right of its centre along its jambs (``jambs``: the
    heights where it has its full width; default its upper part), and above and below
    its centre line (shadows merged at a door's foot do not widen it)."""
    h = z1 - z0
    uc = 0.5 * (u0 + u1)
    lo_z = z1 - 0.45 * h if at_foot else z0 + 0.25 * h
    hi_z = z1 - 0.1 * h
    if jambs is not None:
        lo_z = max(lo_z, jambs[0]) if at_foot else max(z0 + 0.05 * h, jambs[0])
        hi_z = min(hi_z, jambs[1])
        if hi_z - lo_z < 2 * c:  # too short a band: the grid edges stand
            return u0, u1, *_refine_z(uz, u0, u1, z0, z1, c, at_foot)
    band_z = (uz[:, 1] > lo_z) & (uz[:, 1] < hi_z)
    left = uz[band_z & (uz[:, 0] < uc) & (uz[:, 0] > u0 - 2 * c)]
    right = uz[band_z & (uz[:, 0] > uc) & (uz[:, 0] < u1 + 2 * c)]
    if len(left) >= 5 and len(right) >= 5:
        if jambs is None:
            u0, u1 = float(np.percentile(left[:, 0], 99.5)), float(np.percentile(right[:, 0], 0.5))
        else:  # per row of the band the innermost point, then the median over the rows
            u0, u1 = _row_median(left, c, np.maximum), _row_median(right, c, np.minimum)
    return u0, u1, *_refine_z(uz, u0, u1, z0, z1, c, at_foot)


def _row_median(uz: Array, c: float, innermost: np.ufunc) -> float:
    """Median over rows of height ``c`` of the innermost ``u`` of each row."""
    rows = np.floor(uz[:, 1] / c).astype(np.int64)
    order = np.argsort(rows, kind="stable")
    r, u = rows[order], uz[order, 0]
    starts = np.flatnonzero(np.r_[True, np.diff(r) != 0])
    return float(np.median(innermost.reduceat(u, starts)))


def _refine_z(
    uz: Array, u0: float, u1: float, z0: float, z1: float, c: float, at_foot: bool
) -> tuple[float, float]:
    """Head and sill of an opening from the face points above and below its centre."""
    uc, zc, w = 0.5 * (u0 + u1), 0.5 * (z0 + z1), u1 - u0
    band_u = np.abs(uz[:, 0] - uc) < max(0.05 * w, c)
    above = uz[band_u & (uz[:, 1] > zc) & (uz[:, 1] < z1 + 2 * c), 1]
    below = uz[band_u & (uz[:, 1] < zc) & (uz[:, 1] > z0 - 2 * c), 1]
    if len(above) >= 3:
        z1 = float(np.percentile(above, 0.5))
    if not at_foot and len(below) >= 3:
        z0 = float(np.percentile(below, 99.5))
    return z0, z1


def _simplify(ring: Array, tol: float) -> Array:
    import shapely

    poly = shapely.Polygon(ring).buffer(0)
    if poly.geom_type != "Polygon":
        poly = max(poly.geoms, key=lambda g: g.area)
    poly = poly.simplify(tol, preserve_topology=True)
    return np.asarray(poly.exterior.coords)[:-1]


def _mask_polygon(region: NDArray[np.bool_], origin: Array, c: float) -> Array:
    """Outline ``(K, 2)`` of a boolean grid region (cells of size ``c`` from ``origin``)."""
    import rasterio.features
    import shapely

    shapes = [shapely.geometry.shape(g) for g, v in
              rasterio.features.shapes(region.T.astype(np.uint8), mask=region.T) if v]  # fmt: skip
    poly = max(shapes, key=lambda g: g.area).simplify(0.5, preserve_topology=True)
    return np.asarray(poly.exterior.coords)[:-1] * c + origin


def _join(walls: list[dict[str, Any]], p: WallParams) -> None:
    """Move wall ends to the least-squares intersection of the planes meeting there."""
    if p.snap_m <= 0:
        return
    ends = []  # (wall, side, xy)
    for k, w in enumerate(walls):
        for side, u in ((0, w["u_range"][0]), (1, w["u_range"][1])):
            ends.append((k, side, (w["origin"] + u * w["u_axis"])[:2]))
    for k, side, xy in ends:
        w = walls[k]
        partners = []
        for m, v in enumerate(walls):
            if m == k or abs(float(v["normal"][:2] @ w["normal"][:2])) > math.cos(math.radians(30)):
                continue
            corner = intersect_planes([w["normal"], v["normal"]], [w["d"], v["d"]])[:2]
            uv = float((np.r_[corner, 0.0] - v["origin"]) @ v["u_axis"])
            near_v = v["u_range"][0] - p.snap_m <= uv <= v["u_range"][1] + p.snap_m
            if np.hypot(*(corner - xy)) <= p.snap_m + 0.5 * w["thick"] and near_v:
                partners.append(m)
        if not partners:
            continue
        planes = [walls[m] for m in [k, *partners]]
        corner = intersect_planes([q["normal"] for q in planes], [q["d"] for q in planes])
        uc = float((np.r_[corner[:2], 0.0] - w["origin"]) @ w["u_axis"])
        w["ends"][side] = uc
        w["joined"].extend(f"instance {m + 1}" for m in partners)


def _snap_outline(outline: Array, old: tuple[float, float], new: list[float], tol: float) -> Array:
    """Vertices within ``tol`` of an old end move to the new end (``meshSnap``)."""
    out = outline.copy()
    for o, n in zip(old, new, strict=True):
        close = np.abs(out[:, 0] - o) <= tol
        out[close, 0] = n
    return out


# ---------------------------------------------------------------------------- driver


def segment_walls(xyz: ArrayLike, params: WallParams | None = None) -> WallResult:
    """Walls of a building cloud: planes, thickness, outlines with openings, labels.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres, local frame (z up).
    params
        :class:`WallParams`; defaults when omitted.

    Returns
    -------
    WallResult
        Per-point wall labels (0 = not in a wall) and one :class:`Wall` per wall.
        No vertical plane gives no walls and a note, never an error; a wall seen
        on one face has ``thickness_m`` NaN and a note.

    Raises
    ------
    InputError
        Not an ``(N, 3)`` finite array.
    """
    import time

    from scipy.spatial import cKDTree

    from pyheracles.geometry.neighbours import local_pca

    p = params or WallParams()
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"walls need (N, 3) coordinates, got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError("walls: the cloud has NaN or infinite coordinates")
    n = len(pts)
    labels = np.zeros(n, dtype=np.int32)
    timings: dict[str, float] = {}
    notes: list[str] = []
    if n < 50:
        notes.append(f"no walls: {n} points are too few for a wall plane")
        return WallResult(labels, (), p, tuple(notes), timings)
    t = time.perf_counter()
    voxel = p.voxel_m
    if voxel is None:
        from pyheracles.geometry.neighbours import point_spacing

        voxel = max(0.02, 2.0 * float(point_spacing(pts)))
    sample = _voxel_sample(pts, voxel)
    if len(sample) < 50:
        notes.append("no walls: too few points after thinning for a wall plane")
        return WallResult(labels, (), p, tuple(notes), timings)
    pca = local_pca(pts[sample], k=16, directions=False)
    timings["normals"] = time.perf_counter() - t
    t = time.perf_counter()
    found = _find_faces(pts, sample, pca.normals, p)
    timings["faces"] = time.perf_counter() - t
    if not found:
        notes.append(
            "no walls: no vertical plane at least "
            f"{p.min_length_m:g} m long and {p.min_height_m:g} m high in the cloud"
        )
        return WallResult(labels, (), p, tuple(notes), timings)
    t = time.perf_counter()
    faces: list[WallFace] = []
    taken = np.zeros(n, dtype=bool)
    for nrm, d, seeds in found:
        idx = _face_points(pts, nrm, d, seeds, p)
        idx = idx[~taken[idx]]
        if len(idx) < 3:
            continue
        nrm2, d2, rms = _fit_vertical(pts[idx])
        taken[idx] = True
        faces.append(WallFace(nrm2, d2, idx, rms))
    timings["face_points"] = time.perf_counter() - t
    t = time.perf_counter()
    groups = _pair_faces(pts, faces, p)
    tree = cKDTree(pts[sample])
    sample_pts = pts[sample]
    drafts: list[dict[str, Any]] = []
    for g in groups:
        fs = [faces[i] for i in g]
        nrm = fs[0].normal
        if len(fs) == 2:
            s = math.copysign(1.0, float(nrm @ fs[1].normal))
            d_mid = 0.5 * (fs[0].d + s * fs[1].d)
            thick = abs(fs[0].d - s * fs[1].d)
            side = 0
        else:
            d_mid, thick = fs[0].d, float("nan")
            side = _material_side(pts, tree, fs[0], p)
        origin, u = _frame(nrm, d_mid)
        drafts.append({"faces": fs, "normal": nrm, "d": d_mid, "thick": 0.0 if len(fs) == 1
                       else thick, "thickness": thick, "origin": origin, "u_axis": u,
                       "side": side, "joined": []})  # fmt: skip
    # outlines and openings
    for w in drafts:
        idx = np.concatenate([f.indices for f in w["faces"]])
        q = pts[idx] - w["origin"]
        w_uz = np.c_[q @ w["u_axis"], q[:, 2]]
        qa = sample_pts - w["origin"]
        depth = qa @ w["normal"]
        uz_all = np.c_[qa @ w["u_axis"], qa[:, 2]]
        if len(w["faces"]) == 2:
            half = 0.5 * w["thickness"]
            behind = np.abs(depth) < half - p.distance_m
            front = (np.abs(depth) > half + p.distance_m) & (np.abs(depth) < half + 1.0)
        else:
            s = w["side"] or 1
            behind = (s * depth > p.distance_m) & (s * depth < 1.5)
            front = (-s * depth > p.distance_m) & (-s * depth < 1.5)
            if w["side"] == 0:  # unknown side: anything through the hole counts
                behind = behind | front
        near = np.abs(depth) < 1.5 + (0 if np.isnan(w["thickness"]) else w["thickness"])
        outline, openings, ur, zr = _outline(w_uz, depth, uz_all, near, behind, front, p)
        w.update(outline=outline, openings=openings, u_range=ur, z_range=zr, idx=idx,
                 ends=list(ur))  # fmt: skip
    timings["outlines"] = time.perf_counter() - t
    t = time.perf_counter()
    _join(drafts, p)
    walls: list[Wall] = []
    for k, w in enumerate(drafts, start=1):
        outline = _snap_outline(w["outline"], w["u_range"], w["ends"], 1.5 * p.cell_m)
        labels[w["idx"]] = k
        rms = float(np.sqrt(np.mean([f.rms_m**2 for f in w["faces"]])))
        walls.append(Wall(
            instance=k, normal=w["normal"], d=float(w["d"]), origin=w["origin"],
            u_axis=w["u_axis"], faces=tuple(w["faces"]), thickness_m=float(w["thickness"]),
            outline=outline, openings=tuple(w["openings"]),
            u_range=(float(min(w["ends"])), float(max(w["ends"]))), z_range=w["z_range"],
            rms_m=rms, n_points=len(w["idx"]), material_side=int(w["side"]),
            joined=tuple(dict.fromkeys(w["joined"])),
        ))  # fmt: skip
        if len(w["faces"]) == 1:
            notes.append(
                f"wall {k}: seen on one face only; thickness not measured"
                + ("" if w["side"] else "; side of the wall unknown")
            )
    timings["walls"] = time.perf_counter() - t
    return WallResult(labels, tuple(walls), p, tuple(notes), timings)
