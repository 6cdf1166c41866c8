"""Circles in a section: column rings from their arcs, engaged (half-) columns on walls."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.geometry.fitting import MSACParams, fit_circle, fit_circle_msac
from pyheracles.segment.euclidean import euclidean_clusters, relabel_by_size
from pyheracles.supports.core import Array, Island, SupportParams, trimmed_rms
from pyheracles.supports.piers import outline_rectangle, rect_rms

#: Arcs of one ring are grouped across gaps up to this wide (metres): the scan lines of a
#: distant terrestrial scan cross a column this far apart (4 cm at 10 m and 0.23 deg,
#: three times that on the grazing flanks of the ring).
ARC_GAP_M = 0.2


#: Radii of the rings recognised from arcs (metres): from the smallest support island
#: (``min_support_size_m`` 0.1 m across) to the largest column of the family.
RING_RADIUS_M = (0.05, 1.5)


#: Left-over points are thinned to one per cell of this share of the regrouping gap
#: before they are clustered at that gap (a dense leftover, a wall's noise islands in a
#: 30 cm slab, puts thousands of points within 20 cm of each other).
THIN_CELL_SHARE = 0.25


def gap_clusters(q: Array, gap: float, min_points: int) -> NDArray[np.int32]:
    """Single-linkage clusters of the points ``q`` at ``gap`` on a thinned copy.

    The points are reduced to the centroids of their occupied cells of
    ``THIN_CELL_SHARE x gap``; the centroids are linked within ``gap``, and every point
    takes its cell's cluster.  Labels 1..K by decreasing number of points, 0 for
    clusters of fewer than ``min_points`` points (as
    :func:`~pyheracles.segment.euclidean.euclidean_clusters`).
    """
    if len(q) == 0:
        return np.zeros(0, dtype=np.int32)
    cell = THIN_CELL_SHARE * gap
    ij = np.floor((q - q.min(axis=0)) / cell).astype(np.int64)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    cells, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    n = np.bincount(inv, minlength=len(cells)).astype(np.float64)
    rep = np.c_[np.bincount(inv, q[:, 0]) / n, np.bincount(inv, q[:, 1]) / n]
    comp = euclidean_clusters(rep, gap, 1)
    return relabel_by_size(comp[inv], min_points)


def rings_from_arcs(
    xy: Array,
    labels: NDArray[np.intp],
    islands: list[Island],
    params: SupportParams,
    distance_m: float,
) -> list[Island]:
    """Columns whose section ring is broken into arcs and scattered scan-line pieces.

    The clustering distance comes from the spacing of the densest surfaces; a column
    far from the scanners is crossed by scan lines further apart, so its ring falls
    apart into arcs (noise islands) and groups below ``min_points`` (unclustered).
    These leftovers are grouped again with the gap of a distant scan
    (``ARC_GAP_M``), and a group is a column when a circle explains it: radius in
    ``RING_RADIUS_M``, trimmed RMS within a few centimetres and well below that of a
    straight line, the points spread over at least a quarter of the ring; groups
    that are shorter arcs (``ARC_MIN_SECTORS``) of one ring (:func:`group_arcs`), with
    the scattered left-over points on that ring (:func:`ring_scatter`), are one column
    when together they cover a quarter of it (draw 39: rings of 1.26 m crossed by a few
    scan lines, in bunches 0.25-2 m apart).
    """
    noise = [k for k, i in enumerate(islands) if i.kind == "noise"]
    left = np.flatnonzero(labels == 0)
    if noise:
        left = np.r_[left, np.concatenate([islands[k].index for k in noise])]
    gap = max(distance_m, ARC_GAP_M)
    if len(left) < params.min_points or gap <= distance_m:
        return islands
    q = xy[left]
    lab = gap_clusters(q, gap, params.min_points)
    order = np.argsort(lab, kind="stable")
    bounds = np.r_[0, np.cumsum(np.bincount(lab))]
    rings: list[Island] = []
    arcs: list[NDArray[np.intp]] = []  # groups on a circle but less than a quarter ring
    for g in range(1, len(bounds) - 1):  # loop over groups of arcs
        sub = order[bounds[g] : bounds[g + 1]]
        ext = np.ptp(q[sub], axis=0)
        fit = ring_fit(q[sub]) if np.hypot(*ext) >= params.min_support_size_m else None
        if fit is not None and fit[4] >= RING_MIN_SECTORS:  # a quarter ring: a column
            # (a shorter arc goes on with the arcs below: its ring's other bunches and
            # scattered points join it before it is judged by ring_covered)
            centre, radius, c_rms, line_rms, _ = fit
            nan = float("nan")
            rings.append(
                Island("column", left[sub], centre, radius, 0.0, ext, nan, c_rms, line_rms)
            )
        elif fit is not None and fit[4] >= ARC_MIN_SECTORS:
            arcs.append(left[sub])
    # arcs of one ring further apart than the gap (a distant column crossed by a few
    # scan lines, its ring in two or three bunches: draw 39)
    groups, fits = group_arcs(xy, arcs)
    taken = np.zeros(len(xy), dtype=bool)
    for r in rings:
        taken[r.index] = True
    for members, fit in zip(groups, fits, strict=True):
        index = np.concatenate([arcs[j] for j in members])
        rest = left[~taken[left]]
        on = ring_scatter(xy, index, rest[~np.isin(rest, index)], fit, params.seed)
        if len(on):  # and the scattered points of its ring (a bunch of a few points)
            with_on = ring_fit(xy[np.r_[index, on]])
            if with_on is not None and with_on[4] >= fit[4]:
                fit, index = with_on, np.r_[index, on]
        centre, radius, c_rms, line_rms, _ = fit
        if ring_covered(fit):
            taken[index] = True
            ext = np.ptp(xy[index], axis=0)
            nan = float("nan")
            rings.append(Island("column", index, centre, radius, 0.0, ext, nan, c_rms, line_rms))
    if not rings:
        return islands
    used = np.zeros(len(xy), dtype=bool)
    for r in rings:
        used[r.index] = True
    kept = [i for i in islands if i.kind != "noise" or not used[i.index].any()]
    return kept + rings


#: An island is an arc of a column ring when a circle of a radius in ``RING_RADIUS_M``
#: explains it (the ring test of :func:`ring_island`) over at least this many of 36
#: sectors (40 degrees: a circle through a shorter arc is too loose to join others).
ARC_MIN_SECTORS = 4
#: A group of arcs is a column ring when they cover at least this many of 36 sectors
#: (a quarter ring, as :func:`ring_island` asks of scattered points), or when their arc
#: is long enough for its bulge to be seen (:func:`ring_covered`).
RING_MIN_SECTORS = 9
#: ... or when the arc they cover bulges out of its chord by at least this many ring
#: test tolerances (:func:`ring_tolerance`): a large column far from the stations, or
#: shadowed by its neighbours, shows only the 60-80 degrees of its ring that face the
#: one station seeing it, at every height (draws 27, 33 and 39 of the supports family:
#: rings of 0.5-1.3 m radius over 6-8 sectors, 1-3 mm off their circle where a line is
#: 7-30 cm off).  On a small ring the quarter stays the rule (the bulge of a sixth of a
#: ring of 0.2 m is 2.7 cm: the corner of a pier seen in scan-line bunches bends as much;
#: draw 26).
ARC_SAGITTA_TOLERANCES = 3.0
#: ... and when the circle explains them within this share of the RMS of the best line
#: (half the share of the ring test, :func:`ring_fit`: the bulge of a short arc must
#: stand out twice as clearly; 15 points of a portico's wall 1.3 cm off a circle of
#: 0.74 m, 3 cm off a line, were a column of draw 34).
ARC_LINE_RMS_SHARE = 0.25
#: The points of a ring run along an arc across gaps up to this wide (degrees; and up to
#: ``ARC_GAP_M`` along the ring): the scan lines of a distant scan on a small column.
SCAN_GAP_MAX_DEG = 45.0
#: ... and when the circle passes within this share of the ring test's tolerance (1 cm
#: + 3 % of the radius, trimmed RMS) of them (sparse columns of the supports family:
#: 1-4 mm on rings of 0.08-0.16 m).
ARC_SPREAD_RMS_SHARE = 0.5
#: The rectangle a ring is compared with is fitted to the points within this many
#: trimmed RMS of the circle (and at least ``RING_INLIER_MIN_M``, metres) only.
RING_INLIER_SIGMAS = 3.0
RING_INLIER_MIN_M = 0.01


def ring_tolerance(radius: float) -> float:
    """Trimmed RMS within which the points of a ring of ``radius`` (metres) lie on
    their circle for the ring test of :func:`ring_fit`: 1 cm + 3 % of the radius."""
    return 0.01 + 0.03 * radius


def ring_covered(fit: tuple[Array, float, float, float, int]) -> bool:
    """Whether the arc of a ring fit (:func:`ring_fit`: centre, radius, trimmed RMS,
    RMS of the best line, sectors of 36) is enough of its ring for a column:
    ``RING_MIN_SECTORS`` (a quarter), or at least ``ARC_MIN_SECTORS`` with the arc's
    sagitta (its bulge out of its chord, ``radius x (1 - cos(half the arc))``) at least
    ``ARC_SAGITTA_TOLERANCES`` x :func:`ring_tolerance` and the circle within
    ``ARC_LINE_RMS_SHARE`` of the line's RMS."""
    _, radius, c_rms, line_rms, sectors = fit
    if sectors >= RING_MIN_SECTORS:
        return True
    if sectors < ARC_MIN_SECTORS or c_rms > ARC_LINE_RMS_SHARE * line_rms:
        return False
    sagitta = radius * (1.0 - np.cos(np.radians(5.0 * sectors)))
    return bool(sagitta >= ARC_SAGITTA_TOLERANCES * ring_tolerance(radius))


def rectangle_rms_on_circle(p: Array, residuals: Array, c_rms: float) -> float:
    """Trimmed RMS of the points ``p`` the circle explains to the rectangle outline they
    lie on (:func:`~pyheracles.supports.piers.outline_rectangle`), metres.

    ``residuals``: the points' distances to the circle, ``c_rms`` their trimmed RMS.
    The points within ``RING_INLIER_SIGMAS`` x ``c_rms`` (at least
    ``RING_INLIER_MIN_M``) of the circle are kept (all when fewer than 5): a few stray
    points off both shapes (a rope, a sign or a fence bar touching the support) set
    the extent of a rectangle, whose outline they lie on, not of a circle, and turned
    the rectangle of a square pier to its diagonal (draw 8 of the supports family: a
    0.3 x 0.3 m pier with a tail of six points 0.4 m long fitted its rectangle
    within 2.2 cm, a circle of 0.16 m radius within 1.5 cm).
    """
    on = np.abs(residuals) <= max(RING_INLIER_SIGMAS * c_rms, RING_INLIER_MIN_M)
    q = p[on] if np.count_nonzero(on) >= 5 else p
    centre, angle, size = outline_rectangle(q)
    return rect_rms(q, centre, angle, size)[0]


def ring_fit(p: Array) -> tuple[Array, float, float, float, int] | None:
    """Circle through the points ``p`` when they lie on a column ring: ``(centre,
    radius, trimmed RMS, RMS of the best straight line, sectors of 36 covered)``, else
    None.

    The ring test: radius in ``RING_RADIUS_M``, trimmed RMS within 1 cm + 3 % of the
    radius, at most half that of a straight line, and not more than twice that of the
    rectangle outline the points lie on (:func:`~pyheracles.supports.piers.outline_rectangle`:
    the two faces of a small pier seen from a corner fit a circle within 1.5 cm; draw 32
    of the supports family, piers of 0.49 x 0.31 m taken for columns of 0.2 m radius).
    Circle and rectangle are compared on the points the circle explains
    (:func:`rectangle_rms_on_circle`).  The sectors are those the points run along
    (:func:`ring_sectors`: scan-line bunches of a distant column) when the circle passes
    within ``ARC_SPREAD_RMS_SHARE`` of the tolerance of them, else the sectors they
    occupy.
    """
    if len(p) < 5:
        return None
    quick = fit_circle(p, method="algebraic")  # a straight wall: kilometres, at once
    if not quick or quick.radius > 3.0 * RING_RADIUS_M[1]:
        return None
    circle = fit_circle(p)
    if not circle or not RING_RADIUS_M[0] <= circle.radius <= RING_RADIUS_M[1]:
        return None
    c_rms = trimmed_rms(circle.residuals(p))
    ev = np.linalg.eigvalsh(np.cov((p - p.mean(axis=0)).T))
    line_rms = float(np.sqrt(max(ev[0], 0.0)))
    tol = ring_tolerance(float(circle.radius))
    if c_rms > tol or c_rms > 0.5 * line_rms:
        return None
    if c_rms > 2.0 * rectangle_rms_on_circle(p, circle.residuals(p), c_rms):
        return None  # the points lie on a rectangle: a pier seen from a corner
    ang = np.arctan2(p[:, 1] - circle.center[1], p[:, 0] - circle.center[0])
    # the arc the points run along counts when the circle passes within half the ring
    # test's tolerance (ARC_SPREAD_RMS_SHARE) of them: the bunches on two faces of a
    # pier run along an arc too, 9 mm off a circle of 0.19 m (draw 26)
    if c_rms <= ARC_SPREAD_RMS_SHARE * tol:
        sectors = ring_sectors(ang, float(circle.radius))
    else:
        sectors = occupied_sectors(ang)
    return np.asarray(circle.center), float(circle.radius), c_rms, line_rms, sectors


def occupied_sectors(ang: Array) -> int:
    """Number of the 36 sectors of a ring holding one of the azimuths ``ang`` (radians)."""
    a = np.mod(np.asarray(ang, dtype=np.float64), 2 * np.pi)
    return len(np.unique(np.floor(a / (2 * np.pi) * 36).astype(int)))


def ring_sectors(ang: Array, radius: float) -> int:
    """How much of a ring of ``radius`` (metres) the azimuths ``ang`` (radians, about its
    centre) cover, in sectors of 36: the occupied sectors, or, when the points fall in
    at least ``ARC_MIN_SECTORS`` of them, the arc they run along, whichever is more.

    A column far from the scanners is crossed by a few vertical scan lines: its
    section points come in bunches, one per scan line, 15-40 degrees apart on a small
    ring, so they occupy as many sectors as scan lines cross it while they run along a
    half ring (draw 36 of the supports family: twin columns of 0.14 m radius, 38
    points on 8 scan lines along 129 degrees; draw 21: fluted columns of 0.08 m, 23
    points on 7 along 186 degrees).  The arc is the sum of the gaps between
    consecutive azimuths up to the gap of such scan lines (``ARC_GAP_M`` along the
    ring, at most ``SCAN_GAP_MAX_DEG``), the largest gap (the side not seen) left out:
    a bunch of stray points across the ring from an arc (draw 10: a scaffold tube and
    two points 12 cm away, on a circle of 6.5 cm) does not stretch it.  :func:`ring_fit`
    counts the arc only where the circle passes close to the points
    (``ARC_SPREAD_RMS_SHARE``).
    """
    a = np.sort(np.mod(np.asarray(ang, dtype=np.float64), 2 * np.pi))
    occupied = occupied_sectors(a)
    if occupied < ARC_MIN_SECTORS:
        return occupied
    gaps = np.diff(np.r_[a, a[0] + 2 * np.pi])
    gaps[np.argmax(gaps)] = 0.0  # the side not seen
    bridge = min(np.radians(SCAN_GAP_MAX_DEG), ARC_GAP_M / max(radius, 1e-9))
    arc = float(np.sum(gaps[gaps <= bridge]))
    return max(occupied, int(arc / (2 * np.pi) * 36))


def group_arcs(
    xy: Array, arcs: list[NDArray[np.intp]]
) -> tuple[list[list[int]], list[tuple[Array, float, float, float, int]]]:
    """Arcs (index arrays into ``xy``, each passing :func:`ring_fit`) grouped by ring:
    largest first, an arc joins the first group whose ring through it and the group's
    arcs still passes the ring test, with a radius within 15 % of the group's.
    Returns the groups (positions in ``arcs``) and the ring fit of each."""
    order = sorted(range(len(arcs)), key=lambda j: -len(arcs[j]))
    groups: list[list[int]] = []
    fits: list[tuple[Array, float, float, float, int]] = []
    for j in order:
        p = xy[arcs[j]]
        c0 = ring_fit(p)
        if c0 is None:
            continue
        joined = False
        for g, members in enumerate(groups):
            centre, radius = fits[g][0], fits[g][1]
            if np.hypot(*(c0[0] - centre)) > 0.5 * (radius + c0[1]):
                continue  # cheap: another ring
            both = ring_fit(np.vstack([xy[arcs[m]] for m in members] + [p]))
            if both is not None and abs(both[1] - radius) <= 0.15 * radius:
                members.append(j)
                fits[g] = both
                joined = True
                break
        if not joined:
            groups.append([j])
            fits.append(c0)
    return groups, fits


def join_arcs(
    xy: Array, labels: NDArray[np.intp], islands: list[Island], params: SupportParams
) -> list[Island]:
    """Islands that are arcs of one column ring joined into one column island.

    The section ring of a large column breaks where its neighbour shadows it (twin
    columns, a colonnade seen from one station) or where the scan lines graze it; its
    arcs are islands of their own, and an arc longer than 1 m is long and thin like a
    piece of wall (draw 33 of the supports family: columns of 1.1 m radius cut into
    arcs of 1.2-1.9 m, every one a wall island).  Wall, noise and column islands
    whose points lie on a circle of a column's radius (:func:`ring_fit`, at least
    ``ARC_MIN_SECTORS`` of 36 sectors; a straight wall fits a circle of a radius of
    kilometres) are joined, largest first, to a group when the circle through the
    group and the arc still passes the ring test; a group covering
    ``RING_MIN_SECTORS`` is one column island (its arcs leave the list).  Every group
    takes the scattered points (unclustered, ``labels`` 0, or in noise islands) on
    its ring (:func:`ring_scatter`): the far side of a ring crossed by a few distant
    scan lines; a group covering less is a column when it then covers
    ``RING_MIN_SECTORS`` and passes the ring test, else stays as it was.  A quarter, not
    the shorter arc of :func:`ring_covered`: a wall island with a half column on it bends
    like a short arc of a large ring (held-out draw 40: rings of 0.76 and 0.82 m through
    walls and engaged columns, which then made ten columns of 0.22 m too thin to carry).
    """
    arcs: list[tuple[int, int]] = []  # (island, sectors)
    for k, isl in enumerate(islands):
        if isl.kind not in ("wall", "noise", "column") or len(isl.index) < params.min_points:
            continue
        if isl.kind == "wall" and float(np.max(isl.size)) > 2.2 * RING_RADIUS_M[1]:
            continue  # longer than the chord of any ring
        fit = ring_fit(xy[isl.index])
        if fit is not None and fit[4] >= ARC_MIN_SECTORS:
            arcs.append((k, fit[4]))
    if not arcs:
        return islands
    groups, fits = group_arcs(xy, [islands[k].index for k, _ in arcs])
    groups = [[arcs[j][0] for j in members] for members in groups]
    grouped = {k for members in groups for k in members}
    loose = [np.flatnonzero(labels == 0)] + [
        i.index for k, i in enumerate(islands) if i.kind == "noise" and k not in grouped
    ]
    scatter = np.concatenate(loose)
    out_of: set[int] = set()
    rings: list[Island] = []
    taken = np.zeros(len(xy), dtype=bool)
    for members, fit in zip(groups, fits, strict=True):
        index = np.concatenate([islands[j].index for j in members])
        on = ring_scatter(xy, index, scatter[~taken[scatter]], fit, params.seed)
        with_on = ring_fit(xy[np.r_[index, on]]) if len(on) else None
        if with_on is not None and with_on[4] >= RING_MIN_SECTORS:
            fit, index = with_on, np.r_[index, on]
            taken[on] = True
        elif fit[4] < RING_MIN_SECTORS or (
            len(members) == 1 and islands[members[0]].kind == "column"
        ):
            continue  # no ring, or a column island already
        centre, radius, c_rms, line_rms, _ = fit
        ext = np.ptp(xy[index], axis=0)
        nan = float("nan")
        rings.append(Island("column", index, centre, radius, 0.0, ext, nan, c_rms, line_rms))
        out_of.update(members)
    if not rings:
        return islands
    kept = [
        i for k, i in enumerate(islands)
        if k not in out_of and not (i.kind == "noise" and taken[i.index].any())
    ]  # fmt: skip
    return kept + rings


#: The circle through a short arc is loose: the scattered points of its ring are looked
#: for this far (share of its radius, plus 10 cm) around its centre.
SCATTER_REACH = 1.3


def ring_scatter(
    xy: Array,
    arc: NDArray[np.intp],
    scatter: NDArray[np.intp],
    fit: tuple[Array, float, float, float, int],
    seed: int,
) -> NDArray[np.intp]:
    """The scattered section points (indices ``scatter``) on the ring of an arc.

    The circle through an arc of 40-80 degrees places the far side of its ring a few
    centimetres off, so the ring is fitted again robustly (MSAC, radius within 20 % of
    the arc's, inliers within three times the arc's RMS, at least 1 cm) through the arc
    and the scattered points within ``SCATTER_REACH`` x its radius of its centre; the
    scattered inliers are returned when the ring keeps 90 % of the arc's points (none
    otherwise).
    """
    centre, radius, c_rms = fit[0], fit[1], fit[2]
    near = scatter[np.hypot(*(xy[scatter] - centre).T) <= SCATTER_REACH * radius + 0.1]
    if len(near) < 3:
        return near[:0]
    p = xy[np.r_[arc, near]]
    msac = MSACParams(threshold=max(3.0 * c_rms, 0.01), max_trials=300, min_inlier_fraction=0.0)
    ring = fit_circle_msac(p, msac, rng=seed, radius_range=(0.8 * radius, 1.25 * radius))
    if not ring or ring.inliers is None or ring.inliers[: len(arc)].mean() < 0.9:
        return near[:0]
    return near[ring.inliers[len(arc) :]]


def ring_island(p: Array, index: NDArray[np.intp], params: SupportParams) -> Island | None:
    """A column island when a circle explains the points ``p`` (section indices
    ``index``): the ring test of :func:`ring_fit`, the points spread over at least a
    quarter of the ring (``RING_MIN_SECTORS`` of 36 sectors) or over an arc that bulges
    enough (:func:`ring_covered`); else None."""
    ext = np.ptp(p, axis=0)
    if len(p) < 5 or np.hypot(*ext) < params.min_support_size_m:
        return None
    fit = ring_fit(p)
    if fit is None or not ring_covered(fit):
        return None
    centre, radius, c_rms, line_rms, _ = fit
    return Island(
        "column", np.asarray(index), centre, radius, 0.0, ext, float("nan"), c_rms, line_rms
    )


def twin_rings(
    p: Array, index: NDArray[np.intp], params: SupportParams
) -> tuple[Island, Island] | None:
    """Two column islands when the points ``p`` are two rings side by side (twin columns
    grouped as one at a large gap, which a rectangle can fit as well as a pier).

    The points are split across the middle of their major axis, and again around the
    two centres found (2-means, a few rounds); both halves must pass the ring test of
    :func:`ring_island` with radii within 30 % of each other.
    """
    if len(p) < 2 * max(params.min_points, 5):
        return None
    m = p.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((p - m).T))
    side = (p - m) @ vec[:, 1] > 0
    for _ in range(3):  # 2-means from the split across the major axis
        if side.all() or not side.any():
            return None
        c0, c1 = p[~side].mean(axis=0), p[side].mean(axis=0)
        side = np.hypot(*(p - c1).T) < np.hypot(*(p - c0).T)
    a = ring_island(p[~side], index[~side], params)
    b = ring_island(p[side], index[side], params)
    if a is None or b is None or not 0.7 <= a.radius / b.radius <= 1 / 0.7:
        return None
    if np.hypot(*(a.center - b.center)) < 0.9 * (a.radius + b.radius):
        return None  # overlapping circles: one ring fitted twice
    return a, b


def pair_lines(p: Array, trials: int, rng: np.random.Generator) -> tuple[Array, Array]:
    """Lines through ``trials`` random pairs of the points ``p`` (a line search's
    candidates): unit normals ``(K, 2)`` and offsets ``(K,)`` with ``n . x = d`` on the
    line; pairs of coincident points are left out."""
    idx = rng.integers(0, len(p), size=(trials, 2))
    dvec = p[idx[:, 1]] - p[idx[:, 0]]
    nrm = np.c_[-dvec[:, 1], dvec[:, 0]]
    ln = np.linalg.norm(nrm, axis=1)
    good = ln > 1e-6
    nrm = nrm[good] / ln[good, None]
    return nrm, np.einsum("ij,ij->i", nrm, p[idx[good, 0]])


def pair_line_inliers(
    p: Array, tol: float, trials: int, max_sample: int, rng: np.random.Generator
) -> NDArray[np.bool_]:
    """The points of ``p`` within ``tol`` of the candidate of :func:`pair_lines` with
    the lowest truncated cost (MSAC; at most ``max_sample`` of the points scored), as a
    mask: the first step of a sequential line search, before the line's refit."""
    nrm, off = pair_lines(p, trials, rng)
    sub = p if len(p) <= max_sample else p[rng.choice(len(p), max_sample, replace=False)]
    cost = np.minimum((sub @ nrm.T - off) ** 2, tol**2).sum(axis=0)
    b = int(np.argmin(cost))
    return np.abs(p @ nrm[b] - off[b]) <= tol


def refit_line(q: Array) -> tuple[Array, float, Array]:
    """Least-squares line through the points ``q`` (a search's inliers): unit normal
    ``n``, offset ``d`` (``n . x = d`` on it) and the points' centroid."""
    m = q.mean(axis=0)
    _, vec = np.linalg.eigh((q - m).T @ (q - m))
    n = vec[:, 0]
    return n, float(n @ m), m


def wall_face_lines(
    xy: Array, tol: float, distance: float, rng: np.random.Generator
) -> tuple[list[tuple[Array, float, float]], NDArray[np.intp]]:
    """The straight faces of a wall island's section points ``xy``: ``(unit normal n,
    offset d, RMS)`` per face (``n . x = d`` on it), each continuous over at least 1 m
    (its inliers fill 70 % of their span: the aligned apexes of several half-columns
    are not a face), and the indices of the points on none of them."""
    rest = np.arange(len(xy))
    lines: list[tuple[Array, float, float]] = []  # (unit normal n, offset d, rms): n.x = d
    msac = MSACParams(threshold=tol, max_trials=300, min_inlier_fraction=0.0)
    for _ in range(12):  # wall faces (a closed wall ring has 8 and more)
        if len(rest) < 20:
            break
        p = xy[rest]
        inl = pair_line_inliers(p, tol, msac.max_trials, 3000, rng)
        if inl.sum() < max(20, 0.02 * len(xy)):
            break
        n, d, _ = refit_line(p[inl])  # the face line on its inliers
        inl = np.abs(p @ n - d) <= tol
        # a face is continuous: its inliers fill most of their span along the line (the
        # aligned apexes of several half-columns are not a face)
        along = p[inl] @ np.array([-n[1], n[0]])
        span = np.ptp(along) if inl.any() else 0.0
        bins = np.unique(np.floor(along / (2 * distance)))
        if span < 1.0 or len(bins) * 2 * distance < 0.7 * span:  # not a chord of a bump
            break
        lines.append((n, d, float(np.sqrt(np.mean((p[inl] @ n - d) ** 2)))))
        rest = rest[~inl]
    return lines, rest


def engaged_on_wall(
    xy: Array,
    params: SupportParams,
    tol: float,
    distance: float,
    rng: np.random.Generator,
    faces: tuple[list[tuple[Array, float, float]], NDArray[np.intp]] | None = None,
) -> list[tuple[Array, float, Array, float]]:
    """Half-columns on a wall island (``faces``: its :func:`wall_face_lines`, found
    here when not given).

    Returns ``(centre, radius, unit face normal into the room, face offset, face RMS)``.
    """
    lines, rest = faces if faces is not None else wall_face_lines(xy, tol, distance, rng)
    if not lines or len(rest) < params.min_points:
        return []
    labels = euclidean_clusters(xy[rest], distance, params.min_points)
    found = []
    for lab in range(1, int(labels.max()) + 1 if len(labels) else 1):
        p = xy[rest[labels == lab]]
        ext = np.ptp(p, axis=0).max()
        if ext < params.min_support_size_m:
            continue
        circle = fit_circle(p)
        lo, hi = params.engaged_radius_m
        noise = float(np.median([f[2] for f in lines]))  # the faces' RMS is the noise level
        if (
            not circle
            or not lo <= circle.radius <= hi
            or circle.rms > min(max(tol, 0.05 * circle.radius), 3 * noise + 0.002)
        ):
            continue
        q = p - circle.center
        arc = np.unique(np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * 36))
        if len(arc) < 7:  # less than 70 degrees of arc: a corner, not a half-column
            continue
        # attached to a face: centre close to a face line, bump standing out of it
        for n, d, face_rms in lines:
            dc = float(circle.center @ n - d)
            if abs(dc) <= 0.6 * circle.radius + tol:
                off = p @ n - d
                side = np.sign(np.median(off))
                if side == 0 or np.max(side * off) < 0.5 * circle.radius:
                    continue
                found.append((circle.center, circle.radius, side * n, side * d, face_rms))
                break
    return found


def detached_half_column(
    xy: Array, isl: Island, wall_tree: cKDTree, distance: float
) -> dict | None:
    """A column island that is only an arc and stands against a wall is an engaged column
    whose junction with the wall was not captured (occlusion in the re-entrant corner)."""
    q = xy - isl.center
    bins = np.unique(np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * 36))
    if len(bins) > 0.75 * 36:
        return None
    near = wall_tree.query_ball_point(isl.center, isl.radius + 3 * distance)
    if len(near) < 10:
        return None
    w = wall_tree.data[near]
    m = w.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((w - m).T))
    n = vec[:, 0]  # face normal (smallest spread)
    d = float(n @ m)
    side = np.sign(np.median(xy @ n - d))
    if side == 0 or abs(float(isl.center @ n - d)) > 0.6 * isl.radius + distance:
        return None
    face_rms = float(np.sqrt(np.mean((w @ n - d) ** 2)))
    return {
        "class": "engaged_column",
        "island": None,
        "centre": isl.center,
        "radius": isl.radius,
        "half": np.array([isl.radius, isl.radius]),
        "angle": 0.0,
        "normal": side * n,
        "d": side * d,
        "face_gap": max(0.01, 3 * face_rms),
        "circularity": isl.circularity,
    }


#: Half-height of the slab about the section whose points show the wall a column
#: stands against (metres): the wall's face is sparse or shadowed in the section's few
#: centimetres (draw 39 of the supports family: 0.6 m engaged columns 9.6 m up a nave,
#: no wall island within 1 m of them), not over 0.6 m of height.
WALL_BAND_M = 0.3
#: A wall beside a column shows at least this many points on its face line.
WALL_FACE_POINTS = 20
#: Cells (metres, along the face by height) in which a wall's face is a surface: it
#: holds points in at least ``WALL_FACE_FILL`` of the cells of the slab's height at the
#: places along it where it is seen, in at least ``WALL_FACE_CELLS`` places.  A
#: scaffold's standards and ledgers, a rail or a rope on a line through a column fill a
#: few (supports draw 46: a scaffold round free columns, 3-4 places, or 28 % of cells).
WALL_FACE_CELL_M = 0.1
WALL_FACE_FILL = 0.5
WALL_FACE_CELLS = 5


def wall_face_beside(
    around: Array, ring: Array, centre: Array, radius: float, tol: float,
    rng: np.random.Generator, heights: Array | None = None,
) -> tuple[Array, float, float] | None:  # fmt: skip
    """The face of a wall a round section stands against, from the points around it.

    An engaged column is a round shaft whose axis lies near a wall's face (within
    ``0.6 radius + tol``: a half or three-quarter column) and whose ring stops at that
    face.  Tested on plan geometry, not on the wall points next to the shaft, which the
    shaft itself shadows from most stations.

    Parameters
    ----------
    around
        ``(M, 2)`` plan positions of the points of a slab about the section (the
        column's own points may be among them) within reach of the column.
    ring
        ``(K, 2)`` the section's points on the column's ring.
    centre, radius
        The ring's circle, metres.
    tol
        Surface tolerance, metres.
    rng
        Random generator of the line search.
    heights
        ``(M,)`` heights of ``around`` above the bottom of their slab, metres (``2 x
        WALL_BAND_M`` tall); with them the face must be a surface
        (``WALL_FACE_FILL``), not a scaffold's tubes.

    Returns
    -------
    tuple or None
        ``(unit normal into the room, offset d with n.x = d on the face, face RMS)``
        when a straight face of at least ``WALL_FACE_POINTS`` points, outside the ring,
        passes within ``0.6 radius + tol`` of the centre with the whole ring on one
        side of it (beyond it by ``tol`` at most 2 % of the ring's points); else None.
    """
    outside = np.hypot(*(around - centre).T) > radius + 3.0 * tol
    out = around[outside]
    if len(out) < WALL_FACE_POINTS or len(ring) < 8:
        return None
    nrm, off = pair_lines(out, 200, rng)
    # only lines through the column's reach can be the face it stands against
    near = np.abs(nrm @ centre - off) <= 0.6 * radius + tol
    if not near.any():
        return None
    nrm, off = nrm[near], off[near]
    cost = np.minimum((out @ nrm.T - off) ** 2, tol**2).sum(axis=0)
    b = int(np.argmin(cost))
    inl = np.abs(out @ nrm[b] - off[b]) <= tol
    if inl.sum() < WALL_FACE_POINTS:
        return None
    n, d, m = refit_line(out[inl])
    on = np.abs(out @ n - d) <= tol
    face = out[on]
    if len(face) < WALL_FACE_POINTS or abs(float(n @ centre - d)) > 0.6 * radius + tol:
        return None
    along = (face - m) @ np.array([-n[1], n[0]])
    if float(np.ptp(along)) < radius:  # a face runs on: not a moulding's corner
        return None
    if heights is not None:  # a surface, not a lattice of tubes
        ia = np.floor(along / WALL_FACE_CELL_M).astype(np.int64)
        iz = np.floor(heights[outside][on] / WALL_FACE_CELL_M).astype(np.int64)
        places = len(np.unique(ia))
        n_z = max(1, round(2.0 * WALL_BAND_M / WALL_FACE_CELL_M))
        cells = len(np.unique(ia * (n_z + 2) + np.clip(iz, 0, n_z)))
        if places < WALL_FACE_CELLS or cells < WALL_FACE_FILL * places * n_z:
            return None
    side = np.sign(float(np.median(ring @ n - d)))
    if side == 0 or np.mean(side * (ring @ n - d) < -tol) > 0.02:
        return None  # the ring goes on behind the line: a free column
    rms = float(np.sqrt(np.mean((face @ n - d) ** 2)))
    return side * n, side * d, rms
