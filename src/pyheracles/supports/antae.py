"""Antae: a pier that ends a wall, cut off the wall it ends at the step of their faces.

An anta is a wall's end thickened into a pier: its side faces stand out of the wall's
faces by a few centimetres to a decimetre on each side (the family's antae by 0.1 m).
In a section the wall's stub and the pier make one island, and the cookie of that
island holds both: the pier's box then spans the wall too (supports draws 13, 16, 28,
35, 21, 34: boxes 0.4-1.4 m too long, half the support's points wall).  Along the
axis the wall runs on, the pier's outline is as wide as the pier; the wall's is set in
on both sides (or on its only face seen): the pier is cut there, as a respond or an
engaged column is cut at its wall's face.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.cookies import offset
from pyheracles.supports.core import Array
from pyheracles.supports.piers import rect_coords
from pyheracles.supports.primitives import prism_points


@dataclass(frozen=True)
class AntaParams:
    """What the wall beyond an anta looks like in the plan of the support's prism.

    Attributes
    ----------
    bin_m
        Length of the bins along the wall, metres.
    min_wall_m
        The set-in outline runs on over at least this length beyond the step, metres
        (a face seen in part at a pier's end is shorter).
    min_wall_bins
        ... in at least this many bins holding points.
    min_pier_share
        The pier (the full-width part) is at least this share of the support's length.
    face_tol_factor
        A wall face seen along the set-in bins stays within this many surface
        tolerances of one line (the wall's face, not scattered points) ...
    face_share
        ... in at least this share of the bins.
    min_layers
        A plan cell of a face holds points in at least this many of 8 height layers
        (:func:`~pyheracles.supports.primitives.prism_points`): a ruined wall's stub
        stands lower than the pier, a chair or the floor fills one or two layers.
    height_band
        The outline is read from the points between these quantiles of the support's
        heights: not its floor, a plinth, a capital or the ceiling over a wall.
    cut_margin_factor
        Points up to this many surface tolerances beyond the pier's end stay its own
        (the noise of its side faces' last points; the wall's first points lie beyond).
    min_wall_thickness_m
        A wall set in on one side only spans at least this much across, metres (a pier
        whose one side face was seen in part leaves only its other side face beyond).
    """

    bin_m: float = 0.05
    min_wall_m: float = 0.25
    min_wall_bins: int = 3
    min_pier_share: float = 0.2
    face_tol_factor: float = 1.0
    face_share: float = 0.8
    min_layers: int = 3
    height_band: tuple[float, float] = (0.2, 0.8)
    cut_margin_factor: float = 0.25
    min_wall_thickness_m: float = 0.15


ANTAE = AntaParams()


def anta_cut(
    pts: Array, centre: Array, angle: float, tol: float, cell: float, ap: AntaParams = ANTAE
) -> tuple[int, float, float, float] | None:
    """Where a pier candidate's points ``pts`` go on into the wall it ends, or None.

    The points of its shaft (:func:`shaft_prism`, plan cells of ``cell`` metres: faces,
    not a floor, a chair, a capital), in the frame of their faces' direction
    (:func:`face_angle`, searched from the section rectangle's ``angle`` in radians)
    about ``centre``; along each axis, a wall running on from one end of it and not
    from the other (:func:`wall_end`; narrower arms at both ends make a cross-shaped
    pier, no anta).

    Returns
    -------
    (axis, sign, cut, face_angle) or None
        The axis (0: along the faces' direction ``face_angle``, :func:`face_angle`, 1:
        across) and end (+1 or -1) the wall leaves from, and the coordinate along that
        axis of the pier's end there: its points beyond it (``sign x (u - cut)`` > 0,
        less a margin, :func:`cut_mask`) are the wall's.
    """
    if len(pts) < 20:
        return None
    prism = shaft_prism(pts, cell, ap)
    if len(prism) < 20:
        return None
    angle = face_angle(prism[:, :2], angle, tol)
    end = one_wall_end(rect_coords(prism[:, :2], centre, angle), tol, ap)
    return None if end is None else (*end, angle)


def one_wall_end(
    uv: Array, tol: float, ap: AntaParams = ANTAE, across_reach: Array | None = None
) -> tuple[int, float, float] | None:
    """The axis, end and cut of the first axis of a pier's outline ``uv`` (plan
    coordinates along and across its faces) along which a wall runs on from one end and
    not from the other (:func:`wall_end`; narrower arms at both ends make a
    cross-shaped pier, no anta), or None (see :func:`anta_cut`).  With
    ``across_reach`` (metres, per axis), only the points within that far of the centre
    across each axis are read along it (the section around a pier holds its
    neighbours too)."""
    for axis in (0, 1):
        along, across = uv[:, axis], uv[:, 1 - axis]
        if across_reach is not None:
            near = np.abs(across) <= across_reach[1 - axis]
            along, across = along[near], across[near]
            if len(along) < 20:
                continue
        ends = [wall_end(sign * along, across, tol, ap) for sign in (1.0, -1.0)]
        if (ends[0] is None) == (ends[1] is None):
            continue  # neither end, or both (a cross-shaped pier): no anta
        sign = 1.0 if ends[0] is not None else -1.0
        return axis, sign, sign * float(ends[0] if ends[0] is not None else ends[1])
    return None


def shaft_prism(pts: Array, cell: float, ap: AntaParams = ANTAE) -> Array:
    """The points of a pier candidate ``pts`` that outline its shaft: between the
    :attr:`AntaParams.height_band` quantiles of its heights, in plan cells of ``cell``
    metres holding points in :attr:`AntaParams.min_layers` of 8 layers
    (:func:`~pyheracles.supports.primitives.prism_points`)."""
    z = pts[:, 2]
    z_lo, z_hi = np.quantile(z, [ap.height_band[0], ap.height_band[1]])
    mid = pts[(z >= z_lo) & (z <= z_hi)]
    return mid[prism_points(mid, cell, min_layers=ap.min_layers)]


def face_angle(xy: Array, angle: float, tol: float, sample: int = 2000) -> float:
    """Direction (radians) of the faces of a box's plan points ``xy`` within 45 degrees
    of ``angle``: where their coordinates along and across pile up most (the sum of the
    squared counts in bins on both axes), searched in steps of 0.5 degrees (bins of
    ``tol / 2``) then 0.05 degrees (bins of ``tol / 5``).

    A section island of a pier and the wall it ends is no rectangle: the rectangle of
    its outline leans across the step of their faces (supports draw 16: 8 degrees).
    """
    q = xy[np.linspace(0, len(xy) - 1, min(len(xy), sample)).astype(np.intp)]
    q = q - q.mean(axis=0)
    best = angle
    for step, half, bin_m in (
        (np.radians(0.5), np.radians(45.0), 0.5 * tol),
        (np.radians(0.05), np.radians(0.5), 0.2 * tol),
    ):
        cands = best + np.arange(-half, half + step / 2, step)
        scores = [pile_up(q, a, bin_m) for a in cands]
        best = float(cands[int(np.argmax(scores))])
    return best


def pile_up(q: Array, angle: float, bin_m: float) -> float:
    """Sum of the squared counts of the points ``q`` in bins of ``bin_m`` along and
    across the direction ``angle``."""
    uv = rect_coords(q, np.zeros(2), angle)
    total = 0.0
    for k in (0, 1):
        c = np.bincount(np.floor((uv[:, k] - uv[:, k].min()) / bin_m).astype(np.intp))
        total += float(np.sum(c.astype(np.float64) ** 2))
    return total


def wall_end(along: Array, across: Array, tol: float, ap: AntaParams = ANTAE) -> float | None:
    """The end (largest ``along``) of a pier's outline when a wall runs on beyond it
    (see :func:`anta_cut`), or None.

    A side of the outline (its extreme ``across``, 0.2 or 99.8 % quantile) ends where
    its last point within ``tol`` of that extreme lies; when one side or both end
    :attr:`AntaParams.min_wall_m` before the far end, what lies beyond (the wall, its
    1-99 % quantiles across) must stand inside the pier across: not out of either of
    its sides by more than ``tol``, set in by more than ``tol`` on both, or on one and
    :attr:`AntaParams.min_wall_thickness_m` thick (a pier whose one side face was seen
    in part leaves its other side face beyond: no wall), with a face line on a set-in
    side (:func:`wall_faces`).
    """
    far = float(along.max())
    ends = []
    for flip in (1.0, -1.0):
        a = flip * across
        ends.append(float(along[a > float(np.quantile(a, 0.998)) - tol].max()))
    stepping = [e for e in ends if far - e >= ap.min_wall_m]
    if not stepping:
        return None
    end = max(stepping)
    beyond = along > end + tol
    if np.count_nonzero(beyond) < 10 or np.count_nonzero(~beyond) < 10:
        return None
    if end - float(along.min()) < ap.min_pier_share * float(np.ptp(along)):
        return None
    p_lo, p_hi = np.quantile(across[~beyond], [0.002, 0.998])
    w_lo, w_hi = np.quantile(across[beyond], [0.01, 0.99])
    if w_lo < p_lo - tol or w_hi > p_hi + tol:
        return None  # wider than the pier: no anta
    set_in = (w_lo > p_lo + tol, w_hi < p_hi - tol)
    if not any(set_in):
        return None
    if not all(set_in) and w_hi - w_lo < ap.min_wall_thickness_m:
        return None  # a side face of the pier itself, running on beyond the other's end
    faces = wall_faces(along[beyond], across[beyond], tol, ap)
    return end if any(i and f is not None for i, f in zip(set_in, faces, strict=True)) else None


def wall_faces(
    along: Array, across: Array, tol: float, ap: AntaParams = ANTAE
) -> tuple[float | None, float | None]:
    """The faces (low, high across) of the wall that set-in points (``along``,
    ``across`` the pier's axes) outline, or None for a side that shows none: in bins of
    :attr:`AntaParams.bin_m` (at least :attr:`AntaParams.min_wall_bins` holding
    points), the median of the bins' extremes on that side, when those of
    ``face_share`` of the bins lie within ``face_tol_factor x tol`` of it (a face line,
    not scattered points)."""
    k = np.floor((along - along.min()) / ap.bin_m).astype(np.intp)
    bins, inv = np.unique(k, return_inverse=True)
    if len(bins) < ap.min_wall_bins:
        return None, None
    lo = np.full(len(bins), np.inf)
    hi = np.full(len(bins), -np.inf)
    np.minimum.at(lo, inv, across)
    np.maximum.at(hi, inv, across)
    lim = ap.face_tol_factor * tol
    out = []
    for ext in (lo, hi):
        face = float(np.median(ext))
        out.append(face if np.mean(np.abs(ext - face) <= lim) >= ap.face_share else None)
    return out[0], out[1]


def cut_mask(
    xy: Array, centre: Array, cut: tuple[int, float, float, float], margin: float
) -> NDArray[np.bool_]:
    """Mask of the points ``xy`` on the pier's side of an :func:`anta_cut` made about
    ``centre``."""
    axis, sign, at, angle = cut
    u = rect_coords(xy, centre, angle)[:, axis]
    return sign * (u - at) <= margin


def cut_shape(sh: dict, xy: Array, angle: float) -> dict:
    """The section shape ``sh`` (a pier's rectangle) of the plan points ``xy`` of the
    shaft left to a pier by an :func:`anta_cut` (:func:`shaft_prism`: not its capital's
    or its plinth's): the rectangle of their 0.2-99.8 % quantiles along and across the
    faces' direction ``angle`` (radians)."""
    uv = rect_coords(xy, np.zeros(2), angle)
    lo, hi = np.quantile(uv, 0.002, axis=0), np.quantile(uv, 0.998, axis=0)
    c, s = np.cos(angle), np.sin(angle)
    mid = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    out = dict(sh)
    out["centre"] = mid[0] * np.array([c, s]) + mid[1] * np.array([-s, c])
    out["half"] = half
    out["angle"] = float(angle)
    out["radius"] = float(np.hypot(*half))
    return out


def end_at_anta(
    cidx: NDArray[np.intp], cpts: Array, sh: dict, tol: float, ap: AntaParams = ANTAE
) -> tuple[NDArray[np.intp], Array, Array] | None:
    """A pier candidate's points (``cidx``, ``cpts``) and their offsets from its section
    shape ``sh``, cut off the wall it ends (:func:`anta_cut`), or None when no wall runs
    on from it.  ``sh`` is ended at the cut in place (its ``centre`` and ``half``)."""
    cell = max(0.02, 2.0 * tol)  # the prism cells of the pier's box (describe)
    cut = anta_cut(cpts, sh["centre"], float(sh["angle"]), tol, cell, ap)
    if cut is None:
        return None
    keep = cut_mask(cpts[:, :2], sh["centre"], cut, ap.cut_margin_factor * tol)
    cpts = cpts[keep]
    shaft = shaft_prism(cpts, cell, ap)
    sh.update(cut_shape(sh, (shaft if len(shaft) >= 20 else cpts)[:, :2], cut[3]))
    return cidx[keep], offset(cpts[:, :2], sh)[0], cpts
