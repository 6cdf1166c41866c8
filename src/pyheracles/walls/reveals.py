"""Reveals: the edges of an opening through a wall from the surfaces lining it.

A window or door is lined, between the wall's two faces, by its reveals: the jambs,
the head's soffit and the sill, square to the wall (straight) or widening towards one
face (splayed).  The opening through the wall is its narrowest section, where a
straight reveal stands: a jamb's points there share one ``u`` (a plane seen edge on in
the wall's ``(u, z)`` frame, however sparse the faces are), and a splayed part spreads
outwards from it.  Glass, cames and a door leaf fill the opening at one or two depths
and are left out; mixed pixels inside the opening are few and scattered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyheracles.walls.model import Array

__all__ = [
    "RevealParams",
    "fill_edges",
    "glass_sill",
    "pane_mask",
    "reveal_edges",
    "reveal_peak",
    "soffit_head",
    "splayed_share",
]


@dataclass(frozen=True)
class RevealParams:
    """Parameters of :func:`reveal_edges` (metres, counts).

    Attributes
    ----------
    bin_m
        Histogram bin across a reveal (0.01 m); the peak is three bins wide.
    min_points
        Fewest points in the peak's three bins (8).
    contrast
        The peak's three bins hold at least this many times the median count of three
        bins over the span searched (6): a straight reveal seen edge on, not the spread
        of a splay, of mixed pixels or of the glass's stray returns beside its depth
        (church draw 0: 10 a bin across the opening, 250 on the jamb).
    sharpness
        The fullest of the peak's three bins holds at least this share of them (0.5):
        a plane seen edge on (noise of a few millimetres), not a splay seen across
        (church draw 0: a jamb 5 cm outside the opening).
    row_m, coverage
        A reveal's peak reaches at least ``coverage`` (0.5) of the rows ``row_m``
        (0.1 m) tall over the heights searched (columns across the head's band):
        church draw 8's leaded light had 11 stray returns in three bins 0.37 m inside
        its jamb, above the contrast of a sparse band.
    depth_m
        A reveal's peak spreads over at least this depth across the wall (0.03 m, the
        10th to 90th percentile): a straight reveal runs from a face to the glass
        (at least 5 cm); a scanner's column of fixed azimuth meets a splayed reveal
        along one vertical line, at one ``u`` and one depth (church draw 7: jambs of
        splayed windows 5-10 cm outside the opening).
    inward_m
        Farthest an edge is looked for inside the grid's hole (0.4 m: the widest splay
        of a reveal, 0.35 m, and a cell).
    fill_points
        Fewest points of the fill (glass and cames within ``pane_m`` of its depth)
        from which :func:`fill_edges` measures an opening (10).
    pane_m, fill_share, fill_m
        Points within ``pane_m`` (0.03 m) of the glass, cames or leaf are no reveal: of
        the median depth of the points in the opening's middle, and for a door of each
        depth within ``fill_m`` (0.1 m: a leaf 5-8 cm thick) of it where ``fill_share``
        (0.1) of them lie (see :func:`pane_mask`).
    sill_points
        Fewest points of a sill's splayed part, seen under the glass over the middle
        half of the opening's width, from which :func:`glass_sill` puts the sill at the
        glass's lowest returns (3, lower than them by more than ``bin_m``: a sill's
        straight part, seen from above, is level with them).
    splay_share, splay_band_m
        Least share (0.1) of an opening's lining at its jambs, up to ``splay_band_m``
        (0.1 m) outside them, standing outside them for its reveals to be splayed
        (:func:`splayed_share`).
    sill_gap_m
        The highest of those points stands at most this far below the glass's lowest
        returns (0.1 m): the splay seen up to the glass, whose foot the same scanners
        see over it; a far scan seeing the splay's lower part only and the glass 15 cm
        above the sill (church draw 4's south wall) does not put the sill there.
    """

    bin_m: float = 0.01
    min_points: int = 8
    contrast: float = 6.0
    sharpness: float = 0.5
    row_m: float = 0.1
    coverage: float = 0.5
    depth_m: float = 0.03
    inward_m: float = 0.4
    fill_points: int = 10
    pane_m: float = 0.03
    fill_share: float = 0.1
    fill_m: float = 0.1
    sill_points: int = 3
    sill_gap_m: float = 0.1
    splay_share: float = 0.1
    splay_band_m: float = 0.1


def reveal_peak(v: Array, lo: float, hi: float, p: RevealParams,
                along: Array | None = None, extent: tuple[float, float] | None = None,
                depth: Array | None = None) -> float:  # fmt: skip
    """Position of a straight reveal seen edge on among coordinates ``v`` (m, growing
    into the opening), in ``[lo, hi)``: the median of the densest three bins of the
    innermost run of bins passing ``min_points`` and ``contrast`` (the narrowest
    section: across a mullion, the next light's jamb is farther out) where the fullest
    of the three holds ``sharpness`` of them and, given the points' other coordinate
    ``along`` and the ``extent`` searched along it, the peak's points reach
    ``coverage`` of its ``row_m`` rows (a reveal lines the opening along its length;
    stray returns gathered in one bin do not, and the next run out is tried) and,
    given their ``depth`` across the wall, spread over ``depth_m`` of it; NaN when
    no run does."""
    inside = (v >= lo) & (v < hi)
    v = v[inside]
    if len(v) < p.min_points or hi <= lo:
        return float("nan")
    k = np.floor((v - lo) / p.bin_m).astype(np.int64)
    cnt = np.bincount(k, minlength=int(np.ceil((hi - lo) / p.bin_m)) + 2).astype(np.float64)
    three = cnt[:-2] + cnt[1:-1] + cnt[2:]
    base = float(np.median(three))
    good = np.flatnonzero(three >= max(p.min_points, p.contrast * base))
    if len(good) == 0:
        return float("nan")
    starts = np.flatnonzero(np.r_[True, np.diff(good) > 1])
    ends = np.r_[starts[1:], len(good)] - 1
    for a, b in zip(starts[::-1], ends[::-1], strict=True):  # innermost first
        j = good[a] + int(np.argmax(three[good[a] : good[b] + 1])) + 1
        if cnt[j - 1 : j + 2].max() < p.sharpness * three[j - 1]:
            continue  # spread over the three bins: a splay, not a plane edge on
        on = (k >= j - 1) & (k <= j + 1)
        if along is not None and extent is not None:
            rows = max(1, int(np.ceil((extent[1] - extent[0]) / p.row_m)))
            seen = np.unique(np.floor((along[inside][on] - extent[0]) / p.row_m))
            if len(seen) < p.coverage * rows:
                continue  # stray returns gathered at a few heights
        if depth is not None:
            d = depth[inside][on]
            if np.percentile(d, 90) - np.percentile(d, 10) < p.depth_m:
                continue  # one scan column on a splayed reveal (one depth), not a plane
        return float(np.median(v[on]))
    return float("nan")


def pane_mask(uz: Array, depth: Array, u0: float, u1: float, z0: float, z1: float,
              p: RevealParams, leaf: bool = False) -> np.ndarray:  # fmt: skip
    """Points that may line the opening ``u0``-``u1`` x ``z0``-``z1``: not within
    ``pane_m`` of a depth of what fills its middle (the points in its central half, when
    at least 5: their median depth, and for a door's ``leaf`` each depth within
    ``fill_m`` of it where ``fill_share`` of them, and 5 at least, lie within ``bin_m``).

    Glass 1-4 cm thick lies within ``pane_m`` of its median depth.  A door leaf 5-8 cm
    thick is seen on both its faces, from inside and from outside: two depths, and
    the columns of points on the one not left out, beside a jamb, made a reveal
    there (church draws 4 and 9: door jambs put on the leaf 0.2-0.35 m inside the
    opening).
    """
    uc, zc = 0.5 * (u0 + u1), 0.5 * (z0 + z1)
    mid = (np.abs(uz[:, 0] - uc) < 0.25 * (u1 - u0)) & (np.abs(uz[:, 1] - zc) < 0.25 * (z1 - z0))
    if np.count_nonzero(mid) < 5:
        return np.ones(len(uz), dtype=bool)
    dm = np.sort(depth[mid])
    near = np.searchsorted(dm, dm + p.bin_m, "right") - np.searchsorted(dm, dm - p.bin_m)
    med = float(np.median(dm))
    two = (near >= max(5.0, p.fill_share * len(dm))) & (np.abs(dm - med) <= p.fill_m) & leaf
    fill = np.sort(np.r_[dm[two], med])
    k = np.clip(np.searchsorted(fill, depth), 1, len(fill)) - 1  # the fills either side
    nxt = fill[np.minimum(k + 1, len(fill) - 1)]
    gap = np.minimum(np.abs(depth - fill[k]), np.abs(depth - nxt))
    return gap > p.pane_m


def reveal_edges(uz: Array, depth: Array, u0: float, u1: float, z0: float, z1: float,
                 c: float, jambs: tuple[float, float] | None = None,
                 p: RevealParams | None = None, leaf: bool = False,
                 ) -> tuple[float, float, float, float]:  # fmt: skip
    """Jambs, sill and head of an opening from the points between the wall's faces
    around it (``uz`` on the wall plane, ``depth`` across it; NaN: not measured).

    The grid's hole ``u0``-``u1`` x ``z0``-``z1`` (cell ``c``) is where neither face
    is: a splayed face's hole is wider than the opening by its splay, a sparse face's
    reaches into the gaps between its points.  Each jamb is looked for from two cells
    outside the grid's edge to ``inward_m`` inside it (not past the middle), among the
    points at the heights where the hole has its full width (``jambs``; default its
    upper part below the head); the head among the points of the central column band
    (a tenth of the width, at least a cell), from ``inward_m`` below the grid's head to
    four cells above it (the apex of a pointed head, closed in the grid).  The sill is
    not measured (NaN): its straight part faces up, out of sight of scanners below it,
    and the straight jambs' lowest points seen stood 0.1-0.4 m above it (church draw 4).
    """
    p = p or RevealParams()
    nan = float("nan")
    if len(uz) < p.min_points:
        return nan, nan, nan, nan
    ok = pane_mask(uz, depth, u0, u1, z0, z1, p, leaf)
    q, dq = uz[ok], depth[ok]
    h = z1 - z0
    lo_z, hi_z = (z0 + 0.25 * h, z1 - 0.1 * h) if jambs is None else jambs
    band = (q[:, 1] > lo_z) & (q[:, 1] < hi_z)
    uc, zc = 0.5 * (u0 + u1), 0.5 * (z0 + z1)
    zs, ds = q[band, 1], dq[band]
    left = reveal_peak(q[band, 0], u0 - 2 * c, min(u0 + p.inward_m, uc), p, zs, (lo_z, hi_z),
                       ds)  # fmt: skip
    right = -reveal_peak(-q[band, 0], -(u1 + 2 * c), -max(u1 - p.inward_m, uc), p, zs,
                         (lo_z, hi_z), ds)  # fmt: skip
    a = u0 if np.isnan(left) else left
    b = u1 if np.isnan(right) else right
    half = max(0.05 * (b - a), c)
    centre = np.abs(q[:, 0] - 0.5 * (a + b)) < half
    head = -reveal_peak(-q[centre, 1], -(z1 + 4 * c), -max(z1 - p.inward_m, zc), p,
                        q[centre, 0], (0.5 * (a + b) - half, 0.5 * (a + b) + half),
                        dq[centre])  # fmt: skip
    sill = nan  # its straight part faces up, out of sight of scanners below
    return left, right, sill, head


def fill_edges(uz: Array, depth: Array, u0: float, u1: float, z0: float, z1: float,
               p: RevealParams | None = None) -> tuple[float, float, float, float]:  # fmt: skip
    """Jambs, sill and head of the glass filling an opening (NaN: fewer than
    ``fill_points`` points of it in the grid's hole ``u0``-``u1`` x ``z0``-``z1``).

    The glass and its cames fill a window at its narrowest section (a pane set in the
    straight reveal behind a splay): the points of the hole within ``pane_m`` of the
    fill's depth (:func:`pane_mask`) span the opening, each edge put by the second
    outermost of them (a stray return beyond one is left out).  Glass returns few
    points, and those of its lower part are hidden from scanners below behind the sill
    (church draw 4: the lowest 0.1-0.4 m above the sill), so the edges are for an
    opening whose faces do not measure it (see :func:`~pyheracles.walls.outlines.wall_outline`).
    """
    p = p or RevealParams()
    nan = float("nan")
    hole = (uz[:, 0] > u0) & (uz[:, 0] < u1) & (uz[:, 1] > z0) & (uz[:, 1] < z1)
    q, dq = uz[hole], depth[hole]
    if len(q) < p.fill_points:
        return nan, nan, nan, nan
    fill = q[~pane_mask(q, dq, u0, u1, z0, z1, p)]
    if len(fill) < p.fill_points:
        return nan, nan, nan, nan
    us, zs = np.sort(fill[:, 0]), np.sort(fill[:, 1])
    return float(us[1]), float(us[-2]), float(zs[1]), float(zs[-2])


def soffit_head(uz: Array, depth: Array, u0: float, u1: float, z1: float, c: float,
                bin_m: float = 0.05, min_points: int = 3,
                below_m: float | None = None) -> float:  # fmt: skip
    """Head of an opening ``u0``-``u1`` whose grid head is ``z1`` (cell ``c``) from the
    points between the wall's faces at full resolution (``uz`` on the wall plane,
    ``depth`` across it): the least over the depths (``bin_m`` bins holding at least
    ``min_points``) of their highest point over the opening's centre (a tenth of its
    width, at least a cell), from ``below_m`` under ``z1`` (default a cell) up to four
    cells above it; NaN when no depth holds enough.

    Nothing stands between the faces above the head but the wall: the soffit, the glass
    and its cames reach up to the head and no higher, and a splayed soffit rises from the
    narrowest section towards its face (the least over the depths is the narrowest).  The
    apex of a pointed head is a narrow wedge that the grid closes, 6-13 cm of it, and a
    sparse face has no point within reach of it (church draws 17 and 18: heads short with
    the soffit seen up to the apex, but thinned to one point per 6 cm in the detection
    sample that the reveals are read from).  A grid's head over the opening, a splayed
    face's hole with the other face's too sparse to close it, has only the splayed
    soffit over it, rising to its face: searched from a splay under it (``below_m``),
    the least is the narrowest section's (church draw 4: heads 8-17 cm high).
    """
    uc, half = 0.5 * (u0 + u1), max(0.05 * (u1 - u0), c)
    below = c if below_m is None else below_m
    sel = (np.abs(uz[:, 0] - uc) < half) & (uz[:, 1] > z1 - below) & (uz[:, 1] <= z1 + 4 * c)
    if np.count_nonzero(sel) < min_points:
        return float("nan")
    k = np.floor(depth[sel] / bin_m).astype(np.int64)
    k -= k.min()
    n = np.bincount(k)
    top = np.full(len(n), -np.inf)
    np.maximum.at(top, k, uz[sel, 1])
    ok = n >= min_points
    return float(top[ok].min()) if ok.any() else float("nan")


def glass_sill(uz: Array, depth: Array, hole: tuple[float, float, float, float],
               jambs: tuple[float, float], p: RevealParams | None = None) -> float:  # fmt: skip
    """Sill of a window from the points between the wall's faces at full resolution
    (``uz`` on the wall plane, ``depth`` across it): the glass's lowest returns (the
    second lowest point of the grid's ``hole`` ``(u0, u1, z0, z1)``, lower half, within
    ``pane_m`` of the fill's depth, :func:`pane_mask`) where its reveals are splayed
    (:func:`splayed_share` of the lining outside the opening's ``jambs`` at least
    ``splay_share``) and the sill's splay is seen under the glass (``sill_points``
    points more than ``bin_m`` and up to ``inward_m`` below its lowest returns, over
    the middle half of the width, not the glass, the highest within ``sill_gap_m``);
    NaN otherwise.

    The glass stands on the sill.  A sill's straight part, from a face to the glass,
    faces up and is out of sight from below; a splayed part falls from the glass to
    the other face, and a scanner below sees it when its rays rise less steeply than
    it falls, the same rays that reach the foot of the glass over its inner edge: where
    the splay is seen, so is the glass down to the sill (church draws 1, 4 and 12: the
    sills of splayed faces' holes and of faces 15-18 cm between points 3-27 cm low, the
    glass's lowest returns within 2 cm of the sills).  Where the reveals are straight,
    the glass's foot is out of sight from below on both sides, and mixed pixels of
    rays grazing a sill's edge on their way to the glass stand under its lowest
    returns as a splay would (church draw 2: glass seen from 12 cm over the sill).
    """
    p = p or RevealParams()
    nan = float("nan")
    u0, u1, z0, z1 = hole
    zc = 0.5 * (z0 + z1)
    box = (uz[:, 0] > u0 - p.inward_m) & (uz[:, 0] < u1 + p.inward_m)
    box &= (uz[:, 1] > z0 - p.inward_m) & (uz[:, 1] < z1)
    q, dq = uz[box], depth[box]
    if len(q) < p.fill_points:
        return nan
    off = pane_mask(q, dq, u0, u1, z0, z1, p)
    inside = (q[:, 0] > u0) & (q[:, 0] < u1) & (q[:, 1] < zc)
    glass = np.sort(q[~off & inside, 1])
    if len(glass) < p.fill_points:
        return nan
    low = float(glass[1])
    rows = off & (q[:, 1] > z0 + 0.25 * (z1 - z0)) & (q[:, 1] < zc)
    if splayed_share(q[rows, 0], jambs, p) < p.splay_share:
        return nan
    mid = np.abs(q[:, 0] - 0.5 * (u0 + u1)) < 0.25 * (u1 - u0)
    under = off & mid & (q[:, 1] < low - p.bin_m) & (q[:, 1] > low - p.inward_m)
    if np.count_nonzero(under) < p.sill_points or q[under, 1].max() < low - p.sill_gap_m:
        return nan
    return low


def splayed_share(u: Array, jambs: tuple[float, float], p: RevealParams) -> float:
    """Share of the points ``u`` (m, along the wall) of an opening's lining at the
    heights of its jambs, from ``pane_m`` inside a jamb (``jambs``: the opening's, at
    its narrowest section) to ``splay_band_m`` outside it, that stand more than
    ``pane_m`` outside it (0 where none): a splayed reveal widens from the narrowest
    section to its face, its points spread outside the opening; a straight one stands
    at it, and the next light's jamb across a mullion stands farther out (church
    draw 2: none of 2600 points of straight reveals, some across mullions 0.2 m wide;
    draws 1, 4 and 12's splayed windows, a sixth to a half)."""
    out = np.r_[jambs[0] - u, u - jambs[1]]
    near = (out > -p.pane_m) & (out <= p.splay_band_m)
    n = np.count_nonzero(near)
    return float(np.count_nonzero(near & (out > p.pane_m))) / n if n else 0.0
