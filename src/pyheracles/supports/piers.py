"""Rectangles in a section: the rectangle residual of an island, wall pieces that are no piers."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.supports.core import Array, Island, trimmed_rms
from pyheracles.supports.sparse_faces import runs_on_sparse


def rect_coords(xy: Array, centre: Array, angle: float) -> Array:
    """``(N, 2)`` coordinates of points along and across a rectangle turned by ``angle``
    (radians) about its ``centre``."""
    c, s = np.cos(angle), np.sin(angle)
    q = xy - centre
    return np.c_[q @ np.array([c, s]), q @ np.array([-s, c])]


def rect_rms(xy: Array, centre: Array, angle: float, size: Array) -> tuple[float, Array]:
    """RMS distance to a rectangle whose edges are re-estimated as medians (2 rounds)."""
    c, s = np.cos(angle), np.sin(angle)
    uv = rect_coords(xy, centre, angle)
    lo, hi = -size / 2, size / 2
    for _ in range(2):
        d = np.stack(
            [
                np.abs(uv[:, 0] - lo[0]),
                np.abs(uv[:, 0] - hi[0]),
                np.abs(uv[:, 1] - lo[1]),
                np.abs(uv[:, 1] - hi[1]),
            ],
            axis=1,
        )
        k = d.argmin(axis=1)
        for j, (arr, col) in enumerate(((lo, 0), (hi, 0), (lo, 1), (hi, 1))):
            sel = k == j
            if sel.sum() >= 2:
                arr[col] = np.median(uv[sel, col])
    d = np.stack(
        [
            np.abs(uv[:, 0] - lo[0]),
            np.abs(uv[:, 0] - hi[0]),
            np.abs(uv[:, 1] - lo[1]),
            np.abs(uv[:, 1] - hi[1]),
        ],
        axis=1,
    )
    mid = (lo + hi) / 2
    new_centre = centre + mid[0] * np.array([c, s]) + mid[1] * np.array([-s, c])
    return trimmed_rms(d.min(axis=1)), np.r_[new_centre, hi - lo]


#: Hull edges within this angle (mod 90 degrees) give one candidate rectangle direction.
OUTLINE_ANGLE_BIN = np.radians(0.5)


def outline_rectangle(xy: Array) -> tuple[Array, float, Array]:
    """The rectangle whose outline the points ``xy`` lie on (centre, angle, size).

    The minimum-area enclosing rectangle is the outline of a pier scanned all round, but
    not of one seen from a corner: the two faces in view make an L whose hull is a
    triangle, and the smallest rectangle around a triangle lies along its hypotenuse,
    the diagonal of the pier (draw 27 of the supports family: a pier 1.07 x 0.72 m seen
    as a 1.27 x 0.59 m rectangle turned 35 degrees, its points 6 cm off that outline).
    Each direction of a hull edge (mod 90 degrees) gives the bounding rectangle in that
    direction; the one whose outline the points are closest to (trimmed RMS) is kept,
    ties to the smaller area.

    Parameters
    ----------
    xy
        ``(N, 2)`` points, metres.

    Returns
    -------
    centre : (2,) array
    angle : float
        Direction of the first side, radians from +x.
    size : (2,) array
        Side lengths along the first and second direction (first >= second), metres.
    """
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(xy, dtype=np.float64)
    m = p.mean(axis=0)
    q = p - m
    try:
        hull = q[ConvexHull(q).vertices]
    except (QhullError, ValueError):
        hull = q
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
    ang = np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2)
    ang = np.unique(np.round(ang / OUTLINE_ANGLE_BIN)) * OUTLINE_ANGLE_BIN
    cos, sin = np.cos(ang), np.sin(ang)
    u = q @ np.vstack([cos, sin])  # (N, A)
    v = q @ np.vstack([-sin, cos])
    lo_u, hi_u, lo_v, hi_v = u.min(0), u.max(0), v.min(0), v.max(0)
    d = np.minimum(np.minimum(u - lo_u, hi_u - u), np.minimum(v - lo_v, hi_v - v))
    keep = max(1, int(0.9 * len(q)))  # the trimmed RMS of :func:`trimmed_rms`, per angle
    rms = np.sqrt(np.mean(np.sort(d, axis=0)[:keep] ** 2, axis=0))
    area = (hi_u - lo_u) * (hi_v - lo_v)
    k = int(np.lexsort((area, np.round(rms, 4)))[0])
    su, sv = hi_u[k] - lo_u[k], hi_v[k] - lo_v[k]
    cu, cv = (hi_u[k] + lo_u[k]) / 2, (hi_v[k] + lo_v[k]) / 2
    a = float(ang[k])
    centre = m + np.array([cu * cos[k] - cv * sin[k], cu * sin[k] + cv * cos[k]])
    if sv > su:
        su, sv, a = sv, su, a + np.pi / 2
    return centre, a, np.array([su, sv])


#: No passage is narrower: section points this close around a pier belong to what it
#: stands in (metres).
CLEARANCE_M = 0.5
#: A wall face alongside a pier candidate runs on beyond one of its ends over at least
#: this length (metres).
WALL_RUN_M = 0.5 * CLEARANCE_M


def wall_fragment(xy: Array, isl: Island, tree: cKDTree, band_m: float) -> bool:
    """A pier island is a piece of a wall when the wall goes on beside it.

    A pier stands free.  The pieces of a wall broken up in the section (gaps in sparse
    or occluded data, narrow slits) have the next pieces of the same wall in line with
    them: within :data:`CLEARANCE_M` beyond one of their sides, inside the band of
    their own width (plus ``band_m``), at least half as many section points as their
    own (as many in the middle of the wall, about half at its ends).  Clutter beside a
    pier (a fence, a bench, a scaffold) is not in line with it.
    """
    half = np.maximum(isl.size / 2, 1e-6)
    need = 0.5 * len(isl.index)
    near = tree.query_ball_point(isl.center, float(np.hypot(*half)) + CLEARANCE_M)
    others = np.setdiff1d(np.asarray(near, dtype=np.intp), isl.index, assume_unique=False)
    if len(others) < need:
        return False
    u, v = np.abs(rect_coords(xy[others], isl.center, isl.angle)).T
    beyond_u = (u > half[0]) & (u <= half[0] + CLEARANCE_M) & (v <= half[1] + band_m)
    beyond_v = (v > half[1]) & (v <= half[1] + CLEARANCE_M) & (u <= half[0] + band_m)
    return max(int(beyond_u.sum()), int(beyond_v.sum())) >= need


#: An opening or a breach in a wall is at most this wide: a wall face this far beyond a
#: pier candidate's side, on the line of that side, is the same wall (metres).
WALL_LINE_GAP_M = 3.0
#: A wall face on the line of a side covers at least this length (metres); a wall
#: crossing the line covers its own thickness there, two scanned faces of a few cm.
WALL_LINE_COVER_M = 0.5


def in_wall_line(isl: Island, wall_xy: Array, tol: float, bin_m: float) -> bool:
    """A pier candidate is a piece of a wall when one of its sides lies on a wall face.

    The piece of a wall between two openings (doors, windows, the breaches of a ruin)
    is cut off in the section like a pier, but its sides facing the room and the
    outside lie on the faces of the wall that goes on beyond the openings: wall points
    (``wall_xy``, the wall islands of the section) within ``tol`` of the line of one of
    its sides, beyond its ends and at most :data:`WALL_LINE_GAP_M` from them, that
    cover at least :data:`WALL_LINE_COVER_M` of that line in bins of ``bin_m``.  A free
    pier in front of a wall, or in a row of piers, has no wall on the lines of its
    sides (a fence between piers runs on their axis, not on a face).
    """
    if len(wall_xy) == 0:
        return False
    half = np.maximum(isl.size / 2, 1e-6)
    u, v = rect_coords(wall_xy, isl.center, isl.angle).T
    need = max(2, int(np.ceil(WALL_LINE_COVER_M / bin_m)))
    for across, along, h_across, h_along in ((v, u, half[1], half[0]), (u, v, half[0], half[1])):
        beyond = (np.abs(along) > h_along + tol) & (np.abs(along) <= h_along + WALL_LINE_GAP_M)
        for side in (-h_across, h_across):
            on = beyond & (np.abs(across - side) <= tol)
            if np.count_nonzero(on) >= need and len(np.unique(np.floor(along[on] / bin_m))) >= need:
                return True
    return False


#: A wall face alongside a pier candidate covers at least this share of its side.
ALONGSIDE_COVER = 0.8


def wall_alongside(isl: Island, wall_xy: Array, bin_m: float) -> bool:
    """A pier candidate is a piece of a wall when a wall face runs alongside it.

    The end of a thick wall seen from one side breaks up in the section: its end
    face and its far face, crossed by scan lines far apart, are regrouped into an
    open rectangle while its near face is a wall island of its own (draw 9 of the
    supports family: a 1.15 m thick wall ending in a "pier" 1.1 x 0.95 m).  The near
    face runs parallel to a side of the candidate, within :data:`CLEARANCE_M` of it,
    along :data:`ALONGSIDE_COVER` of that side (in bins of ``bin_m``) and on beyond
    one of its ends over :data:`WALL_RUN_M`.  A free pier has no wall face that close
    (no passage is narrower), and the face of a neighbour in a row of piers does not
    run on beyond its ends.
    """
    if len(wall_xy) == 0:
        return False
    half = np.maximum(isl.size / 2, 1e-6)
    u, v = rect_coords(wall_xy, isl.center, isl.angle).T
    for along, across, h_along, h_across in ((u, v, half[0], half[1]), (v, u, half[1], half[0])):
        for side in (-1.0, 1.0):
            off = side * across - h_across
            face = (off > 0) & (off <= CLEARANCE_M) & (np.abs(along) <= h_along + 2 * CLEARANCE_M)
            if np.count_nonzero(face) < 3:
                continue
            a = along[face]
            n_bins = max(1, int(np.ceil(2 * h_along / bin_m)))
            inside = a[np.abs(a) <= h_along]
            cover = len(np.unique(np.floor((inside + h_along) / bin_m))) / n_bins
            beyond = max(float(a.max()) - h_along, -h_along - float(a.min()))
            if cover >= ALONGSIDE_COVER and beyond >= WALL_RUN_M:
                return True
    return False


#: The foot of a support: the band from this far above its floor ...
FOOT_FROM_M = 0.1
#: ... up to this far (below the sill of any window, above the floor's noise), metres.
FOOT_TO_M = 0.5
#: The wall beside a wall piece's foot is looked for this far beyond its outline, metres.
FOOT_REACH_M = 1.5
#: Foot points this close to a pier candidate's outline are its own (plinth, base), metres.
FOOT_OWN_M = 0.15
#: A wall face runs on beside a wall piece's foot over at least this length, metres.
FOOT_COVER_M = 0.3
#: The wall above the lintels of the openings beside a wall piece is looked for in the
#: band from this far below the candidate's own top ...
UPPER_FROM_M = 0.5
#: ... up to this far below it (clear of what it carries and of the ceiling's noise), metres.
UPPER_TO_M = 0.1
#: Two walls meet at a corner piece: their directions at least 45 degrees apart.
CORNER_COS = float(np.cos(np.radians(45.0)))


#: Rounds of :func:`refit_line`.
REFIT_ROUNDS = 2


def refit_line(p: Array, d: Array, off: float, tol: float) -> tuple[Array, float]:
    """The line (unit direction, offset along its normal) fitted to the points of ``p``
    within ``tol`` of the line (``d``, ``off``), :data:`REFIT_ROUNDS` times.

    A line through two points of a face picked at random holds all of the face's points
    within ``tol`` while tilted or shifted by up to ``tol`` (every such line scores the
    same): at a wall piece's end it lay 1-2.5 cm off the face, and the flush test, within
    ``tol`` of the piece's outermost face points, missed the wall running on (supports
    draws 6 and 7: a building's corner between a door and a window, seen from outside,
    whose turning wall's face was never flush, so no band held a corner; draw 16: 2.3
    cm off the piece's side over the door).  The principal direction of the points near
    it, through their mean, is the face's own line.
    """
    for _ in range(REFIT_ROUNDS):
        nrm = np.array([-d[1], d[0]])
        sel = p[np.abs(p @ nrm - off) <= tol]
        if len(sel) < 3:
            break
        m = sel.mean(axis=0)
        _, vec = np.linalg.eigh(np.cov((sel - m).T))
        new = vec[:, 1] / np.hypot(*vec[:, 1])  # the largest eigenvalue's direction
        d = new if float(new @ d) >= 0 else -new
        off = float(np.array([-d[1], d[0]]) @ m)
    return d, off


def face_lines(
    q: Array, tol: float, rng: np.random.Generator, n_lines: int = 2, trials: int = 200
) -> list[tuple[Array, float, NDArray[np.bool_]]]:
    """The ``n_lines`` straight lines holding most of the points ``q`` (within ``tol``):
    ``(unit direction, offset along the normal, inliers)``, greedy, largest first; each
    line found through two points is fitted to the points near it (:func:`refit_line`)."""
    out = []
    rest = np.ones(len(q), dtype=bool)
    for _ in range(n_lines):
        p = q[rest]
        if len(p) < 10:
            break
        pick = rng.integers(0, len(p), size=(trials, 2))
        dv = p[pick[:, 1]] - p[pick[:, 0]]
        ln = np.hypot(dv[:, 0], dv[:, 1])
        ok = ln > 4.0 * tol  # pairs far enough apart to give a direction
        if not ok.any():
            break
        dv = dv[ok] / ln[ok, None]
        nrm = np.c_[-dv[:, 1], dv[:, 0]]
        off = np.einsum("ij,ij->i", nrm, p[pick[ok, 0]])
        score = (np.abs(p @ nrm.T - off) <= tol).sum(axis=0)
        b = int(np.argmax(score))
        d, o = refit_line(p, dv[b], float(off[b]), tol)  # the face's own line
        inl = np.zeros(len(q), dtype=bool)
        inl[np.flatnonzero(rest)[np.abs(p @ np.array([-d[1], d[0]]) - o) <= tol]] = True
        out.append((d, o, inl))
        rest &= ~inl
    return out


#: A wall face flush with a face of a pier candidate: its unit direction, whether it runs
#: on beyond the candidate's low / high end along that direction, and whether the
#: candidate shows that face (its own section points lie along at least
#: :data:`SHOWN_SHARE` of it).
WallLine = tuple[Array, tuple[bool, bool], bool]
#: A candidate shows a face when its own points lie along at least this share of it: a
#: pier standing against a wall has no face of its own on the wall's face, only the
#: ends of its sides.
SHOWN_SHARE = 0.5


def flush_wall_ends(
    foot_xy: Array,
    foot_layer: NDArray[np.int64],
    own_xy: Array,
    tol: float,
    cell: float,
    rng: np.random.Generator,
    n_layers: int,
    from_end: bool = False,
) -> list[WallLine]:
    """The wall faces flush with a face of a pier candidate in a height band, and the
    ends of the candidate they run on beyond.

    Parameters
    ----------
    foot_xy, foot_layer
        Points of the band within :data:`FOOT_REACH_M` of the candidate's outline
        (relative to its centre) and their height layer (of ``cell``) in the band.
    own_xy
        The candidate's own surface points at its section (its faces, same origin).
    tol, cell
        Surface tolerance and layer / bin size, metres.
    rng
        Random generator of the line search.
    n_layers
        Height layers in the band.
    from_end
        The face must run on from the candidate's end itself: all but one of the bins of
        the first :data:`FOOT_COVER_M` beyond it hold points (the wall is one with the
        candidate there, not a neighbour across an opening or a gap in a row of piers;
        the points within :data:`FOOT_OWN_M` of its outline are its own and left out).

    Returns
    -------
    list of (direction, (low end, high end), shown)
        Per line among the three main lines of the band's points that runs on the line
        of the candidate's own outermost face points across it (within ``tol``: flush
        with a face), its unit direction, whether it covers :data:`FOOT_COVER_M` of
        that line beyond the candidate's low / high end along that direction in at
        least half the layers of the band (``from_end``: or, a face scanned sparsely,
        with no gap wider than :data:`~pyheracles.supports.sparse_faces.SPARSE_GAP_M`
        along it or up the band, :func:`~pyheracles.supports.sparse_faces.runs_on_sparse`;
        not for the foot and the upper band, where 0.3 m of a flush face anywhere
        within 1.5 m counts: read from its gaps, the sparse face of the architrave over
        an anta ran on beyond both its ends, supports draw 30, noise draw 1), and
        whether the candidate shows that face (:data:`WallLine`).
    """
    if len(foot_xy) < 20 or len(own_xy) < 10:
        return []
    need = max(2, int(np.ceil(FOOT_COVER_M / cell)))
    near_end = int(np.ceil((FOOT_OWN_M + FOOT_COVER_M) / cell)) + 1
    out: list[WallLine] = []
    for d, off, inl in face_lines(foot_xy, tol, rng, n_lines=3):
        nrm = np.array([-d[1], d[0]])
        lo_ac, hi_ac = np.quantile(own_xy @ nrm, [0.02, 0.98])
        if min(abs(lo_ac - off), abs(hi_ac - off)) > tol:
            continue  # not flush with a face of the candidate
        on_face = np.abs(own_xy @ nrm - off) <= tol
        lo, hi = np.quantile(own_xy @ d, [0.02, 0.98])
        n_bins = max(1, int(np.ceil((hi - lo) / cell)))
        bins = np.floor((own_xy[on_face] @ d - lo) / cell)
        shown = len(np.unique(bins[(bins >= 0) & (bins < n_bins)])) >= SHOWN_SHARE * n_bins
        f_al = foot_xy[inl] @ d
        end = f_al > hi
        dist = np.where(end, f_al - hi, lo - f_al)
        beyond = dist > tol
        if np.count_nonzero(beyond) < need:
            continue
        dist, end, lay = dist[beyond], end[beyond], foot_layer[inl][beyond]
        # per layer and per end, the bins of the line beyond the candidate holding points
        key = (lay * 2 + end) * 100_000 + np.floor(dist / cell).astype(np.int64)
        keys = np.unique(key)
        if from_end:  # only the bins next to the end count, all but one of them needed
            keys = keys[keys % 100_000 < near_end]
        ids, counts = np.unique(keys // 100_000, return_counts=True)
        full = ids[counts >= (need - 1 if from_end else need)]  # (layer, end) covered
        walled = [np.count_nonzero(full % 2 == e) >= 0.5 * n_layers for e in (0, 1)]
        if from_end and not all(walled):  # a face scanned sparsely: from its gaps too
            for e in (0, 1):
                at = end == e
                walled[e] = walled[e] or runs_on_sparse(
                    dist[at], lay[at], n_layers, cell, FOOT_COVER_M, FOOT_OWN_M
                )
        if any(walled):
            out.append((d, (walled[0], walled[1]), bool(shown)))
    return out


def foot_on_wall_line(
    foot_xy: Array,
    foot_layer: NDArray[np.int64],
    own_xy: Array,
    tol: float,
    cell: float,
    rng: np.random.Generator,
) -> bool:
    """A pier candidate is a piece of a wall when a wall face runs on, flush with one of
    its faces, at its foot.

    The piece of a wall between two windows stands free from the sill up to the lintel
    (tall windows with low sills leave it joined to the wall in a few height layers
    only, and a section between sill and lintel cuts it off like a pier); below the
    sills the wall goes on, flush with its faces.  A pier stands free at its foot: the
    floor around it is open (a fence on its axis, a bench touching it, the wall behind
    an anta 10 cm inside its face are not flush with a face).

    Parameters
    ----------
    foot_xy, foot_layer
        Points of the foot band (:data:`FOOT_FROM_M` to :data:`FOOT_TO_M` above the
        candidate's floor) within :data:`FOOT_REACH_M` of its outline, and their height
        layer (of ``cell``) in the band.
    own_xy
        The candidate's own surface points at its section (its faces).
    tol, cell
        Surface tolerance and layer / bin size, metres.
    rng
        Random generator of the line search.

    Returns
    -------
    bool
        Whether a flush wall face (:func:`flush_wall_ends`) runs on beyond both of the
        candidate's ends (a piece between two openings), or two at least 45 degrees
        apart beyond one end each (a corner piece).  A wall ending flush in a pier
        beyond one end only is an anta's (a low cella wall ending in a pier that carries
        the pediment): the pier stays a pier.
    """
    n_layers = max(1, int(np.ceil((FOOT_TO_M - FOOT_FROM_M) / cell)))
    return walled_piece(flush_wall_ends(foot_xy, foot_layer, own_xy, tol, cell, rng, n_layers))


def walled_piece(lines: list[WallLine]) -> bool:
    """Whether the flush wall faces of one height band (:func:`flush_wall_ends`) make a
    pier candidate a piece of a wall: one runs on beyond both of its ends, or two at
    least 45 degrees apart beyond one end each (see :func:`foot_on_wall_line`)."""
    one_end: list[Array] = []  # directions of the flush lines walled beyond one end
    for d, walled, _ in lines:
        if all(walled):
            return True  # the wall runs on beyond both ends: a piece between openings
        if any(abs(float(d @ other)) < CORNER_COS for other in one_end):
            return True  # two walls meeting at it: a corner piece
        one_end.append(d)
    return False


def walled_at_both_ends(lines: list[WallLine], axis: Array) -> bool:
    """Whether flush wall faces found in several height bands (:func:`flush_wall_ends`
    of each band), on faces the candidate shows, together run on beyond both ends of a
    pier candidate along one of its axes.

    The piece of a wall between a door and a window is walled beyond one end at its
    foot (below the window's sill) and beyond the other above the door's lintel only;
    neither band alone runs on beyond both.  A pier standing against a wall (a respond,
    supports draw 37) is flush with the wall's face on its back, which it does not show
    (its sides end there); its own faces stand out in the room.  ``axis`` is the unit
    direction of the candidate's first side; each line's ends are taken along the side
    it runs with."""
    ax = np.asarray(axis, dtype=np.float64)
    sides = (ax, np.array([-ax[1], ax[0]]))
    ends: set[tuple[int, int]] = set()
    for d, walled, shown in lines:
        if not shown:
            continue
        k = 0 if abs(float(d @ sides[0])) >= abs(float(d @ sides[1])) else 1
        flip = int(float(d @ sides[k]) < 0)  # the line runs against the side: ends swap
        for e, w in enumerate(walled):
            if w:
                ends.add((k, e ^ flip))
    return any({(k, 0), (k, 1)} <= ends for k in (0, 1))


#: A pier (broken or carrying) must be a prism as wide as its section: a
#: layer whose points stop short of both ends of the section rectangle along one of its
#: axes, by more than this share of its half size (and a surface tolerance) at each
#: end, is narrower than the section, as the end of a lying drum is above and below the
#: chord the section cut, or the post under the tub of a pulpit (an occlusion shadow
#: cuts one end).
NARROW_SHARE = 0.2
#: Largest share of the height layers of a pier narrower than its section.
MAX_NARROW_LAYERS = 0.3


def narrow_share(xy: Array, z: Array, sh: dict, tol: float, cell: float) -> float:
    """Share of the height layers (of ``cell``) of a pier candidate's points (``xy``,
    ``z``) narrower than its section rectangle (``sh``: ``centre``, ``angle``,
    ``half``) at both ends of one of its axes (see :data:`NARROW_SHARE`), 0..1 (layers
    of fewer than 10 points do not count)."""
    if len(z) < 20:
        return 0.0
    uv = rect_coords(xy, sh["centre"], sh["angle"])
    layer = np.floor((z - z.min()) / cell).astype(np.intp)
    inner = (1.0 - NARROW_SHARE) * np.asarray(sh["half"], dtype=np.float64) - tol
    narrow, counted = 0, 0
    for k in np.unique(layer):  # a few dozen layers
        sel = uv[layer == k]
        if len(sel) < 10:
            continue
        counted += 1
        lo, hi = np.quantile(sel, 0.02, axis=0), np.quantile(sel, 0.98, axis=0)
        narrow += bool(np.any((lo > -inner) & (hi < inner)))
    return narrow / counted if counted else 0.0
