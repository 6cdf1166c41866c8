"""Deflection (sag, bow) and twist of a beam measured from its own points.

A fitted :class:`~pyheracles.beams.model.BeamCuboid` is straight; the timber
it stands for may sag under load or twist as it dried.  Both are what a
conservator inspects, and both are read from the points along the beam:

1. the member's points are cut into slices along the cuboid axis; in each
   slice the points of every lateral face (the face nearest to each point, its
   edges left out) give the face's offset from the straight cuboid's face
   (robust median) and the face's tilt in the section (least-squares slope);
2. the offsets of the faces across the width and across the height give the
   centre line's displacement per slice (one unknown constant per face takes
   up a wrong width or height of the cuboid), fitted by a bow (second-degree
   curve) along the axis; the **deflection** is the bow's largest distance
   from the chord between the ends of the beam's scanned length, ``|c| L^2 / 4``
   (the issue's "largest deviation of the scanned centre line from straight").
   ``L`` runs between the outermost of the beam's own points with at least
   ``min_face_points`` of them within a slice inwards (:func:`scanned_ends`): not the
   located slices only (the faces' first and last located slices often stop
   short of the scanned ends, where a crossing member or the boarding hides a
   face, and the sag over that shorter chord is smaller by the square of its
   share), and not the cuboid's ends or faces followed past them (a post's
   cuboid runs on through the tie it stands on, and its side faces go on in
   the tie's: the sag over that longer chord came out up to 1.7 times the
   true one, roof seeds 1, 3, 6);
3. the section's rotation per slice (from every face's tilt, again with one
   constant per face) is fitted by a straight line along the axis; the
   **twist** is its end-to-end change, degrees, right-handed about the axis;
4. the fit is repeated (``passes``): each pass takes every point near the bent and
   twisted surface estimated by the first (not only the points within the
   straight cuboid's tolerance, which miss the middle of a strongly bent beam)
   and not given to another beam.

The largest deviation of the slice centres from the straight line through the
first and last slice (``deviation_m``) and the slices' RMS about the bow
(``centreline_rms_m``) are reported too: a beam that is not simply bowed (a
kink, an S-shape) shows a large RMS.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.model import BeamCuboid, box_distance
from pyheracles.errors import InputError
from pyheracles.geometry.groups import group_medians
from pyheracles.geometry.sections import sort_order

__all__ = [
    "BoxIndex",
    "MemberShape",
    "ShapeParams",
    "deleted_residuals",
    "member_shape",
    "member_shapes",
    "near_beams",
    "reach_ends",
    "scanned_ends",
    "search_box",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ShapeParams:
    """Parameters of the deflection and twist measurement.

    Attributes
    ----------
    slice_m
        Length of a slice along the beam axis, metres.
    min_face_points
        Fewest points of one face in one slice that locate it.
    edge_share
        Points within this share of a face's width from its edges are left
        out (the adjacent face's points and rounded arrises).
    search_m
        Later passes: points up to this distance (metres) from the straight
        cuboid's surface are candidates (the largest bow measured is about
        this).
    surface_tol_m
        Later passes: a candidate belongs to the beam within this distance of
        the bent and twisted surface, metres.
    min_slices
        Fewest slices with a located face for a measurement (else NaN).
    min_coverage
        Smallest share of the beam's length spanned by located slices for a
        deflection (a bow read from one end is an extrapolation; else NaN).
    extend_m
        The beam's faces are followed this far past the cuboid's ends, metres
        (an end fitted short); slices there count while contiguous.
    end_gap_m
        Largest gap past a cuboid's end bridged when following the faces,
        metres (a crossing beam whose cuboid holds the points there).
    passes
        Fits; the first from the beam's labelled points, each later one from
        the candidates near the surface bent and twisted by the one before.
    """

    slice_m: float = 0.1
    min_face_points: int = 8
    edge_share: float = 0.15
    search_m: float = 0.05
    surface_tol_m: float = 0.012
    min_slices: int = 5
    min_coverage: float = 0.5
    passes: int = 2
    extend_m: float = 0.5
    end_gap_m: float = 0.1

    def validate(self) -> ShapeParams:
        if not 0 < self.slice_m <= 2.0:
            raise InputError(f"slice_m must be in (0, 2] metres, got {self.slice_m}")
        if self.min_face_points < 3:
            raise InputError(f"min_face_points must be >= 3, got {self.min_face_points}")
        if not 0 <= self.edge_share < 0.5:
            raise InputError(f"edge_share must be in [0, 0.5), got {self.edge_share}")
        if not 0 < self.surface_tol_m <= self.search_m:
            raise InputError(
                f"need 0 < surface_tol_m <= search_m, got {self.surface_tol_m} and {self.search_m}"
            )
        if self.min_slices < 3:
            raise InputError(f"min_slices must be >= 3, got {self.min_slices}")
        if not 0 <= self.end_gap_m <= self.extend_m:
            raise InputError(
                f"need 0 <= end_gap_m <= extend_m, got {self.end_gap_m} and {self.extend_m}"
            )
        if not 0 <= self.extend_m <= 5.0:
            raise InputError(f"extend_m must be in [0, 5] metres, got {self.extend_m}")
        if not 1 <= self.passes <= 10:
            raise InputError(f"passes must be in [1, 10], got {self.passes}")
        if not 0 < self.min_coverage <= 1:
            raise InputError(f"min_coverage must be in (0, 1], got {self.min_coverage}")
        return self


@dataclass(frozen=True)
class MemberShape:
    """Deflection and twist of one beam.

    Attributes
    ----------
    deflection_m
        Largest distance of the fitted bow from the chord between the ends
        of the member's scanned length (``chord_m``), metres (NaN: not
        measurable, see ``note``; a beam seen only on one face, or on two
        opposite faces, bows unseen in their plane).
    direction
        ``(3,)`` unit vector from the chord towards the bow's middle (zeros
        when not measured).
    twist_deg
        Rotation of the section about the cuboid axis over the measured
        length, right-handed, degrees (NaN: not measurable).
    deviation_m
        Largest distance of a slice centre from the straight line through the
        first and last located slice, metres.
    centreline_rms_m
        RMS of the slice centres about the bow, metres.
    coverage
        ``measured_length_m`` over the cuboid's length (above 1 when the
        faces go on past the cuboid's ends).
    n_slices
        Slices with at least one located face.
    n_points
        Points used (second pass).
    note
        Why a value is NaN, or ``""``.
    centreline
        ``(k, 3)``: position along the axis from the centre, displacement
        along the width and along the height direction, metres, per slice.
    measured_length_m
        Length from the first to the last located slice, metres: the span of
        the twist.
    chord_m
        ``(2,)`` the ends of the deflection's chord along the axis from the
        cuboid's centre, metres: the ends of the beam's scanned length
        (:func:`scanned_ends` of its own points).
    """

    deflection_m: float
    direction: Array
    twist_deg: float
    deviation_m: float
    centreline_rms_m: float
    coverage: float
    n_slices: int
    n_points: int
    note: str = ""
    centreline: Array = field(default_factory=lambda: np.zeros((0, 3)))
    measured_length_m: float = float("nan")
    chord_m: Array = field(default_factory=lambda: np.full(2, np.nan))


@dataclass(frozen=True)
class _Slices:
    """Per slice and face: position, offset, tilt (NaN where not located)."""

    t: Array  # (S,) slice centres along the axis
    offset: Array  # (S, 4) face offsets: +w, -w, +h, -h
    tilt: Array  # (S, 4) section rotation read from each face, radians
    count: NDArray[np.int64]  # (S, 4)


def _local(cub: BeamCuboid, pts: Array) -> Array:
    return (pts - cub.centre) @ cub.axes


def _handedness(cub: BeamCuboid) -> float:
    return float(np.sign(np.linalg.det(cub.axes)) or 1.0)


def _slices(
    loc: Array,
    cub: BeamCuboid,
    corr: tuple[Array, Array, Array] | None,
    p: ShapeParams,
) -> _Slices:
    """Face offsets and tilts per slice from local coordinates (axis, width, height).

    Slices run over the cuboid's length and ``p.extend_m`` past each end; the
    ends' slices count only while contiguous with the cuboid's (gaps up to
    ``p.end_gap_m``).
    """
    half = 0.5 * np.array([cub.length, cub.width, cub.height])
    span = half[0] + p.extend_m
    n_s = max(1, int(np.ceil(2 * span / p.slice_m)))
    edges = np.linspace(-span, span, n_s + 1)
    t_mid = 0.5 * (edges[:-1] + edges[1:])
    a = loc[:, 0]
    u, v = loc[:, 1].copy(), loc[:, 2].copy()
    if corr is not None:  # remove the current estimate of bow and twist
        du, dv, th = (np.interp(a, t_mid, c) for c in corr)
        u, v = u - du, v - dv
        c, s = np.cos(th), np.sin(th)
        u, v = c * u + s * v, -s * u + c * v
    k = np.clip(np.searchsorted(edges, a) - 1, 0, n_s - 1)
    inside = np.abs(a) <= span
    gap_w = np.abs(np.abs(u) - half[1])
    gap_h = np.abs(np.abs(v) - half[2])
    on_w = (gap_w < gap_h) & (np.abs(v) <= (0.5 - p.edge_share) * cub.height) & inside
    on_h = (gap_h <= gap_w) & (np.abs(u) <= (0.5 - p.edge_share) * cub.width) & inside
    # face (0: +w, 1: -w, 2: +h, 3: -h), offset q from the straight face, coordinate
    # along the face; a right-handed rotation by theta (width towards height) tilts
    # the width faces by dq/dv = -theta and the height faces by dq/du = +theta
    face = np.full(len(a), -1)
    face[on_w] = np.where(u[on_w] > 0, 0, 1)
    face[on_h] = np.where(v[on_h] > 0, 2, 3)
    use = np.flatnonzero(face >= 0)
    f = face[use]
    q = np.where(f == 0, u[use] - half[1], np.where(f == 1, u[use] + half[1], 0.0))
    q = np.where(f == 2, v[use] - half[2], np.where(f == 3, v[use] + half[2], q))
    along = np.where(f < 2, v[use], u[use])
    group = k[use] * 4 + f
    n_g = 4 * n_s
    med = group_medians(q, group, n_g)
    dev = np.abs(q - med[group])
    mad = group_medians(dev, group, n_g)
    keep = dev <= np.maximum(3.0 * mad[group], 0.003)
    q, along, group = q[keep], along[keep], group[keep]
    count = np.bincount(group, minlength=n_g)
    offset = group_medians(q, group, n_g)
    offset[count < p.min_face_points] = np.nan
    # tilt: least-squares slope of q over the coordinate along the face
    n = np.maximum(count, 1)
    mp = np.bincount(group, along, n_g) / n
    mq = np.bincount(group, q, n_g) / n
    var = np.bincount(group, along * along, n_g) / n - mp**2
    cov = np.bincount(group, along * q, n_g) / n - mp * mq
    width = np.tile([cub.height, cub.height, cub.width, cub.width], n_s)
    ok = (count >= p.min_face_points) & (np.sqrt(np.maximum(var, 0.0)) > 0.1 * width)
    sign = np.tile([-1.0, -1.0, 1.0, 1.0], n_s)
    tilt = np.where(ok, sign * np.arctan(cov / np.where(ok, var, 1.0)), np.nan)
    offset, tilt, count = offset.reshape(n_s, 4), tilt.reshape(n_s, 4), count.reshape(n_s, 4)
    # slices past the cuboid's ends: only while contiguous with the located ones
    beyond = np.abs(t_mid) > half[0]
    located = np.isfinite(offset).any(axis=1)
    keep_s = _contiguous(located, beyond, t_mid, int(np.ceil(p.end_gap_m / p.slice_m)))
    offset[~keep_s] = np.nan
    tilt[~keep_s] = np.nan
    count[~keep_s] = 0
    if corr is not None:  # back to offsets and tilts from the straight cuboid
        offset[:, :2] += corr[0][:, None]
        offset[:, 2:] += corr[1][:, None]
        tilt += corr[2][:, None]
    return _Slices(t=t_mid, offset=offset, tilt=tilt, count=count)


def _contiguous(
    located: NDArray[np.bool_], beyond: NDArray[np.bool_], t: Array, max_misses: int
) -> NDArray[np.bool_]:
    """Slices to keep: all inside the cuboid; past its ends until ``max_misses`` empty ones."""
    keep = ~beyond
    for run in (np.flatnonzero(beyond & (t > 0)), np.flatnonzero(beyond & (t < 0))[::-1]):
        misses = 0
        for i in run:
            if misses > max_misses:
                break
            misses = 0 if located[i] else misses + 1
            keep[i] = bool(located[i])
    return keep


def _fit_with_face_constants(
    t: Array, values: Array, weights: Array, degree: int
) -> tuple[Array, Array, Array]:
    """Weighted least squares ``value = c_face + sum_k a_k t^k`` (k = 1..degree), 4-sigma cut.

    Returns the polynomial coefficients ``a`` (k = 1..degree), the per-face
    constants and the per-slice combined curve (face constants removed; NaN
    where no face).
    """
    n_f = values.shape[1]
    ok = np.isfinite(values)
    rows, cols = np.nonzero(ok)
    y = values[rows, cols]
    w = np.sqrt(weights[rows, cols])
    keep = np.ones(len(y), bool)
    coef = np.zeros(degree)
    const = np.zeros(n_f)
    for _ in range(2):
        A = np.zeros((len(y), n_f + degree))
        A[np.arange(len(y)), cols] = 1.0
        for d in range(1, degree + 1):
            A[:, n_f + d - 1] = t[rows] ** d
        used = np.flatnonzero(A[keep].any(axis=0))
        sol, *_ = np.linalg.lstsq((A[keep] * w[keep, None])[:, used], y[keep] * w[keep], rcond=None)
        full = np.zeros(n_f + degree)
        full[used] = sol
        const, coef = full[:n_f], full[n_f:]
        res = y - A @ full
        res[keep] = deleted_residuals((A[keep] * w[keep, None])[:, used], res[keep])
        mad = float(np.median(np.abs(res[keep]))) if keep.any() else 0.0
        new = np.abs(res) <= max(4.0 * 1.4826 * mad, 1e-4)
        if new.sum() < degree + 2 or np.array_equal(new, keep):
            break
        keep = new
    cleaned = np.where(ok, values - const[None, :], np.nan)
    wts = np.where(ok, weights, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        combined = np.nansum(np.nan_to_num(cleaned) * wts, axis=1) / wts.sum(axis=1)
    combined[wts.sum(axis=1) == 0] = np.nan
    return coef, const, combined


def deleted_residuals(design: Array, res: Array) -> Array:
    """Residuals of a least-squares fit as if each row had been left out of it.

    ``design``: the ``(n, k)`` (weighted) design matrix of the fit, ``res`` its
    ``(n,)`` residuals.  A row far from the others along the beam (a face's
    slice at an end, beyond a gap) has a high leverage ``h``: the fit bends
    towards it and its own residual stays small, so that a cut on the residuals
    keeps it; ``res / (1 - h)`` is its distance from the fit of the other rows
    (roof draw 1, a common rafter whose side was located in one end slice 0.7 m
    from its other slices, 8 mm off: a sideways bow of 15 mm).
    """
    if len(res) == 0:
        return res
    q, _ = np.linalg.qr(design)
    h = np.minimum(np.sum(q * q, axis=1), 0.99)
    return res / (1.0 - h)


def _estimate(sl: _Slices) -> dict[str, Array]:
    """Bow and twist coefficients, their constants and the per-slice centre line.

    The constant of a direction is the mean of its faces' constants weighted
    by their points (two opposite faces: the centre's offset, whatever the
    cuboid's width error; one face: its offset, the width taken as right).
    """
    w = sl.count.astype(np.float64)
    out: dict[str, Array] = {}
    for key, vals, wts, degree in (
        ("u", sl.offset[:, :2], w[:, :2], 2),
        ("v", sl.offset[:, 2:], w[:, 2:], 2),
        ("t", sl.tilt, np.where(np.isfinite(sl.tilt), w, 0.0), 1),
    ):
        coef, const, curve = _fit_with_face_constants(sl.t, vals, wts, degree)
        per_face = wts.sum(axis=0)
        mean = float(const @ per_face / per_face.sum()) if per_face.sum() > 0 else 0.0
        out["c" + key], out["d" + key] = coef, curve
        out["k" + key] = np.array([mean])
    return out


def _poly(t: Array, coef: Array) -> Array:
    """``sum_k coef[k - 1] t^k`` (no constant)."""
    out = np.zeros_like(t)
    for d, c in enumerate(coef):
        out += c * t ** (d + 1)
    return out


def member_shape(
    xyz: Array,
    cub: BeamCuboid,
    own: NDArray[np.bool_],
    params: ShapeParams | None = None,
    *,
    other: NDArray[np.bool_] | None = None,
    others: Sequence[BeamCuboid] = (),
    index: BoxIndex | None = None,
    blocked: NDArray[np.bool_] | None = None,
    box: NDArray[np.int64] | None = None,
) -> MemberShape:
    """Deflection and twist of one beam from its points.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres (local frame).
    cub
        The beam's fitted (straight) cuboid.
    own
        ``(N,)`` points of the beam (its labels): the first pass.
    params
        :class:`ShapeParams`.
    other
        ``(N,)`` points given to other beams (never used); ``None``: none.
    others
        Cuboids of the other beams: points not labelled to this beam that lie
        inside or within ``surface_tol_m`` of one of them are not used (a
        beam's faces are not followed into the beam it meets).
    index
        :class:`BoxIndex` of ``xyz``, shared between beams.
    blocked
        ``(N,)`` points within ``surface_tol_m`` of another beam's cuboid, found
        once for all beams (:func:`near_beams`); replaces ``others``.
    box
        The points of the beam's search box (sorted indices, from :func:`near_beams`);
        replaces ``index``.

    Returns
    -------
    MemberShape
        NaN values with a ``note`` when too few slices locate a face.

    Examples
    --------
    A 3 m beam sagging by 2 cm (see ``tests/test_beams_frame.py``) gives
    ``deflection_m`` close to 0.02.
    """
    p = (params or ShapeParams()).validate()
    if not own.any():
        return _empty(0, "no points")
    # candidates of the later passes: near the straight cuboid, not another beam's
    lo, hi = search_box(cub, p)
    found = (index or BoxIndex(xyz)).query(lo, hi) if box is None else box
    own_found = own[found]
    use = np.ones(len(found), dtype=bool)
    if other is not None:
        use &= ~other[found] | own_found
    if blocked is not None:
        use &= own_found | ~blocked[found]
    for oc in others if blocked is None else ():
        c = oc.corners()
        if np.any(c.max(axis=0) < lo) or np.any(c.min(axis=0) > hi):
            continue
        use &= own_found | (oc.signed_distance(xyz[found]) > p.surface_tol_m)
    return _shape(xyz, cub, p, found, own_found, np.flatnonzero(own), use)


def _shape(
    xyz: Array,
    cub: BeamCuboid,
    p: ShapeParams,
    found: NDArray[np.int64],
    own_found: NDArray[np.bool_],
    own_index: NDArray[np.int64],
    use: NDArray[np.bool_],
) -> MemberShape:
    """:func:`member_shape` from the beam's search box: its points ``found`` (sorted
    indices), which of them are the beam's own (``own_found``) and may be used
    (``use``), and all the beam's own points (``own_index``, sorted; some may lie
    out of the box)."""
    sign = _handedness(cub)
    found_loc = _local(cub, xyz[found])
    cand = found_loc[use]
    if int(own_found.sum()) == len(own_index):  # first pass: the beam's own points
        loc = found_loc[own_found]
    else:  # some lie out of the search box
        loc = _local(cub, xyz[own_index])
    own_ends = scanned_ends(loc[:, 0], p.slice_m, p.min_face_points)
    corr = None
    for _ in range(p.passes):
        sl = _slices(loc, cub, corr, p)
        est = _estimate(sl)
        corr = tuple(_poly(sl.t, est["c" + k]) + est["k" + k][0] for k in "uvt")
        near = _near_bent_surface(cand, cub, sl.t, *corr, p.surface_tol_m, p.extend_m)
        loc = cand[near]
    sl = _slices(loc, cub, corr, p)
    est = _estimate(sl)
    located = np.isfinite(sl.offset).any(axis=1)
    n_slices = int(located.sum())
    if n_slices < p.min_slices:
        return _empty(len(loc), f"{n_slices} slices locate a face (need {p.min_slices})")
    t_loc = sl.t[located]
    L = float(np.ptp(t_loc) + p.slice_m)  # the measured length: first to last located slice
    coverage = L / max(cub.length, p.slice_m)
    cu, cv = float(est["cu"][1]), float(est["cv"][1])
    bow = np.array([cu, cv])
    chord = reach_ends(own_ends, loc[:, 0], 0.5 * cub.length, p)
    deflection = float(np.linalg.norm(bow) * np.ptp(chord) ** 2 / 4)
    direction = np.zeros(3)
    if deflection > 0:
        direction = -(cu * cub.axes[:, 1] + cv * cub.axes[:, 2]) / np.linalg.norm(bow)
    du_s = est["du"] + est["ku"][0]
    dv_s = est["dv"] + est["kv"][0]
    centre = np.column_stack([sl.t, np.nan_to_num(du_s), np.nan_to_num(dv_s)])
    rms, deviation = _centreline_stats(sl.t, du_s, dv_s, est)
    rate = est["ct"]
    twist = float(np.degrees(rate[0] * L) * sign)
    if not np.isfinite(sl.tilt).any() or np.isfinite(sl.tilt).any(axis=1).sum() < p.min_slices:
        twist = float("nan")
    note = ""
    per_dir = [
        int(np.isfinite(sl.offset[:, k]).any(axis=1).sum()) for k in (slice(0, 2), slice(2, 4))
    ]
    if min(per_dir) < p.min_slices:  # a bow along the seen faces moves them in their plane
        deflection = float("nan")
        note = "faces seen across one direction only: a bow along them is not measured"
    if coverage < p.min_coverage:
        deflection, note = float("nan"), f"located slices span {coverage:.0%} of the length"
    return MemberShape(
        measured_length_m=L,
        chord_m=chord,
        deflection_m=deflection,
        direction=direction,
        twist_deg=twist,
        deviation_m=deviation,
        centreline_rms_m=rms,
        coverage=coverage,
        n_slices=n_slices,
        n_points=len(loc),
        note=note,
        centreline=centre[located],
    )


def scanned_ends(along: Array, slice_m: float, min_points: int) -> Array:
    """Ends of a beam's scanned length from its own points along its axis.

    An end is the outermost point with at least ``min_points`` points (itself
    included) within ``slice_m`` inwards of it, towards the beam's middle.

    Parameters
    ----------
    along
        ``(n,)`` positions of the beam's own points along its axis, metres.
    slice_m
        Length looked over inwards of a point, metres.
    min_points
        Fewest points there that make it the beam's: fewer are strays of a
        crossing member labelled to the beam (a purlin's points over a post's
        head) or mixed pixels past its end, not the beam going on.

    Returns
    -------
    ndarray
        ``(2,)`` the two ends, metres (the first and last point when none has
        ``min_points`` inwards; NaN for no point).
    """
    if len(along) == 0:
        return np.full(2, np.nan)
    a = np.sort(along)
    above = np.searchsorted(a, a + slice_m, side="right") - np.arange(len(a))
    below = np.arange(len(a)) + 1 - np.searchsorted(a, a - slice_m, side="left")
    lo = np.flatnonzero(above >= min_points)
    hi = np.flatnonzero(below >= min_points)
    first = a[lo[0]] if len(lo) else a[0]
    last = a[hi[-1]] if len(hi) else a[-1]
    return np.array([float(first), float(last)])


def reach_ends(own_ends: Array, along: Array, half_length: float, p: ShapeParams) -> Array:
    """The chord's ends: the beam's own scanned ends (:func:`scanned_ends`), or
    farther out where the points near its bent surface reach farther within the
    cuboid's length.

    A beam's points are labelled by the distance to its straight cuboid; where the
    beam sags by more than that tolerance the points at its ends, bent out of the
    tight box, go to no beam, and the sag over the shorter chord of the points
    labelled came out smaller by the square of its share (roof draw 29: a common
    rafter sagging 27 mm, its chord 28 cm short, 3.5 mm too little).  The points
    near the bent surface (``along``: their positions along the axis, metres) are
    the same member's there; past the cuboid's ends (``half_length``, metres) they
    may be the faces of the member it meets, and are not looked at.
    """
    inside = along[np.abs(along) <= half_length]
    near = scanned_ends(inside, p.slice_m, p.min_face_points)
    if not np.all(np.isfinite(near)):
        return own_ends
    if not np.all(np.isfinite(own_ends)):
        return near
    return np.array([min(own_ends[0], near[0]), max(own_ends[1], near[1])])


def _near_bent_surface(
    loc: Array,
    cub: BeamCuboid,
    t_s: Array,
    du: Array,
    dv: Array,
    th: Array,
    tol: float,
    extend: float,
) -> NDArray[np.bool_]:
    """Points within ``tol`` of the cuboid's lateral surface displaced and rotated per slice.

    The cuboid is taken ``extend`` longer at both ends.
    """
    a = loc[:, 0]
    u = loc[:, 1] - np.interp(a, t_s, du)
    v = loc[:, 2] - np.interp(a, t_s, dv)
    ang = np.interp(a, t_s, th)
    c, s = np.cos(ang), np.sin(ang)
    u, v = c * u + s * v, -s * u + c * v
    # the box's signed distance, one coordinate at a time (no (n, 3) arrays)
    qa = np.abs(a) - 0.5 * (cub.length + 2 * extend)
    qu = np.abs(u) - 0.5 * cub.width
    qv = np.abs(v) - 0.5 * cub.height
    ma, mu, mv = np.maximum(qa, 0.0), np.maximum(qu, 0.0), np.maximum(qv, 0.0)
    outside = np.sqrt(ma * ma + mu * mu + mv * mv)
    inside = np.minimum(np.maximum(np.maximum(qa, qu), qv), 0.0)
    return np.abs(outside + inside) <= tol


def _centreline_stats(t: Array, du: Array, dv: Array, est: dict[str, Array]) -> tuple[float, float]:
    """RMS of the slice centres about the bow, and their largest deviation from the end chord."""
    cu, cv = est["cu"], est["cv"]
    rows = np.flatnonzero(np.isfinite(du) | np.isfinite(dv))
    if len(rows) < 2:
        return float("nan"), float("nan")
    res = []
    for vals, c in ((du, cu), (dv, cv)):
        fin = np.isfinite(vals)
        if fin.sum() >= 3:
            r = vals[fin] - (c[0] * t[fin] + c[1] * t[fin] ** 2)
            res.append(r - r.mean())
    rms = float(np.sqrt(np.mean(np.concatenate(res) ** 2))) if res else float("nan")
    dev2 = np.zeros(len(t))
    for vals in (du, dv):
        fin = np.flatnonzero(np.isfinite(vals))
        if len(fin) < 2:
            continue
        i0, i1 = fin[0], fin[-1]
        chord = vals[i0] + (vals[i1] - vals[i0]) * (t - t[i0]) / (t[i1] - t[i0])
        dev2[fin] += (vals[fin] - chord[fin]) ** 2
    return rms, float(np.sqrt(dev2.max()))


def _empty(n_points: int, note: str) -> MemberShape:
    nan = float("nan")
    return MemberShape(nan, np.zeros(3), nan, nan, nan, 0.0, 0, n_points, note)


def member_shapes(
    xyz: Array,
    labels: NDArray[np.integer],
    beams: tuple[BeamCuboid, ...] | list[BeamCuboid],
    params: ShapeParams | None = None,
) -> list[MemberShape]:
    """:func:`member_shape` of every beam (``labels``: 1-based beam per point, 0 = none)."""
    p = (params or ShapeParams()).validate()
    xyz = np.asarray(xyz, dtype=np.float64)
    labels = np.asarray(labels)
    if labels.shape != (len(xyz),):
        raise InputError(f"labels must have one value per point ({len(xyz)}), got {labels.shape}")
    beams = list(beams)
    boxes, count, which = near_beams(xyz, beams, p, BoxIndex(xyz))
    # each beam's own points (sorted indices), from one sort of the labels, and every
    # mask taken over the beam's search box only (not the whole cloud once per beam)
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(len(beams) + 2))
    out = []
    for i, cub in enumerate(beams):
        own_index = order[starts[i + 1] : starts[i + 2]]
        if len(own_index) == 0:
            out.append(_empty(0, "no points"))
            continue
        found = boxes[i]
        lab = labels[found]
        own_found = lab == i + 1
        n_near = count[found]
        blocked = (n_near >= 2) | ((n_near == 1) & (which[found] != i))
        # not another beam's point, and not near another beam's cuboid unless its own
        use = ((lab <= 0) | own_found) & (own_found | ~blocked)
        out.append(_shape(xyz, cub, p, found, own_found, own_index, use))
    return out


def search_box(cub: BeamCuboid, params: ShapeParams) -> tuple[Array, Array]:
    """Lower and upper corners of the box searched for a beam's points: the cuboid
    ``extend_m`` longer at both ends, widened by ``search_m``."""
    longer = replace(cub, length=cub.length + 2 * params.extend_m).corners()
    return longer.min(axis=0) - params.search_m, longer.max(axis=0) + params.search_m


def near_beams(
    xyz: Array, beams: Sequence[BeamCuboid], params: ShapeParams, index: BoxIndex
) -> tuple[list[NDArray[np.int64]], NDArray[np.int32], NDArray[np.int32]]:
    """Each beam's search box, and how many cuboids each point is near.

    Returns the points of each beam's :func:`search_box` (sorted indices), then
    ``count`` and ``which``, both
    ``(N,)``: how many cuboids a point lies inside or within ``surface_tol_m`` of
    (the search box holds every such point) and the last of them (0-based, -1
    for none).  A point is near another beam than ``i`` when ``count >= 2``, or
    ``count == 1`` and ``which != i``.  Found once per beam, not once per pair of
    beams (a rafter's box holds half of a roof), and the boxes serve
    :func:`member_shape` too (their coordinates are not kept: a hundred beams'
    boxes over 10 M points would hold gigabytes).
    """
    count = np.zeros(len(xyz), dtype=np.int32)
    which = np.full(len(xyz), -1, dtype=np.int32)
    boxes = []
    for j, cub in enumerate(beams):
        found = index.query(*search_box(cub, params))
        loc = _local(cub, xyz[found])
        hit = found[box_distance(loc, cub.half_extents) <= params.surface_tol_m]
        count[hit] += 1
        which[hit] = j
        boxes.append(found)
    return boxes, count, which


class BoxIndex:
    """Points sorted along each coordinate, for axis-aligned box queries.

    A query scans the points inside the box's narrowest coordinate range only
    (a beam along ``x`` is narrow in ``y`` and ``z``), not the whole cloud.  The
    coordinates are kept in each of the three orders, so that a query reads one
    contiguous run of them instead of gathering scattered rows (three copies of
    the cloud: on a 1 M-point roof the gathers took most of the queries' time).
    """

    def __init__(self, xyz: Array) -> None:
        self.xyz = xyz
        # sort_order: numpy's stable argsort, 3x faster (an int64 SIMD sort of keys)
        self.order = [sort_order(np.ascontiguousarray(xyz[:, d]))[0] for d in range(3)]
        self.points = [xyz[o] for o in self.order]
        self.sorted = [pts[:, d] for d, pts in enumerate(self.points)]

    def query(self, lo: Array, hi: Array) -> NDArray[np.int64]:
        """Sorted indices of the points with ``lo <= xyz <= hi``."""
        spans = [
            (
                int(np.searchsorted(self.sorted[d], lo[d], side="left")),
                int(np.searchsorted(self.sorted[d], hi[d], side="right")),
            )
            for d in range(3)
        ]
        d = int(np.argmin([b - a for a, b in spans]))
        a, b = spans[d]
        pts = self.points[d][a:b]
        inside = (pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0])
        for k in (1, 2):
            inside &= (pts[:, k] >= lo[k]) & (pts[:, k] <= hi[k])
        return np.sort(self.order[d][a:b][inside])
