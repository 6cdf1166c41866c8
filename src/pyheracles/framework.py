"""Step 2b: beams of timber roof frameworks, each with a fitted cuboid.

Thesis chapter 6.3 (Murtiyoso 2020; MATLAB ``regiongrowingnormals``,
``axedetect``, ``beamSeg``).  The pipeline reads top-down:

1. :func:`~pyheracles.segment.regiongrow.region_growing` cuts the cloud into
   smooth planar *facets* (the faces of the beams; coplanar faces of beams
   meeting in a joint come out as one L-, T-, X- or Y-shaped facet);
2. :func:`split_facet` cuts every facet into *straight facets*: bands of
   constant width found with a Hough-style search in the facet plane (the
   direction and offset whose band holds the densest line of points, longest
   first), the width measured automatically at half the band's density
   profile (the thesis asked the user for the beam width);
3. :func:`group_facets` joins straight facets into beams: parallel axes and a
   shared edge (boundary-to-boundary contact over at least half of the shorter
   facet, not centroid distance); a beam needs at least two facets with
   non-parallel normals (otherwise no cuboid is defined) and the rest goes
   back to the pool;
4. :func:`fit_beam_cuboid` fits one oriented cuboid per beam from its facets;
5. every point within ``surface_tolerance_m`` of a cuboid surface is given to
   the nearest cuboid (the thesis's re-merge of pool points): labels, not
   copies, and nothing is lost (the remainder is label 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.geometry.neighbours import _as_xyz, build_tree, point_spacing
from pyheracles.labels import Segmentation
from pyheracles.segment.regiongrow import RegionGrowingParams, region_growing

__all__ = [
    "BeamCuboid",
    "BeamParams",
    "BeamResult",
    "StraightFacet",
    "fit_beam_cuboid",
    "group_facets",
    "segment_beams",
    "split_facet",
]

BEAM_CLASS = "beam"
BEAM_CLASS_ID = 1


@dataclass(frozen=True)
class BeamParams:
    """Parameters of beam segmentation.

    Attributes
    ----------
    region
        Region growing of the facets (:class:`RegionGrowingParams`).  Default:
        point level, ``k = 24`` (noisy TLS data), automatic thresholds.
    min_facet_points
        Facets and straight facets with fewer points are noise (back to the pool).
    min_beam_width_m, max_beam_width_m
        Accepted range of a straight facet's width, metres (timber sections of
        historic roofs are 5-60 cm).
    min_elongation
        A straight facet is at least this many times as long as it is wide.
    angle_step_deg
        Direction step of the band (Hough) search, degrees; refined 10 times finer.
    parallel_deg
        Largest angle between the axes of two facets of one beam, degrees.
    contact_m
        Largest boundary-to-boundary distance of two adjacent facets, metres;
        ``None``: 4 times the point spacing, at least 2 cm.
    min_contact_fraction
        Two facets of a beam touch along at least this fraction of the shorter one.
    surface_tolerance_m
        Points closer than this to a fitted cuboid's surface join that beam,
        metres; ``None``: 3 times the median facet plane RMS, at least 1 cm.
    """

    region: RegionGrowingParams = field(
        default_factory=lambda: RegionGrowingParams(k=24, min_points=100)
    )
    min_facet_points: int = 100
    min_beam_width_m: float = 0.04
    max_beam_width_m: float = 0.6
    min_elongation: float = 3.0
    angle_step_deg: float = 1.0
    parallel_deg: float = 5.0
    contact_m: float | None = None
    min_contact_fraction: float = 0.4
    surface_tolerance_m: float | None = None

    def validate(self) -> BeamParams:
        if not 0 < self.min_beam_width_m < self.max_beam_width_m:
            raise InputError(
                "need 0 < min_beam_width_m < max_beam_width_m, got "
                f"{self.min_beam_width_m} and {self.max_beam_width_m}"
            )
        if self.min_facet_points < 10:
            raise InputError(f"min_facet_points must be >= 10, got {self.min_facet_points}")
        if not 0 < self.parallel_deg < 45:
            raise InputError(f"parallel_deg must be in (0, 45), got {self.parallel_deg}")
        if not 0 < self.min_contact_fraction <= 1:
            raise InputError(
                f"min_contact_fraction must be in (0, 1], got {self.min_contact_fraction}"
            )
        if not 0.05 <= self.angle_step_deg <= 10:
            raise InputError(f"angle_step_deg must be in [0.05, 10], got {self.angle_step_deg}")
        self.region.validate()
        return self


@dataclass(frozen=True)
class StraightFacet:
    """A band of constant width inside a planar facet (one face of one beam).

    Attributes
    ----------
    index
        ``(m,)`` indices of its points in the input cloud.
    normal
        ``(3,)`` unit plane normal.
    axis
        ``(3,)`` unit direction of the band (the beam axis candidate).
    centre
        ``(3,)`` centroid, metres.
    width, length
        Band width (half-density edges) and length, metres.
    plane_rms
        RMS distance of its points to their plane, metres.
    parent
        Region (facet) it was cut from.
    """

    index: NDArray[np.int64]
    normal: NDArray[np.float64]
    axis: NDArray[np.float64]
    centre: NDArray[np.float64]
    width: float
    length: float
    plane_rms: float
    parent: int


@dataclass(frozen=True)
class BeamCuboid:
    """Oriented cuboid of one beam.

    Attributes
    ----------
    centre
        ``(3,)`` centre, metres (local frame).
    axes
        ``(3, 3)`` columns: beam axis, width direction, height direction.
    length, width, height
        Edge lengths, metres; width is measured along the cross-section
        direction closer to horizontal.
    rms
        RMS distance of the beam's facet points to the cuboid surface, metres.
    n_facets
        Straight facets used.
    """

    centre: NDArray[np.float64]
    axes: NDArray[np.float64]
    length: float
    width: float
    height: float
    rms: float
    n_facets: int

    @property
    def axis(self) -> NDArray[np.float64]:
        return self.axes[:, 0]

    @property
    def half_extents(self) -> NDArray[np.float64]:
        return 0.5 * np.array([self.length, self.width, self.height])

    def signed_distance(self, points: ArrayLike) -> NDArray[np.float64]:
        """Signed distance to the cuboid surface (negative inside), metres."""
        local = (np.asarray(points, dtype=np.float64) - self.centre) @ self.axes
        q = np.abs(local) - self.half_extents
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(axis=1), 0.0)
        return outside + inside

    def corners(self) -> NDArray[np.float64]:
        """``(8, 3)`` corners (for drawing)."""
        s = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
        return self.centre + (s * self.half_extents) @ self.axes.T


@dataclass(frozen=True)
class BeamResult:
    """Result of :func:`segment_beams`.

    Attributes
    ----------
    labels
        ``(N,)`` int32 beam id per point (1..B), 0 = remainder.
    beams
        Cuboid of each beam (``beams[i]`` is label ``i + 1``).
    facet_labels
        ``(N,)`` int32 region-growing facet per point (0 = none).
    straight_labels
        ``(N,)`` int32 straight facet per point (0 = none).
    facet_beam
        Beam (1-based, 0 = none) of each straight facet.
    params
        Parameters with the automatic values resolved.
    timings
        Seconds per stage.
    """

    labels: NDArray[np.int32]
    beams: tuple[BeamCuboid, ...]
    facet_labels: NDArray[np.int32]
    straight_labels: NDArray[np.int32]
    facet_beam: NDArray[np.int32]
    params: BeamParams
    timings: dict[str, float] = field(default_factory=dict)

    def objects_table(self, offset: ArrayLike | None = None) -> pd.DataFrame:
        """One row per beam: ``instance``, ``class``, ``n_points``, axis, sizes, RMS."""
        off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        counts = np.bincount(self.labels, minlength=len(self.beams) + 1)
        rows: list[dict[str, Any]] = []
        for i, b in enumerate(self.beams):
            c = b.centre + off
            rows.append(
                {
                    "instance": i + 1,
                    "class": BEAM_CLASS,
                    "n_points": int(counts[i + 1]),
                    "n_facets": b.n_facets,
                    "centre_x": c[0],
                    "centre_y": c[1],
                    "centre_z": c[2],
                    "axis_x": b.axis[0],
                    "axis_y": b.axis[1],
                    "axis_z": b.axis[2],
                    "inclination_deg": float(np.degrees(np.arcsin(min(1.0, abs(b.axis[2]))))),
                    "length_m": b.length,
                    "width_m": b.width,
                    "height_m": b.height,
                    "rms_m": b.rms,
                }
            )
        columns = [
            "instance",
            "class",
            "n_points",
            "n_facets",
            "centre_x",
            "centre_y",
            "centre_z",
            "axis_x",
            "axis_y",
            "axis_z",
            "inclination_deg",
            "length_m",
            "width_m",
            "height_m",
            "rms_m",
        ]
        return pd.DataFrame(rows, columns=columns)

    def to_segmentation(self, offset: ArrayLike | None = None) -> Segmentation:
        """The result as a :class:`~pyheracles.labels.Segmentation` (class ``beam``)."""
        class_id = np.where(self.labels > 0, BEAM_CLASS_ID, 0).astype(np.uint8)
        return Segmentation(
            instance=self.labels,
            class_id=class_id,
            classes={BEAM_CLASS_ID: BEAM_CLASS},
            objects=self.objects_table(offset),
        )


# ----------------------------------------------------------------------------- facets
def _plane_frame(p: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
    """Centroid, normal and two in-plane unit vectors (PCA)."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt[2], vt[:2]


def _half_max_edges(values: NDArray[np.float64], bin_m: float) -> tuple[float, float]:
    """Edges of the dense part of a 1-D distribution, at half its plateau density.

    For points uniform on an interval plus Gaussian noise the half-density points
    are the interval's ends whatever the noise, which quantiles are not.
    """
    lo, hi = float(values.min()), float(values.max())
    nb = max(int(np.ceil((hi - lo) / bin_m)), 1)
    hist = np.bincount(
        np.minimum(((values - lo) / bin_m).astype(np.int64), nb - 1), minlength=nb
    ).astype(float)
    if nb >= 3:
        hist = np.convolve(hist, np.ones(3) / 3.0, mode="same")
    peak = int(hist.argmax())
    # plateau level: median of the bins above a quarter of the peak (robust to spikes)
    level = float(np.median(hist[hist >= 0.25 * hist[peak]]))
    half = 0.5 * level
    i = peak
    while i > 0 and hist[i - 1] >= half:
        i -= 1
    j = peak
    while j < nb - 1 and hist[j + 1] >= half:
        j += 1

    # linear interpolation of the half crossing between bin centres
    def _cross(a: int, b: int) -> float:
        ha, hb = hist[a], hist[b]
        frac = 0.5 if ha == hb else (half - ha) / (hb - ha)
        return lo + (a + 0.5 + frac * (b - a)) * bin_m

    left = _cross(i - 1, i) if i > 0 else lo
    right = _cross(j, j + 1) if j < nb - 1 else hi
    return left, right


def _best_direction(
    q: NDArray[np.float64], angles: NDArray[np.float64], bin_m: float
) -> tuple[float, float]:
    """Hough-style search: direction whose perpendicular profile has the densest bin.

    Returns the angle (radians) and the offset of the peak bin centre.
    """
    ca, sa = np.cos(angles), np.sin(angles)
    # offsets across the band for every angle: (m, n_angles)
    s = -q[:, :1] * sa + q[:, 1:] * ca
    smin = s.min(axis=0)
    b = ((s - smin) / bin_m).astype(np.int64)
    nb = int(b.max()) + 1
    flat = b + np.arange(len(angles)) * nb
    acc = np.bincount(flat.ravel(), minlength=nb * len(angles)).reshape(len(angles), nb)
    # a band is wider than one bin: score a 3-bin window
    acc = acc[:, :-2] + acc[:, 1:-1] + acc[:, 2:] if nb > 2 else acc
    k = int(acc.argmax())
    ia, ib = divmod(k, acc.shape[1])
    shift = 1 if nb > 2 else 0
    return float(angles[ia]), float(smin[ia] + (ib + shift + 0.5) * bin_m)


def split_facet(
    xyz: NDArray[np.float64],
    index: NDArray[np.int64],
    params: BeamParams,
    *,
    spacing_m: float,
    parent: int = 0,
    rng: np.random.Generator | None = None,
) -> list[StraightFacet]:
    """Cut an L-, T-, X- or Y-shaped planar facet into straight bands.

    Parameters
    ----------
    xyz
        ``(N, 3)`` all points, metres.
    index
        Indices of the facet's points.
    params
        :class:`BeamParams` (width range, elongation, angle step).
    spacing_m
        Point spacing, metres (sets the profile bin).
    parent
        Facet id recorded in the output.
    rng
        For the subsample of the direction search.

    Returns
    -------
    list of StraightFacet
        Longest band first; points in no band are left out (back to the pool).

    Notes
    -----
    The thesis rasterised the facet and ran a Hough line transform on it, then
    paired edges.  Here the Hough accumulator is built directly on the points:
    for each direction, the histogram of offsets across it; a straight face of a
    beam is the direction and offset with the densest line of points (the
    longest beam wins).  Its width is read at half the band's density, the band
    is cut along its length at gaps, removed, and the search starts again on the
    rest.  No raster, no edge pairing, no width given by the user.
    """
    gen = rng if rng is not None else np.random.default_rng(0)
    pts = xyz[index]
    c, normal, inplane = _plane_frame(pts)
    q_all = (pts - c) @ inplane.T
    plane_d = (pts - c) @ normal
    remaining = np.ones(len(index), dtype=bool)
    out: list[StraightFacet] = []
    bin_m = max(spacing_m, 0.004)
    step = np.radians(params.angle_step_deg)
    coarse = np.arange(0.0, np.pi, step)
    min_pts = params.min_facet_points
    for _ in range(64):  # bands per facet; a facet of a roof holds a handful
        live = np.flatnonzero(remaining)
        if len(live) < min_pts:
            break
        sub = live if len(live) <= 4000 else gen.choice(live, 4000, replace=False)
        ang, _ = _best_direction(q_all[sub], coarse, 2 * bin_m)
        fine = ang + np.linspace(-step, step, 21)
        ang, off = _best_direction(q_all[sub], fine, bin_m)
        d2 = np.array([np.cos(ang), np.sin(ang)])
        n2 = np.array([-np.sin(ang), np.cos(ang)])
        s = q_all[live] @ n2
        near = np.abs(s - off) < params.max_beam_width_m
        if near.sum() < min_pts:
            remaining[live] = False
            break
        lo, hi = _half_max_edges(s[near], bin_m)
        width = hi - lo
        in_band = (s >= lo - 1.5 * bin_m) & (s <= hi + 1.5 * bin_m)
        band = live[in_band]
        # refine the direction by PCA of the band's points (total least squares)
        qb = q_all[band]
        _, evec = np.linalg.eigh(np.cov((qb - qb.mean(axis=0)).T))
        d2 = evec[:, 1] if abs(evec[:, 1] @ d2) > 0.9 else d2
        t = qb @ d2
        order = np.argsort(t)
        gaps = np.flatnonzero(np.diff(t[order]) > max(2.0 * width, 20 * bin_m))
        runs = np.split(order, gaps + 1)
        accepted = False
        for run in runs:
            r_idx = band[run]
            length = float(t[run[-1]] - t[run[0]])
            ok_w = params.min_beam_width_m <= width <= params.max_beam_width_m
            if len(run) >= min_pts and ok_w and length >= params.min_elongation * width:
                axis3 = d2 @ inplane
                rms = float(np.sqrt(np.mean(plane_d[r_idx] ** 2)))
                out.append(
                    StraightFacet(
                        index=index[r_idx],
                        normal=normal,
                        axis=axis3 / np.linalg.norm(axis3),
                        centre=pts[r_idx].mean(axis=0),
                        width=float(width),
                        length=length,
                        plane_rms=rms,
                        parent=parent,
                    )
                )
                remaining[r_idx] = False
                accepted = True
        if not accepted:
            # the densest band is no beam face: drop its points from the search
            remaining[band] = False
    return out


# ----------------------------------------------------------------------------- grouping
class _UnionFind:
    def __init__(self, n: int) -> None:
        self.parent = np.arange(n)

    def find(self, a: int) -> int:
        while self.parent[a] != a:
            self.parent[a] = self.parent[self.parent[a]]
            a = self.parent[a]
        return int(a)

    def union(self, a: int, b: int) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


def group_facets(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    parallel_deg: float,
    contact_m: float,
    min_contact_fraction: float,
) -> NDArray[np.int32]:
    """Join straight facets into beams.

    Two facets belong to one beam when their axes are parallel within
    ``parallel_deg`` and they touch (points of one within ``contact_m`` of the
    other, a boundary-to-boundary distance) along at least
    ``min_contact_fraction`` of the shorter facet.  Groups of connected facets
    with at least two non-parallel normals are beams.

    Returns
    -------
    group
        ``(n_facets,)`` int32 beam id (1..B, by decreasing point count), 0 = none.
    """
    n = len(facets)
    if n == 0:
        return np.zeros(0, dtype=np.int32)
    axes = np.array([f.axis for f in facets])
    cos_par = np.cos(np.radians(parallel_deg))
    trees = [cKDTree(xyz[f.index]) for f in facets]
    lo = np.array([xyz[f.index].min(axis=0) for f in facets]) - contact_m
    hi = np.array([xyz[f.index].max(axis=0) for f in facets]) + contact_m
    uf = _UnionFind(n)
    for i in range(n):
        par = np.abs(axes[i + 1 :] @ axes[i]) >= cos_par
        box = np.all(lo[i + 1 :] <= hi[i], axis=1) & np.all(hi[i + 1 :] >= lo[i], axis=1)
        for j in np.flatnonzero(par & box) + i + 1:
            a, b = (i, j) if len(facets[i].index) <= len(facets[j].index) else (j, i)
            pa = xyz[facets[a].index]
            dist, _ = trees[b].query(pa, k=1, distance_upper_bound=contact_m)
            touch = np.isfinite(dist)
            if touch.sum() < 10:
                continue
            axis = axes[a]
            t = pa[touch] @ axis
            span = np.quantile(t, 0.98) - np.quantile(t, 0.02)
            shorter = min(facets[a].length, facets[b].length)
            if span >= min_contact_fraction * shorter:
                uf.union(i, j)
    roots = np.array([uf.find(i) for i in range(n)])
    normals = np.array([f.normal for f in facets])
    sizes = np.array([len(f.index) for f in facets])
    group = np.zeros(n, dtype=np.int32)
    kept: list[tuple[int, int]] = []
    for r in np.unique(roots):
        members = np.flatnonzero(roots == r)
        if len(members) < 2:
            continue
        nm = normals[members]
        if np.abs(nm @ nm.T).min() > np.cos(np.radians(45.0)):
            continue  # only parallel faces: no cross-section, no cuboid
        kept.append((int(sizes[members].sum()), int(r)))
    for rank, (_, r) in enumerate(sorted(kept, key=lambda t: (-t[0], t[1]))):
        group[roots == r] = rank + 1
    return group


# ----------------------------------------------------------------------------- cuboid
def fit_beam_cuboid(
    xyz: NDArray[np.float64], facets: list[StraightFacet], *, bin_m: float
) -> BeamCuboid:
    """Oriented cuboid of a beam from its straight facets.

    Why not :func:`pyheracles.geometry.fitting.fit_oriented_box`: a beam in a
    roof is seen on two or three of its faces only, and a PCA / minimum-area
    box of such points underestimates the hidden sides.  The facets carry more
    information, used here:

    - the axis is the direction most orthogonal to the facet normals (smallest
      eigenvector of ``sum n n^T``, weighted by points), exact for two
      non-parallel faces;
    - each side of the cross-section comes from the plane of the face on that
      side (median offset, robust) when that face was seen, otherwise from the
      half-density edge of the adjacent faces' points (unbiased by noise);
    - the length from the 0.5 / 99.5 % quantiles of the points along the axis.

    Raises
    ------
    DegenerateGeometryError
        When the facets do not define a cross-section (all parallel).
    """
    normals = np.array([f.normal for f in facets])
    w = np.array([len(f.index) for f in facets], dtype=float)
    m = (normals * w[:, None]).T @ normals
    ev, evec = np.linalg.eigh(m)
    if ev[1] < 0.05 * ev.sum():
        raise DegenerateGeometryError("the facets of this beam are all parallel")
    axis = evec[:, 0]
    mean_axis = np.sum([f.axis * np.sign(f.axis @ axis) * len(f.index) for f in facets], axis=0)
    axis = axis * np.sign(axis @ mean_axis)
    # cross-section frame: the direction closer to horizontal is "width"
    big = facets[int(np.argmax(w))].normal
    u = big - (big @ axis) * axis
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    if abs(u[2]) > abs(v[2]):  # make u the more horizontal one
        u, v = v, -u
    pts = np.vstack([xyz[f.index] for f in facets])
    bounds = []
    for d, other in ((u, v), (v, u)):
        facing = [f for f in facets if abs(f.normal @ d) >= abs(f.normal @ other)]
        across = [f for f in facets if abs(f.normal @ d) < abs(f.normal @ other)]
        offsets = np.array([np.median(xyz[f.index] @ d) for f in facing])
        if across:
            a_vals = np.concatenate([xyz[f.index] @ d for f in across])
        else:
            a_vals = pts @ d
        e_lo, e_hi = _half_max_edges(a_vals, bin_m)
        mid = 0.5 * (e_lo + e_hi)
        lo_faces = offsets[offsets < mid] if len(offsets) else offsets
        hi_faces = offsets[offsets >= mid] if len(offsets) else offsets
        b_lo = float(np.median(lo_faces)) if len(lo_faces) else e_lo
        b_hi = float(np.median(hi_faces)) if len(hi_faces) else e_hi
        bounds.append((b_lo, b_hi))
    t = pts @ axis
    t_lo, t_hi = np.quantile(t, [0.005, 0.995])
    (u_lo, u_hi), (v_lo, v_hi) = bounds
    centre = axis * 0.5 * (t_lo + t_hi) + u * 0.5 * (u_lo + u_hi) + v * 0.5 * (v_lo + v_hi)
    cub = BeamCuboid(
        centre=centre,
        axes=np.column_stack([axis, u, v]),
        length=float(t_hi - t_lo),
        width=float(u_hi - u_lo),
        height=float(v_hi - v_lo),
        rms=0.0,
        n_facets=len(facets),
    )
    dist = np.abs(cub.signed_distance(pts))
    return replace(cub, rms=float(np.sqrt(np.mean(dist**2))))


# ----------------------------------------------------------------------------- pipeline
def _assign_to_cuboids(
    xyz: NDArray[np.float64], tree: cKDTree, beams: list[BeamCuboid], tol: float
) -> NDArray[np.int32]:
    """Each point to the cuboid whose surface is nearest, if within ``tol``."""
    best = np.full(len(xyz), np.inf)
    labels = np.zeros(len(xyz), dtype=np.int32)
    for i, b in enumerate(beams):
        radius = float(np.linalg.norm(b.half_extents)) + tol
        cand = np.asarray(tree.query_ball_point(b.centre, radius, workers=-1), dtype=np.int64)
        if len(cand) == 0:
            continue
        d = np.abs(b.signed_distance(xyz[cand]))
        better = (d <= tol) & (d < best[cand])
        best[cand[better]] = d[better]
        labels[cand[better]] = i + 1
    return labels


def segment_beams(
    xyz: ArrayLike | PointCloud,
    params: BeamParams | None = None,
    *,
    tree: cKDTree | None = None,
    rng: np.random.Generator | int | None = 0,
) -> BeamResult:
    """Segment the beams of a timber framework and fit a cuboid to each.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates in metres (local frame) or a :class:`PointCloud`.
    params
        :class:`BeamParams`.
    tree
        Shared KD-tree on ``xyz``.
    rng
        Seed for the subsampling of the direction search.

    Returns
    -------
    BeamResult
        Per-point beam labels aligned with the input (0 = remainder), one
        :class:`BeamCuboid` per beam, the intermediate facets, timings.

    Raises
    ------
    InputError
        Empty or non-finite input, or no planar facet at all (the message says
        so: the cloud holds no beam faces at this density / noise).
    """
    import time

    source = None
    if isinstance(xyz, PointCloud):
        xyz.validate(what="framework cloud")
        source = xyz.source
        arr = xyz.xyz
    else:
        arr = _as_xyz(xyz)
    p = (params or BeamParams()).validate()
    if len(arr) < 4 * p.min_facet_points:
        raise InputError(
            f"the cloud has {len(arr)} points; beam segmentation needs at least "
            f"{4 * p.min_facet_points}",
            path=source,
            hint="give a denser cloud of the framework or lower min_facet_points",
        )
    gen = np.random.default_rng(rng)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    if tree is None:
        tree = build_tree(arr)
    spacing = point_spacing(arr, tree)
    regions = region_growing(arr, p.region, tree=tree)
    timings["facets"] = time.perf_counter() - t0
    if regions.n_regions == 0:
        raise InputError(
            "no planar facet found: the cloud has no smooth surfaces at this density",
            path=source,
            hint="check that the cloud shows the beams' faces, or raise region.angle_deg",
        )
    t1 = time.perf_counter()
    order = np.argsort(regions.labels, kind="stable")
    bounds = np.searchsorted(regions.labels[order], np.arange(regions.n_regions + 2))
    facets: list[StraightFacet] = []
    for r in range(1, regions.n_regions + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < p.min_facet_points:
            continue
        facets.extend(split_facet(arr, idx, p, spacing_m=spacing, parent=r, rng=gen))
    timings["split"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    contact = p.contact_m if p.contact_m is not None else max(4.0 * spacing, 0.02)
    group = group_facets(
        arr,
        facets,
        parallel_deg=p.parallel_deg,
        contact_m=contact,
        min_contact_fraction=p.min_contact_fraction,
    )
    timings["group"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    cuboids: list[BeamCuboid] = []
    facet_beam = np.zeros(len(facets), dtype=np.int32)
    for g in range(1, int(group.max(initial=0)) + 1):
        members = [facets[i] for i in np.flatnonzero(group == g)]
        try:
            cub = fit_beam_cuboid(arr, members, bin_m=max(spacing, 0.004))
        except DegenerateGeometryError:
            continue
        cuboids.append(cub)
        facet_beam[group == g] = len(cuboids)
    rms = [f.plane_rms for f, g in zip(facets, facet_beam, strict=True) if g > 0]
    tol = p.surface_tolerance_m
    if tol is None:
        tol = max(3.0 * float(np.median(rms)) if rms else 0.0, 0.01)
    labels = _assign_to_cuboids(arr, tree, cuboids, tol)
    timings["cuboids"] = time.perf_counter() - t3
    straight = np.zeros(len(arr), dtype=np.int32)
    for i, f in enumerate(facets):
        straight[f.index] = i + 1
    resolved = replace(p, region=regions.params, contact_m=contact, surface_tolerance_m=tol)
    return BeamResult(
        labels=labels,
        beams=tuple(cuboids),
        facet_labels=regions.labels,
        straight_labels=straight,
        facet_beam=facet_beam,
        params=resolved,
        timings=timings,
    )
