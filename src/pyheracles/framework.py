"""Step 2b: beams of timber roof frameworks, each with a fitted cuboid.

Thesis chapter 6.3 (Murtiyoso 2020; MATLAB ``regiongrowingnormals``,
``axedetect``, ``beamSeg``).  The pipeline reads top-down:

0. clouds denser than ``thin_spacing_m`` are thinned at random for the
   geometry (normals of over-dense noisy scans are noise); labels come back to
   every input point at step 5;
1. :func:`~pyheracles.segment.regiongrow.region_growing` cuts the cloud into
   smooth planar *facets* (the faces of the beams; coplanar faces of beams
   meeting in a joint come out as one L-, T-, X- or Y-shaped facet); a region
   that bridged two faces of a beam along a rounded edge is split by its
   dominant normal directions;
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
4. collinear pieces of one beam (cut by a crossing beam in an X joint or by
   a shadow) are merged, and :func:`fit_beam_cuboid` fits one oriented cuboid
   per beam from its facets, lengthened over the short ends that gave no
   facet of their own;
5. every point within ``surface_tolerance_m`` of a cuboid surface is given to
   the nearest cuboid (the thesis's re-merge of pool points): labels, not
   copies, and nothing is lost (the remainder is label 0).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.geometry.neighbours import as_xyz, build_tree, point_spacing
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
        ``None``: twice the median k-neighbourhood radius (the band along an
        edge where normals are blended and points may stay unassigned), at
        least 4 times the point spacing and 2 cm.
    max_gap_m
        Largest gap along the axis between two pieces of one beam face (cut by a
        crossing beam in an X joint, or by an occlusion shadow), metres.
    min_contact_fraction
        Two facets of a beam touch along at least this fraction of the shorter one.
    surface_tolerance_m
        Points closer than this to a fitted cuboid's surface join that beam,
        metres; ``None``: 3 times the median facet plane RMS, at least 1 cm.
    thin_spacing_m
        Clouds denser than this median point spacing (metres) are randomly
        thinned to it for the facets, bands and cuboids (``None``: never); the
        labels are then given to every input point from the cuboids.  8 mm
        keeps at least 5 points across the narrowest face and lets 24
        neighbours span about 2.5 cm, well above the 2-5 mm noise of
        terrestrial scans (denser neighbourhoods give noisy normals and
        curvature).  Random thinning, unlike a voxel grid, leaves no layering
        of noisy surfaces.
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
    max_gap_m: float = 1.0
    min_contact_fraction: float = 0.4
    surface_tolerance_m: float | None = None
    thin_spacing_m: float | None = 0.008

    def validate(self) -> BeamParams:
        if self.thin_spacing_m is not None and not 0 < self.thin_spacing_m < self.min_beam_width_m:
            raise InputError(
                f"thin_spacing_m must be in (0, min_beam_width_m), got {self.thin_spacing_m}",
                hint="in Python: BeamParams.thin_spacing_m below --min-width, or None: no thinning",
            )
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


def _half_max_edges(
    values: NDArray[np.float64], bin_m: float, level_fraction: float = 0.5
) -> tuple[float, float]:
    """Edges of the dense part of a 1-D distribution, at half its plateau density.

    For points uniform on an interval plus Gaussian noise the half-density points
    are the interval's ends whatever the noise, which quantiles are not.  A lower
    ``level_fraction`` reaches further out where part of a face is shadowed (the
    bias outwards is about ``0.5 sigma`` of the noise at 0.3).
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
    half = level_fraction * level
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


def _sharpest_direction(
    q: NDArray[np.float64], ang0: float, half_range: float, bin_m: float
) -> float:
    """Direction near ``ang0`` across which the band is narrowest.

    A strip tilted by ``d`` spans ``w + L |d|`` across: the robust across-extent
    (0.5 to 99.5 % quantiles) is smallest when aligned.  Unlike PCA this is not
    pulled by an uneven density (overlapping scans) or by a crossing beam's
    points inside the band, and unlike a histogram sharpness it does not lock on
    the scan-line pattern.
    """
    del bin_m  # the extent needs no histogram
    angles = ang0 + np.linspace(-half_range, half_range, 81)
    s = -q[:, :1] * np.sin(angles) + q[:, 1:] * np.cos(angles)
    lo, hi = np.quantile(s, [0.005, 0.995], axis=0)
    score = -(hi - lo)
    k = int(score.argmax())
    if 0 < k < len(angles) - 1:
        y0, y1, y2 = score[k - 1], score[k], score[k + 1]
        den = y0 - 2 * y1 + y2
        frac = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        return float(angles[k] + np.clip(frac, -1, 1) * (angles[1] - angles[0]))
    return float(angles[k])


def _planar_parts(
    normals: NDArray[np.float64],
    index: NDArray[np.int64],
    min_points: int,
    gen: np.random.Generator,
    *,
    angle_deg: float = 20.0,
) -> list[NDArray[np.int64]]:
    """Split a region into its dominant normal directions.

    Region growing can bridge two perpendicular faces of a beam through the
    rounded band of blended normals along their edge; such a region is not
    planar and cannot be cut into bands.  Greedy dominant directions (the
    candidate normal with most points within ``angle_deg``, refined by the mean
    of those points) separate the faces; blended edge points stay out.  A
    planar region comes back whole.
    """
    n = normals[index]
    cos_t = np.cos(np.radians(angle_deg))
    live = np.ones(len(index), dtype=bool)
    parts: list[NDArray[np.int64]] = []
    for _ in range(6):
        alive = np.flatnonzero(live)
        if len(alive) < min_points:
            break
        sample = alive if len(alive) <= 2000 else gen.choice(alive, 2000, replace=False)
        cands = n[sample[:: max(1, len(sample) // 100)]]
        votes = (np.abs(n[sample] @ cands.T) >= cos_t).sum(axis=0)
        c = cands[int(votes.argmax())]
        inl = alive[np.abs(n[alive] @ c) >= cos_t]
        signs = np.sign(n[inl] @ c)[:, None]
        c = (n[inl] * signs).mean(axis=0)
        c /= np.linalg.norm(c)
        inl = alive[np.abs(n[alive] @ c) >= cos_t]
        if len(inl) < min_points:
            break
        if not parts and len(inl) >= 0.9 * len(alive):
            return [index]  # planar: keep the region whole, edge points included
        parts.append(index[inl])
        live[inl] = False
    return parts


def _on_own_plane(p: NDArray[np.float64], n_sigma: float = 3.0) -> NDArray[np.bool_]:
    """Points within ``n_sigma`` robust deviations (at least 6 mm) of the dominant plane.

    Least trimmed squares by concentration steps (Rousseeuw's C-steps, started
    from the least-squares plane): the plane is refitted on the 75 % of points
    closest to the previous one, which a minority of points on a parallel face
    a couple of centimetres away does not tilt, unlike a least-squares plane.
    The deviation is the MAD of all residuals to the final plane.
    """
    on = np.ones(len(p), dtype=bool)
    n_keep = max(int(0.75 * len(p)), 3)
    for _ in range(4):
        c, n, _ = _plane_frame(p[on])
        r = np.abs((p - c) @ n)
        on = np.zeros(len(p), dtype=bool)
        on[np.argpartition(r, n_keep - 1)[:n_keep]] = True
    c, n, _ = _plane_frame(p[on])
    h = (p - c) @ n
    sig = 1.4826 * float(np.median(np.abs(h)))
    return np.abs(h) <= max(n_sigma * sig, 0.006)


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
    c, _, inplane = _plane_frame(pts)
    q_all = (pts - c) @ inplane.T
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
        s = q_all[live] @ np.array([-np.sin(ang), np.cos(ang)])
        near = np.abs(s - off) < params.max_beam_width_m
        if near.sum() < min_pts:
            remaining[live] = False
            break
        lo, hi = _half_max_edges(s[near], bin_m)
        # refine the direction: the sharpest across-profile of the band's points
        in_band = (s >= lo - 1.5 * bin_m) & (s <= hi + 1.5 * bin_m)
        cand = live[in_band]
        if len(cand) > 3000:
            cand = gen.choice(cand, 3000, replace=False)
        ang = _sharpest_direction(q_all[cand], ang, np.radians(6.0), bin_m)
        ang = _sharpest_direction(q_all[cand], ang, np.radians(0.3), bin_m)
        d2 = np.array([np.cos(ang), np.sin(ang)])
        n2 = np.array([-np.sin(ang), np.cos(ang)])
        s = q_all[live] @ n2
        off = float(np.median(s[in_band]))
        near = np.abs(s - off) < params.max_beam_width_m
        lo, hi = _half_max_edges(s[near], bin_m)
        width = hi - lo
        in_band = (s >= lo - 1.5 * bin_m) & (s <= hi + 1.5 * bin_m)
        band = live[in_band]
        qb = q_all[band]
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
                # the band's own plane: a merged facet may hold faces a few
                # millimetres apart (T joints of members of unequal thickness)
                c_run, n_run, _ = _plane_frame(pts[r_idx])
                # ... or centimetres apart (a strut's face behind the face of the
                # post it runs into): the band keeps the points of its own plane
                # and leaves the other face's points to its own band
                on = _on_own_plane(pts[r_idx])
                d_run, w_run = d2, width
                if not on.all() and on.sum() >= min_pts:
                    # the direction and width were measured with the other
                    # face's points: measure them again on the band's own
                    r_idx = r_idx[on]
                    c_run, n_run, _ = _plane_frame(pts[r_idx])
                    q_run = q_all[r_idx]
                    a_run = _sharpest_direction(q_run, ang, np.radians(6.0), bin_m)
                    a_run = _sharpest_direction(q_run, a_run, np.radians(0.3), bin_m)
                    d_run = np.array([np.cos(a_run), np.sin(a_run)])
                    lo_r, hi_r = _half_max_edges(
                        q_run @ np.array([-np.sin(a_run), np.cos(a_run)]), bin_m
                    )
                    t_on = q_run @ d_run
                    length = float(t_on.max() - t_on.min())
                    if params.min_beam_width_m <= hi_r - lo_r <= params.max_beam_width_m:
                        w_run = hi_r - lo_r
                axis3 = d_run @ inplane
                axis3 -= (axis3 @ n_run) * n_run
                rms = float(np.sqrt(np.mean(((pts[r_idx] - c_run) @ n_run) ** 2)))
                out.append(
                    StraightFacet(
                        index=index[r_idx],
                        normal=n_run,
                        axis=axis3 / np.linalg.norm(axis3),
                        centre=c_run,
                        width=float(w_run),
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


def _pair_relation(
    fa: StraightFacet,
    fb: StraightFacet,
    ta: tuple[float, float],
    tb: tuple[float, float],
    *,
    cos_par: float,
    plane_tol: float,
    width_range: tuple[float, float],
    max_gap: float,
    min_overlap: float,
) -> str | None:
    """``"continuation"``, ``"opposite"`` or ``None`` for two parallel facets.

    Continuation: the same face of one beam cut by a crossing beam (X joint) or
    by an occlusion shadow: coplanar, same band line, similar width, separated
    along the axis by less than ``max_gap``.  Opposite: the two parallel faces
    of one beam: parallel planes ``width_range`` apart whose bands project on
    each other (the thesis's paired edges) over ``min_overlap`` of the shorter.
    """
    if abs(fa.normal @ fb.normal) < cos_par:
        return None
    d = fb.centre - fa.centre
    across = np.cross(fa.normal, fa.axis)
    wmax = max(fa.width, fb.width)
    if abs(fa.width - fb.width) > 0.3 * wmax or abs(d @ across) > 0.3 * wmax:
        return None
    sep = abs(d @ fa.normal)
    # both intervals are along fa.axis (tb was computed on fa.axis by the caller)
    gap = max(ta[0], tb[0]) - min(ta[1], tb[1])
    if sep <= plane_tol and gap <= max_gap:
        return "continuation"
    shorter = min(ta[1] - ta[0], tb[1] - tb[0])
    if width_range[0] <= sep <= width_range[1] and -gap >= min_overlap * shorter:
        return "opposite"
    return None


def group_facets(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    parallel_deg: float,
    contact_m: float,
    min_contact_fraction: float,
    width_range: tuple[float, float] = (0.04, 0.6),
    max_gap_m: float = 0.6,
) -> NDArray[np.int32]:
    """Join straight facets into beams.

    Two facets with axes parallel within ``parallel_deg`` belong to one beam when

    - they are *adjacent faces*: points of one within ``contact_m`` of the other
      (a boundary-to-boundary distance, not between centroids) along at least
      ``min_contact_fraction`` of the shorter facet; or
    - they are *opposite faces* or *continuations* of one face across a
      crossing beam or an occlusion (see :func:`_pair_relation`).

    Connected facets form a group; a group is a beam when it has at least two
    facets and they define a cross-section (two non-parallel normals, or two
    opposite faces).

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
    lo = np.array([xyz[f.index].min(axis=0) for f in facets]) - max(contact_m, max_gap_m)
    hi = np.array([xyz[f.index].max(axis=0) for f in facets]) + max(contact_m, max_gap_m)
    plane_tol = max(3.0 * float(np.median([f.plane_rms for f in facets])), 0.01)
    uf = _UnionFind(n)
    opposite = np.zeros((0, 2), dtype=np.int64)
    opp_pairs: list[tuple[int, int]] = []
    for i in range(n):
        par = np.abs(axes[i + 1 :] @ axes[i]) >= cos_par
        box = np.all(lo[i + 1 :] <= hi[i], axis=1) & np.all(hi[i + 1 :] >= lo[i], axis=1)
        ti = xyz[facets[i].index] @ axes[i]
        int_i = (float(np.quantile(ti, 0.01)), float(np.quantile(ti, 0.99)))
        for j in np.flatnonzero(par & box) + i + 1:
            tj = xyz[facets[j].index] @ axes[i]
            int_j = (float(np.quantile(tj, 0.01)), float(np.quantile(tj, 0.99)))
            rel = _pair_relation(
                facets[i],
                facets[j],
                int_i,
                int_j,
                cos_par=cos_par,
                plane_tol=plane_tol,
                width_range=width_range,
                max_gap=max_gap_m,
                min_overlap=min_contact_fraction,
            )
            if rel is not None:
                uf.union(i, j)
                if rel == "opposite":
                    opp_pairs.append((i, j))
                continue
            a, b = (i, j) if len(facets[i].index) <= len(facets[j].index) else (j, i)
            pa = xyz[facets[a].index]
            dist, _ = trees[b].query(pa, k=1, distance_upper_bound=contact_m)
            touch = np.isfinite(dist)
            if touch.sum() < 10:
                continue
            t = pa[touch] @ axes[a]
            span = np.quantile(t, 0.98) - np.quantile(t, 0.02)
            shorter = min(facets[a].length, facets[b].length)
            if span >= min_contact_fraction * shorter:
                uf.union(i, j)
    if opp_pairs:
        opposite = np.array(opp_pairs, dtype=np.int64)
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
        crossed = np.abs(nm @ nm.T).min() <= np.cos(np.radians(45.0))
        paired = bool(len(opposite)) and bool(np.any(roots[opposite[:, 0]] == r))
        if not (crossed or paired):
            continue  # one face only (possibly in pieces): no cross-section, no cuboid
        kept.append((int(sizes[members].sum()), int(r)))
    for rank, (_, r) in enumerate(sorted(kept, key=lambda t: (-t[0], t[1]))):
        group[roots == r] = rank + 1
    return group


# ----------------------------------------------------------------------------- cuboid
def _face_points(
    xyz: NDArray[np.float64], f: StraightFacet, bin_m: float, free: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """The facet's points plus the unclaimed cloud points on its plane past its band.

    Near an edge the normals are blended and points often stay out of every
    facet; the side of a cuboid read from a face's edge needs them back.  Taken:
    points in no straight facet (``free``, their coordinates; the adjacent face's own edge strip
    would pile up at the edge) within 3 plane RMS of the plane, inside the
    facet's length and at most 5 cm (or 10 bins) past its band on either side.
    """
    if free is None:
        return xyz[f.index]
    across = np.cross(f.normal, f.axis)
    own = xyz[f.index]
    t = (own - f.centre) @ f.axis
    s = (own - f.centre) @ across
    margin = max(0.05, 10 * bin_m)
    lo = own.min(axis=0) - margin
    hi = own.max(axis=0) + margin
    cand = free[np.all((free >= lo) & (free <= hi), axis=1)]
    rel = cand - f.centre
    keep = (
        (np.abs(rel @ f.normal) <= max(3.0 * f.plane_rms, bin_m))
        & (rel @ f.axis >= t.min())
        & (rel @ f.axis <= t.max())
        & (rel @ across >= s.min() - margin)
        & (rel @ across <= s.max() + margin)
    )
    return np.vstack([own, cand[keep]])


#: Fewest points on an unfaceted side of a beam that locate that side.
_SPARSE_FACE_MIN_POINTS = 15
#: Smallest share of the beam's length covered by those points (10 cm bins).
_SPARSE_FACE_MIN_COVER = 0.2


def _sparse_face(
    free: NDArray[np.float64],
    axis: NDArray[np.float64],
    d: NDArray[np.float64],
    other: NDArray[np.float64],
    band: NDArray[np.float64],
    t_range: tuple[float, float],
    edge: float,
    sign: float,
    bin_m: float,
) -> float:
    """Offset along ``d`` of a beam side seen by too few points for a facet.

    Candidates are the ``free`` points (in no facet) strictly between the
    planes of the two adjacent faces (offsets ``band`` along ``other``), within
    the beam's length, and within a few centimetres outside to one centimetre
    inside the ``edge`` estimated from the adjacent faces (``sign`` -1 for the
    low side, +1 for the high side).  Their median offset is returned when they
    are enough, spread along the beam (10 cm bins holding them cover at least
    ``_SPARSE_FACE_MIN_COVER`` of its length: the ends of beams resting on this
    one are local) and lie on one plane across ``d`` (interquartile range below
    ``bin_m``, at least 6 mm); otherwise ``edge`` is.
    """
    if len(free) == 0 or np.ptp(band) < 0.04:
        return edge
    margin = max(2.0 * bin_m, 0.01)
    b_lo, b_hi = float(band.min()) + margin, float(band.max()) - margin
    reach = max(6.0 * bin_m, 0.03)
    a = free @ d
    sel = (sign * (a - edge) <= reach) & (sign * (a - edge) >= -max(2.0 * bin_m, 0.01))
    if not sel.any():
        return edge
    cand = free[sel]
    o = cand @ other
    t = cand @ axis
    inside = (o >= b_lo) & (o <= b_hi) & (t >= t_range[0]) & (t <= t_range[1])
    vals = a[sel][inside]
    if len(vals) < _SPARSE_FACE_MIN_POINTS:
        return edge
    # a face runs along the beam: points bunched in a few spots (the ends of
    # beams resting on this one, at a joint) are no side of it, even if their
    # offsets agree by chance
    step = max(0.1, 10.0 * bin_m)
    occupied = len(np.unique(np.floor(t[inside] / step)))
    if occupied * step < _SPARSE_FACE_MIN_COVER * (t_range[1] - t_range[0]):
        return edge
    # one plane across d: a thin layer (noise), not points of a crossing
    # beam's faces, which fill the search window evenly
    q1, q3 = np.quantile(vals, [0.25, 0.75])
    if q3 - q1 > max(bin_m, 0.006):
        return edge
    return float(np.median(vals))


def fit_beam_cuboid(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    bin_m: float,
    free: NDArray[np.float64] | None = None,
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
      half-density edge of the adjacent faces' points (unbiased by noise),
      including the ``free`` points (``(m, 3)`` coordinates of the points in no
      facet) on those faces' planes, which
      restores the edge strips where blended normals kept points out of facets;
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
    ref = facets[int(np.argmax(w))].axis
    mean_axis = np.sum([f.axis * np.sign(f.axis @ ref) * len(f.index) for f in facets], axis=0)
    if ev[1] >= 0.05 * ev.sum():
        axis = evec[:, 0] * np.sign(evec[:, 0] @ mean_axis)
    else:
        # only parallel (opposite) faces: normal to the planes, along the band
        # of the cleanest face (lowest plane RMS; an occluded face may carry a
        # neighbour's points that tilt its band)
        nrm = evec[:, 2]
        best = min(facets, key=lambda f: f.plane_rms)
        axis = best.axis - (best.axis @ nrm) * nrm
        axis /= np.linalg.norm(axis)
        axis *= np.sign(axis @ mean_axis)
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
            a_vals = np.concatenate([_face_points(xyz, f, bin_m, free) @ d for f in across])
        else:
            a_vals = pts @ d
        e_lo, e_hi = _half_max_edges(a_vals, bin_m)
        mid = 0.5 * (e_lo + e_hi)
        if not across and len(offsets) >= 2:
            mid = 0.5 * (offsets.min() + offsets.max())  # two opposite faces
        lo_faces = offsets[offsets < mid] if len(offsets) else offsets
        hi_faces = offsets[offsets >= mid] if len(offsets) else offsets
        b_lo = float(np.median(lo_faces)) if len(lo_faces) else e_lo
        b_hi = float(np.median(hi_faces)) if len(hi_faces) else e_hi
        if free is not None and across and not (len(lo_faces) and len(hi_faces)):
            # A side whose face gave no facet (seen by too few points, or at a
            # grazing angle) is located by the edge of the adjacent faces only
            # to within a scan-line spacing; the face's own points, if any were
            # scanned, fix it (they lie between the adjacent faces' planes).
            band = np.array([np.median(xyz[f.index] @ other) for f in across])
            t_all = pts @ axis
            t_rng = (float(np.quantile(t_all, 0.005)), float(np.quantile(t_all, 0.995)))
            if not len(lo_faces):
                b_lo = _sparse_face(free, axis, d, other, band, t_rng, e_lo, -1.0, bin_m)
            if not len(hi_faces):
                b_hi = _sparse_face(free, axis, d, other, band, t_rng, e_hi, 1.0, bin_m)
        bounds.append((b_lo, b_hi))
    t = pts @ axis
    t_lo, t_hi = np.quantile(t, [0.005, 0.995])
    (u_lo, u_hi), (v_lo, v_hi) = bounds
    if min(u_hi - u_lo, v_hi - v_lo) <= 0:
        raise DegenerateGeometryError("the facets of this beam give no cross-section")
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


def _section_overlap(big: BeamCuboid, small: BeamCuboid) -> tuple[float, NDArray[np.float64]]:
    """Share of ``small``'s cross-section inside ``big``'s, and its extents in ``big``'s frame.

    Both sections are taken as rectangles in the plane across ``big``'s axis
    (the axes are nearly parallel); ``small``'s is its bounding rectangle there.
    """
    d = small.centre - big.centre
    rot = np.abs(big.axes[:, 1:].T @ small.axes[:, 1:])  # (2, 2) |cos| between section axes
    half_small = rot @ (0.5 * np.array([small.width, small.height]))
    centre = big.axes[:, 1:].T @ d
    half_big = 0.5 * np.array([big.width, big.height])
    inter = np.clip(
        np.minimum(centre + half_small, half_big) - np.maximum(centre - half_small, -half_big),
        0.0,
        None,
    )
    return float(np.prod(inter) / max(np.prod(2 * half_small), 1e-12)), 2 * half_small


def _collinear(a: BeamCuboid, b: BeamCuboid, cos_par: float, max_gap: float) -> bool:
    """Two cuboids that are pieces of one beam cut by an X joint or a shadow.

    Parallel, separated along the axis by at most ``max_gap``, and either with
    the same cross-section (centres within 30 % of it, sizes within 25 % or
    2 cm), or with the smaller section inside the larger one and one of its
    sizes equal to the larger one's: a piece seen on too few faces (a side
    shadowed by a crossing beam) has one side located by the edge of a partly
    seen face, so one size comes out short; the refit of the merged beam takes
    that side from the other piece's face.
    """
    if abs(a.axis @ b.axis) < cos_par:
        return False
    gap = abs((b.centre - a.centre) @ a.axis) - 0.5 * (a.length + b.length)
    if gap > max_gap:
        return False
    same = True
    for x, y in ((a, b), (b, a)):
        d = y.centre - x.centre
        if abs(d @ x.axes[:, 1]) > 0.3 * x.width or abs(d @ x.axes[:, 2]) > 0.3 * x.height:
            same = False
    dims_a = np.sort([a.width, a.height])
    dims_b = np.sort([b.width, b.height])
    tol = np.maximum(0.25 * np.maximum(dims_a, dims_b), 0.02)
    if same and not np.any(np.abs(dims_a - dims_b) > tol):
        return True
    big, small = (a, b) if a.width * a.height >= b.width * b.height else (b, a)
    inside, sizes = _section_overlap(big, small)
    big_sizes = np.array([big.width, big.height])
    one_equal = np.any(np.abs(sizes - big_sizes) <= np.maximum(0.1 * big_sizes, 0.01))
    return bool(inside >= 0.8 and one_equal)


def _merge_and_absorb(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    group: NDArray[np.int32],
    p: BeamParams,
    bin_m: float,
    free: NDArray[np.float64] | None = None,
) -> NDArray[np.int32]:
    """Merge collinear beam pieces and absorb lone facets lying on a beam.

    A beam crossed by another (X joint) or shadowed by one is seen as separate
    pieces; their cuboids are collinear with the same cross-section, so they
    are merged (gap at most ``max_gap_m``).  A straight facet left alone (one
    face of a piece) joins the beam whose cuboid, extended by ``max_gap_m``
    along its axis, it lies on.
    """
    n_groups = int(group.max(initial=0))
    cubs: dict[int, BeamCuboid] = {}
    for g in range(1, n_groups + 1):
        try:
            cubs[g] = fit_beam_cuboid(
                xyz, [facets[i] for i in np.flatnonzero(group == g)], bin_m=bin_m, free=free
            )
        except DegenerateGeometryError:
            continue
    cos_par = np.cos(np.radians(p.parallel_deg))
    ids = sorted(cubs)
    uf = _UnionFind(n_groups + 1)
    for i, gi in enumerate(ids):
        for gj in ids[i + 1 :]:
            if _collinear(cubs[gi], cubs[gj], cos_par, p.max_gap_m):
                uf.union(gi, gj)
    out = np.zeros(len(group), dtype=np.int32)
    for k, g in enumerate(group):
        if g > 0 and g in cubs:
            out[k] = uf.find(int(g))
    # lone facets on an (extended) beam
    tol = max(3.0 * float(np.median([f.plane_rms for f in facets])), 0.01) if facets else 0.01
    for k in np.flatnonzero(out == 0):
        f = facets[k]
        pts = xyz[f.index]
        for g in ids:
            c = cubs[g]
            if abs(f.axis @ c.axis) < cos_par:
                continue
            longer = replace(c, length=c.length + 2 * p.max_gap_m)
            if np.median(np.abs(longer.signed_distance(pts))) <= tol:
                out[k] = uf.find(g)
                break
    # renumber 1..B by decreasing point count
    roots = np.unique(out[out > 0])
    sizes = [sum(len(facets[k].index) for k in np.flatnonzero(out == r)) for r in roots]
    order = [int(r) for _, r in sorted(zip(sizes, roots, strict=True), key=lambda t: (-t[0], t[1]))]
    remap = {r: i + 1 for i, r in enumerate(order)}
    return np.array([remap.get(int(g), 0) for g in out], dtype=np.int32)


# ----------------------------------------------------------------------------- pipeline
def _assign_to_cuboids(
    xyz: NDArray[np.float64], beams: list[BeamCuboid], tol: float
) -> NDArray[np.int32]:
    """Each point to the cuboid whose surface is nearest, if within ``tol``."""
    best = np.full(len(xyz), np.inf)
    labels = np.zeros(len(xyz), dtype=np.int32)
    for i, b in enumerate(beams):
        cand = _candidates(xyz, b, tol)
        if len(cand) == 0:
            continue
        d = np.abs(b.signed_distance(xyz[cand]))
        better = (d <= tol) & (d < best[cand])
        best[cand[better]] = d[better]
        labels[cand[better]] = i + 1
    return labels


def _candidates(xyz: NDArray[np.float64], cub: BeamCuboid, margin: float) -> NDArray[np.int64]:
    """Indices of the points in the cuboid's axis-aligned bounding box + margin.

    A vectorised box test over all points is cheaper than a KD-tree ball query
    for long beams (the ball around a 6 m beam holds most of a roof).
    """
    corners = cub.corners()
    lo, hi = corners.min(axis=0) - margin, corners.max(axis=0) + margin
    inside = np.all((xyz >= lo) & (xyz <= hi), axis=1)
    return np.flatnonzero(inside)


def _lateral_face_normals(cub: BeamCuboid, pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """Normal of the nearest lateral (long) face of the cuboid for every point."""
    local = (pts - cub.centre) @ cub.axes
    gap_w = cub.width / 2 - np.abs(local[:, 1])
    gap_h = cub.height / 2 - np.abs(local[:, 2])
    use_w = np.abs(gap_w) < np.abs(gap_h)
    return np.where(use_w[:, None], cub.axes[:, 1], cub.axes[:, 2])


def _extend_along_axis(
    xyz: NDArray[np.float64],
    normals: NDArray[np.float64],
    free: NDArray[np.bool_],
    cub: BeamCuboid,
    tol: float,
    max_gap: float,
    spacing: float,
    cos_normal: float,
) -> BeamCuboid:
    """Lengthen a cuboid over the points that continue its faces past its ends.

    Short beam ends (overhangs, the part beyond a crossing beam) often give no
    straight facet of their own; their points lie on the beam's extended long
    faces, with the face's normal.  The cuboid grows over such points (not
    claimed by another beam's facets) while they are contiguous (gaps below
    ``max_gap / 2``, the size of a crossing beam); the cross-section is kept.
    """
    longer = replace(cub, length=cub.length + 2 * max_gap)
    cand = _candidates(xyz, longer, tol)
    cand = cand[free[cand]]
    if len(cand) == 0:
        return cub
    pts = xyz[cand]
    on = np.abs(longer.signed_distance(pts)) <= tol
    face_n = _lateral_face_normals(cub, pts)
    on &= np.abs(np.einsum("ij,ij->i", normals[cand], face_n)) >= cos_normal
    t = (pts[on] - cub.centre) @ cub.axis
    half = 0.5 * cub.length
    step = max(0.5 * max_gap, 10 * spacing)
    ends = []
    for sign in (1.0, -1.0):
        beyond = np.sort(sign * t[sign * t > half - tol])
        end = half
        if len(beyond) >= 20:
            jumps = np.flatnonzero(np.diff(np.concatenate([[half], beyond])) > step)
            run = beyond[: jumps[0]] if len(jumps) else beyond
            if len(run) >= 20:
                end = max(half, float(np.quantile(run, 0.995)))
        ends.append(end)
    hi, lo = ends[0], -ends[1]
    return replace(cub, centre=cub.centre + cub.axis * 0.5 * (hi + lo), length=float(hi - lo))


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
    source = None
    if isinstance(xyz, PointCloud):
        xyz.validate(what="framework cloud")
        source = xyz.source
        arr = xyz.xyz
    else:
        arr = as_xyz(xyz)
    p = (params or BeamParams()).validate()
    if len(arr) < 4 * p.min_facet_points:
        raise InputError(
            f"the cloud has {len(arr)} points; beam segmentation needs at least "
            f"{4 * p.min_facet_points}",
            path=source,
            hint="give a denser cloud (in Python: lower BeamParams.min_facet_points)",
        )
    gen = np.random.default_rng(rng)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    full = arr
    if tree is None:
        tree = build_tree(full)
    spacing = point_spacing(full, tree)
    keep = np.arange(len(full))
    if p.thin_spacing_m is not None and spacing < p.thin_spacing_m:
        fraction = (spacing / p.thin_spacing_m) ** 2
        keep = np.flatnonzero(gen.random(len(full)) < fraction)
        arr = full[keep]
        tree = build_tree(arr)
        spacing = point_spacing(arr, tree)
    regions = region_growing(arr, p.region, tree=tree)
    timings["facets"] = time.perf_counter() - t0
    if regions.n_regions == 0:
        raise InputError(
            "no planar facet found: the cloud has no smooth surfaces at this density",
            path=source,
            hint="check that the cloud shows the beams' faces, or raise --angle",
        )
    t1 = time.perf_counter()
    order = np.argsort(regions.labels, kind="stable")
    bounds = np.searchsorted(regions.labels[order], np.arange(regions.n_regions + 2))
    facets: list[StraightFacet] = []
    for r in range(1, regions.n_regions + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < p.min_facet_points:
            continue
        for part in _planar_parts(regions.normals, idx, p.min_facet_points, gen):
            facets.extend(split_facet(arr, part, p, spacing_m=spacing, parent=r, rng=gen))
    timings["split"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    contact = p.contact_m
    if contact is None:
        sample = arr[:: max(1, len(arr) // 20000)]
        r_k = float(np.median(tree.query(sample, k=p.region.k, workers=-1)[0][:, -1]))
        contact = max(2.0 * r_k, 4.0 * spacing, 0.02)
    group = group_facets(
        arr,
        facets,
        parallel_deg=p.parallel_deg,
        contact_m=contact,
        min_contact_fraction=p.min_contact_fraction,
        width_range=(p.min_beam_width_m, p.max_beam_width_m),
        max_gap_m=p.max_gap_m,
    )
    timings["group"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    bin_m = max(spacing, 0.004)
    free_mask = np.ones(len(arr), dtype=bool)
    for f in facets:
        free_mask[f.index] = False
    free = arr[free_mask]
    facet_beam = _merge_and_absorb(arr, facets, group, p, bin_m, free)
    cuboids: list[BeamCuboid] = []
    final = np.zeros(len(facets), dtype=np.int32)
    for g in range(1, int(facet_beam.max(initial=0)) + 1):
        members = [facets[i] for i in np.flatnonzero(facet_beam == g)]
        try:
            cub = fit_beam_cuboid(arr, members, bin_m=bin_m, free=free)
        except DegenerateGeometryError:
            continue
        cuboids.append(cub)
        final[facet_beam == g] = len(cuboids)
    facet_beam = final
    rms = [f.plane_rms for f, g in zip(facets, facet_beam, strict=True) if g > 0]
    tol = p.surface_tolerance_m
    if tol is None:
        tol = max(3.0 * float(np.median(rms)) if rms else 0.0, 0.01)
    claimed = np.zeros(len(arr), dtype=np.int32)  # beam of each facet point
    for f, g in zip(facets, facet_beam, strict=True):
        claimed[f.index] = g
    cos_n = np.cos(np.radians(regions.params.angle_deg or 15.0))
    cuboids = [
        _extend_along_axis(
            arr,
            regions.normals,
            (claimed == 0) | (claimed == i + 1),
            c,
            tol,
            p.max_gap_m,
            spacing,
            cos_n,
        )
        for i, c in enumerate(cuboids)
    ]
    labels = _assign_to_cuboids(full, cuboids, tol)
    timings["cuboids"] = time.perf_counter() - t3
    straight = np.zeros(len(arr), dtype=np.int32)
    for i, f in enumerate(facets):
        straight[f.index] = i + 1
    facet_labels = regions.labels
    if len(keep) < len(full):  # intermediate labels: from the nearest kept point
        _, near = tree.query(full, k=1, workers=-1)
        facet_labels, straight = facet_labels[near], straight[near]
    resolved = replace(p, region=regions.params, contact_m=contact, surface_tolerance_m=tol)
    return BeamResult(
        labels=labels,
        beams=tuple(cuboids),
        facet_labels=facet_labels,
        straight_labels=straight,
        facet_beam=facet_beam,
        params=resolved,
        timings=timings,
    )
