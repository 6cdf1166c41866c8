"""Piers seen face-on: one straight face standing free and rising from the floor.

A pier scanned from one side only (a station straight in front of it, its other faces
in the shadow of its neighbours) leaves one straight line of points in a section, as a
piece of wall does: too thin for a support island, it is noise when shorter than 1 m
and a wall when longer (supports draw 27: a hypostyle whose piers far from the one
station inside are lines 0.15-0.63 m long; draw 30: two 2.0 x 1.77 m piers of a portico
seen from the front, 2.0 x 0.07 m lines; draws 7 and 12 alike).  What tells it from a
wall is what the section alone cannot see: the line ends free (no section points go on
along it past its ends) and its face rises from the floor over most of the height in
its footprint.  Such a line is a pier candidate; the wall-piece tests of the other
piers (a wall running on in line with it, in bands of its height) and the
cookie-cutter's height and carried tests then judge it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Island, Scales, SupportParams, trimmed_rms
from pyheracles.supports.piers import WALL_LINE_COVER_M, WALL_LINE_GAP_M
from pyheracles.supports.sections import pool_groups

__all__ = [
    "FaceOnParams",
    "continues_line",
    "face_line_of",
    "face_on_piers",
    "on_wall_line",
    "rises_from_floor",
    "run_bounds",
]


@dataclass(frozen=True)
class FaceOnParams:
    """When a straight section line is the face of a pier seen face-on.

    Attributes
    ----------
    max_width_tol
        The line's points lie within this many surface tolerances of it (trimmed RMS),
        and its width across is at most twice that (a face, not an L or a ring).
    end_gap_m
        Its ends are free: no section points on its line within this distance past
        either end, metres (the gap between two windows' jambs is larger: those pieces
        are judged by the wall-piece tests).
    end_points
        At most this many section points may lie there (noise, a chair leg).
    layer_m
        Height of the layers in which the face must rise, metres.
    rise_share
        The face holds points in at least this share of the layers from the floor up to
        the section and from the section up to the top of the face.
    foot_m
        The face stands free from this height above the floor up to the section, metres
        (the floor's own points lie on every line below it).
    run_reach_m, run_cover
        A wall runs on in line from an end in a layer when points on the line (within the
        surface tolerance) cover ``run_cover`` of the ``run_reach_m`` metres beyond that
        end (in bins of three times the face's own point spacing in that layer: the
        local density, not the cloud's).
    max_run_layers
        A face-on pier has a wall running on from one of its ends in at most this many
        of the layers where it stands free (a jamb has the wall under the sill or
        beside a door; the wall below a window is one with it).
    corner_cover_m
        A wall turning at an end covers at least this length of the perpendicular
        through that end in the section, metres (a face-on pier shows a graze of its
        sides: 0.4 m at most in the supports family's draws 6, 12, 27 and 37).
    line_slope
        A short face line's direction is known to about two degrees: the line beyond
        its ends is searched within the surface tolerance plus this slope times the
        distance from the end.
    outline_share, outline_gap_m
        A face on the building's outline has (almost) nothing behind it: at most
        ``outline_share`` of the section's points lie further than ``outline_gap_m``
        metres from its line on one side.
    run_gap_m
        The points of a wall's face along its line are one run while no gap between
        them exceeds this, metres (:func:`on_wall_line`).
    """

    max_width_tol: float = 1.0
    end_gap_m: float = 0.5
    end_points: int = 3
    layer_m: float = 0.25
    rise_share: float = 0.6
    foot_m: float = 0.3
    run_reach_m: float = 0.3
    run_cover: float = 0.5
    max_run_layers: int = 1
    corner_cover_m: float = 0.75
    line_slope: float = 0.035
    outline_share: float = 0.01
    outline_gap_m: float = 0.1
    run_gap_m: float = 0.2


def face_line_of(xy: Array, tol: float, p: FaceOnParams) -> tuple[Array, Array, float] | None:
    """The straight line an island's points ``xy`` lie on: centre, unit direction and
    length (metres), or None when they do not lie on one within the tolerance ``tol``
    (trimmed RMS across <= ``p.max_width_tol x tol / 2``)."""
    if len(xy) < 3:
        return None
    c = xy.mean(axis=0)
    q = xy - c
    _, vec = np.linalg.eigh(q.T @ q)
    u = vec[:, 1]
    along, across = q @ u, q @ np.array([-u[1], u[0]])
    if trimmed_rms(across) > 0.5 * p.max_width_tol * tol:
        return None
    lo, hi = np.quantile(along, [0.01, 0.99])
    return c + u * 0.5 * (lo + hi), u, float(hi - lo)


def ends_free(
    sec_xy: Array, c: Array, u: Array, length: float, tol: float, p: FaceOnParams
) -> bool:
    """Whether no more than ``p.end_points`` section points lie on the line (within
    ``tol``) between its ends and ``p.end_gap_m`` beyond them."""
    q = sec_xy - c
    along = np.abs(q @ u)
    across = np.abs(q @ np.array([-u[1], u[0]]))
    beyond = (across <= tol) & (along > 0.5 * length + tol) & (along <= 0.5 * length + p.end_gap_m)
    return int(np.count_nonzero(beyond)) <= p.end_points


def rises_from_floor(
    layers: list[Array],
    c: Array,
    u: Array,
    length: float,
    tol: float,
    k_sec: int,
    p: FaceOnParams,
) -> bool:
    """Whether the face's footprint (the line's length, ``tol`` either side) holds
    points in ``p.rise_share`` of the layers ``layers`` (plan points of consecutive
    height layers from the floor up) below the section's layer ``k_sec``, and in as
    many of those from it up to the highest layer it holds points in."""
    n = np.array(
        [
            np.count_nonzero(
                (np.abs((xy - c) @ u) <= 0.5 * length)
                & (np.abs((xy - c) @ np.array([-u[1], u[0]])) <= tol)
            )
            for xy in layers
        ]
    )
    held = n >= 2
    if not held[: k_sec + 1].any():
        return False
    top = int(np.flatnonzero(held).max())
    below, above = held[: k_sec + 1], held[k_sec : max(top, k_sec) + 1]
    return bool(below.mean() >= p.rise_share and above.mean() >= p.rise_share)


def runs_on_in_line(
    layers: list[Array], c: Array, u: Array, length: float, tol: float, reach_m: float, cover: float
) -> NDArray[np.int64]:
    """Per end of a face line (low, high along ``u``), the number of layers in which
    points on the line (within ``tol`` across) cover ``cover`` of the ``reach_m``
    beyond that end, in bins of three times the line's own point spacing in that layer
    (at least 5 cm; the layer's own points along the face: a face far from the
    scanners is crossed by scan lines further apart).  Layers whose footprint holds
    fewer than 3 points of the face are not read."""
    nrm = np.array([-u[1], u[0]])
    out = np.zeros(2, dtype=np.int64)
    for xy in layers:  # loop over layers
        q = xy - c
        on = np.abs(q @ nrm) <= tol
        t = q[on] @ u
        own = np.sort(t[np.abs(t) <= 0.5 * length])
        if len(own) < 3:
            continue
        bin_m = max(0.05, 3.0 * float(np.median(np.diff(own))))
        n_bins = max(1, int(np.ceil(reach_m / bin_m)))
        for e, sign in enumerate((-1.0, 1.0)):
            d = sign * t - 0.5 * length - tol
            d = d[(d > 0) & (d <= reach_m)]
            out[e] += len(np.unique(np.floor(d / bin_m))) >= cover * n_bins
    return out


def wall_from_ends(
    sec_xy: Array,
    own: NDArray[np.intp],
    c: Array,
    u: Array,
    length: float,
    tol: float,
    bin_m: float,
    p: FaceOnParams,
) -> bool:
    """Whether a wall goes on from a face line's ends in the section: the section's
    other points within ``tol`` of the line beyond an end (up to
    :data:`~pyheracles.supports.piers.WALL_LINE_GAP_M`) cover
    :data:`~pyheracles.supports.piers.WALL_LINE_COVER_M` of it (the wall between two
    openings is broken into short lines, none of them a wall island: supports draw 37,
    the pieces of an end wall between its doors), or those within ``tol`` of the
    perpendicular through an end cover ``p.corner_cover_m`` of it (a wall turning at a
    corner; a pier seen face-on shows at most a short graze of its sides)."""
    other = np.ones(len(sec_xy), dtype=bool)
    other[own] = False
    q = sec_xy[other] - c
    t, s = q @ u, q @ np.array([-u[1], u[0]])
    half = 0.5 * length
    sides = np.count_nonzero(s > p.outline_gap_m), np.count_nonzero(s < -p.outline_gap_m)
    if min(sides) <= p.outline_share * sum(sides):
        return True  # on the building's outline: the section holds (almost) nothing behind it

    def cover(x: Array) -> float:
        return len(np.unique(np.floor(x / bin_m))) * bin_m

    # a short line's direction is known to a degree or two: the cone widens along it
    beyond = (
        (np.abs(s) <= tol + p.line_slope * np.maximum(np.abs(t) - half, 0.0))
        & (np.abs(t) > half + tol)
        & (np.abs(t) <= half + WALL_LINE_GAP_M)
    )
    for side in (-1.0, 1.0):  # loop over ends
        end = beyond & (side * t > 0)
        if cover(t[end]) >= WALL_LINE_COVER_M and continues_line(
            t[end], s[end], side * half, tol, bin_m
        ):
            return True
        across = (
            (np.abs(t - side * half) <= tol) & (np.abs(s) > tol) & (np.abs(s) <= WALL_LINE_GAP_M)
        )
        if max(cover(s[across & (s > 0)]), cover(-s[across & (s < 0)])) >= p.corner_cover_m:
            return True
    return False


def continues_line(t: Array, s: Array, end: float, tol: float, bin_m: float) -> bool:
    """Whether the points ``(t, s)`` beyond a face line's end (``t`` along the line,
    ``s`` across it, metres) continue that line: those within ``tol`` of it cover
    :data:`~pyheracles.supports.piers.WALL_LINE_COVER_M` (in bins of ``bin_m``), or the
    line fitted to all of them meets the line's end ``t = end`` within ``tol``.

    The cone beyond a short line widens with the distance (its direction is known to a
    degree or two), and far out it takes in a parallel face set back from the line: the
    faces of the wall an anta ends, 0.1 m in from the anta's sides, run on beyond
    them and within the cone two metres out (supports draw 14: both side faces of an
    anta, 0.52 m long, were a wall going on).  A wall continuing the face lies on its
    line at the end, whatever the line's small error of direction.
    """
    on = np.abs(s) <= tol
    if len(np.unique(np.floor(t[on] / bin_m))) * bin_m >= WALL_LINE_COVER_M:
        return True
    if len(t) < 3:
        return False
    a, b = np.polyfit(t, s, 1)
    return bool(abs(a * end + b) <= tol)


def run_bounds(t: Array, gap_m: float) -> list[tuple[float, float]]:
    """The runs of the positions ``t`` (metres along a line) in which no two
    neighbours are more than ``gap_m`` apart: their ends, the longest first."""
    if len(t) < 2:
        return []
    t = np.sort(t)
    breaks = np.flatnonzero(np.diff(t) > gap_m)
    starts, ends = t[np.r_[0, breaks + 1]], t[np.r_[breaks, len(t) - 1]]
    order = np.argsort(starts - ends)
    return [(float(starts[k]), float(ends[k])) for k in order]


def on_wall_line(
    xy: Array, c: Array, u: Array, length: float, tol: float, run_m: float, gap_m: float
) -> bool:
    """Whether a face line lies on the line of a wall at the building's scale: the
    points ``xy`` (the section's) on its line beyond its ends, anywhere over the
    building, hold a run (:func:`run_bounds`, gaps up to ``gap_m``) longer than
    ``run_m`` (longer than any support: a wall) whose own line passes through the
    face's centre ``c`` within ``tol``.

    The face of a wall seen only from outside, through a colonnade, is cut into pieces
    by the shadows of the supports: a piece of pier width between two shadows has free
    ends and rises from the floor like a pier seen face-on, but the wall's other
    pieces lie on its line metres away (supports draws 11, 30, 33: the inner face of
    a portico's back wall and of a nave's side wall).  A face-on pier in a row of
    piers has the faces of its neighbours on its line, each shorter than a support,
    and a wall parallel to the row off its line.  A short face's direction is known to
    ``atan(2 tol / length)``: the line is turned within that about the face's centre,
    in steps that move its far end by half the tolerance; a run it meets is a wall on
    the face's line only when the run's own line (fitted to it) goes through the face
    (turned, the line also crosses a parallel wall at a glancing angle).
    """
    nrm = np.array([-u[1], u[0]])
    q = xy - c
    t, s = q @ u, q @ nrm
    turn = float(np.arctan(2.0 * tol / max(length, tol)))
    cone = (np.abs(t) > 0.5 * length + tol) & (np.abs(s) <= tol + np.abs(t) * np.tan(turn))
    t, s = t[cone], s[cone]
    if len(t) < 2 or float(np.ptp(t)) <= run_m:
        return False
    step = 0.5 * tol / float(np.max(np.abs(t)))
    seen: set[tuple[float, float]] = set()
    for slope in np.tan(np.arange(-turn, turn + step, step)):  # loop over directions
        on = np.abs(s - t * slope) <= tol
        for side in (t > 0, t < 0):
            for lo, hi in run_bounds(t[on & side], gap_m):  # loop over runs, longest first
                if hi - lo <= run_m:
                    break
                key = (round(lo, 2), round(hi, 2))
                if key in seen:
                    continue
                seen.add(key)
                run = on & side & (t >= lo) & (t <= hi)
                a, b = np.polyfit(t[run], s[run], 1)
                if abs(b) <= tol and abs(a) <= np.tan(turn):
                    return True
    return False


def line_groups(
    sec_xy: Array, islands: list[Island], params: SupportParams, distance_m: float, tol: float
) -> list[NDArray[np.intp]]:
    """Indices of the section's point groups that may be lines: its wall and noise
    islands, and the points left over (in no island or in noise islands) grouped again
    at the gaps of :func:`~pyheracles.supports.sections.sparse_gaps`, the largest first
    (a face far from the scanners is crossed by scan lines further apart than the
    clustering distance: its points are left over); a group that is a straight line
    within ``tol`` (:func:`face_line_of`) leaves the pool."""
    groups = [i.index for i in islands if i.kind in ("noise", "wall")]
    used = np.zeros(len(sec_xy), dtype=bool)
    for i in islands:
        if i.kind != "noise":
            used[i.index] = True
    for sub in pool_groups(sec_xy, used, distance_m, params.min_points, params.min_points):
        if face_line_of(sec_xy[sub], tol, FaceOnParams()) is not None:
            groups.append(sub)
            used[sub] = True
    return groups


def face_on_piers(
    sec_xy: Array,
    islands: list[Island],
    band: Callable[[float, float], NDArray[np.intp]],
    xyz: Array,
    z_range: tuple[float, float],
    h_sec: float,
    params: SupportParams,
    sc: Scales,
    p: FaceOnParams | None = None,
) -> list[Island]:
    """Pier islands of the straight noise and wall islands of a section that are faces
    of piers seen face-on: between ``min_support_size_m`` and ``max_support_size_m``
    long, on a line within the surface tolerance, free at both ends
    (:func:`ends_free`) and rising from the floor past the section ``h_sec``
    (:func:`rises_from_floor`, in slabs every ``p.layer_m`` from the floor to the top,
    ``z_range``; ``band(z_lo, z_hi)`` gives the indices of the points of ``xyz``
    between two heights).

    Returns the new islands (kind ``pier``, the face's rectangle: its length by twice
    the tolerance), to be judged like any pier island.
    """
    p = p or FaceOnParams()
    cands = []
    for index in line_groups(sec_xy, islands, params, sc.distance, sc.tol):
        line = face_line_of(sec_xy[index], sc.tol, p)
        if line is None or not params.min_support_size_m <= line[2] <= params.max_support_size_m:
            continue
        if (
            ends_free(sec_xy, *line, sc.tol, p)
            and not wall_from_ends(sec_xy, index, *line, sc.tol, max(0.05, 3.0 * sc.spacing), p)
            and not on_wall_line(sec_xy, *line, sc.tol, params.max_support_size_m, p.run_gap_m)
        ):
            cands.append((index, line))
    if not cands:
        return []
    floor_z, top_z = z_range
    n_lay = max(1, int(np.ceil((h_sec - floor_z) / p.layer_m)))
    k_sec = n_lay - 1
    mids = floor_z + p.layer_m * (np.arange(max(n_lay, int((top_z - floor_z) / p.layer_m))) + 0.5)
    half = 0.5 * min(p.layer_m, max(2.0 * sc.thickness, 0.1))
    # the plan points of a slab in each layer, near any candidate (one pass over them)
    margin = sc.tol + p.run_reach_m
    lo = np.min([c - 0.5 * ln * np.abs(u) - margin for _, (c, u, ln) in cands], axis=0)
    hi = np.max([c + 0.5 * ln * np.abs(u) + margin for _, (c, u, ln) in cands], axis=0)
    layers = []
    for z in mids:  # loop over layers
        xy = xyz[band(float(z - half), float(z + half)), :2]
        layers.append(xy[np.all((xy >= lo) & (xy <= hi), axis=1)])
    free = (mids >= floor_z + p.foot_m) & (mids <= h_sec)  # layers where it stands free
    out = []
    for index, (c, u, length) in cands:  # loop over candidates
        near = [lay[np.all(np.abs(lay - c) <= 0.5 * length + sc.tol, axis=1)] for lay in layers]
        wide = [
            lay[np.all(np.abs(lay - c) <= 0.5 * length + margin, axis=1)]
            for lay, f in zip(layers, free, strict=False)
            if f
        ]
        runs = runs_on_in_line(wide, c, u, length, sc.tol, p.run_reach_m, p.run_cover)
        if int(runs.max()) > p.max_run_layers:
            continue
        if rises_from_floor(near, c, u, length, sc.tol, k_sec, p):
            size = np.array([length, 2.0 * sc.tol])
            angle = float(np.arctan2(u[1], u[0]))
            nan = float("nan")
            out.append(Island("pier", index, c, nan, angle, size, nan, nan, nan))
    return out
