"""Section islands: Euclidean clustering of a horizontal slab, noise / wall / column / pier."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.geometry.fitting import fit_circle, min_area_rectangle
from pyheracles.geometry.sections import circularity
from pyheracles.segment.euclidean import euclidean_clusters
from pyheracles.supports.core import Array, Island, SupportParams, check_pair_memory, trimmed_rms
from pyheracles.supports.piers import (
    WALL_LINE_COVER_M,
    WALL_LINE_GAP_M,
    outline_rectangle,
    rect_rms,
)
from pyheracles.supports.rings import (
    ARC_GAP_M,
    RING_RADIUS_M,
    gap_clusters,
    join_arcs,
    rectangle_rms_on_circle,
    ring_island,
    rings_from_arcs,
    twin_rings,
)
from pyheracles.supports.steps import back_on_wall_face, line_tolerance, side_on_line


def island_kind(length: Array, width: Array, params: SupportParams) -> NDArray[np.str_]:
    """``noise``, ``wall`` or ``support`` from an island's length and width (metres)."""
    elongated = length > params.wall_min_aspect * np.maximum(width, 1e-6)
    wall = (length > params.max_support_size_m) | ((length > 1.0) & elongated)
    # a short straight piece (a wall fragment, a board, a railing) is noise
    short = elongated | (width < 0.5 * params.min_support_size_m)
    return np.select(
        [length < params.min_support_size_m, wall, short],
        ["noise", "wall", "noise"],
        default="support",
    )


def classify_island(
    p: Array, idx: NDArray[np.intp], params: SupportParams, *, with_shapes: bool = True
) -> Island:
    """One island from its points ``p`` (section indices ``idx``): noise, wall, column or
    pier (``support`` without shapes)."""
    nan = float("nan")
    if np.hypot(*np.ptp(p, axis=0)) < params.min_support_size_m:  # cheap: clearly noise
        return Island("noise", idx, p.mean(axis=0), nan, 0.0, np.ptp(p, axis=0), nan, nan, nan)
    if with_shapes:
        centre, angle, size = min_area_rectangle(p)
    else:  # principal axes: enough to tell noise / wall / support, no hull needed
        centre = p.mean(axis=0)
        _, vec = np.linalg.eigh(np.cov((p - centre).T))
        uv = (p - centre) @ vec[:, ::-1]
        size = np.ptp(uv, axis=0)
        angle = float(np.arctan2(vec[1, 1], vec[0, 1]))
    length = float(size[0])
    kind = str(island_kind(np.array([length]), np.array([float(size[1])]), params)[0])
    if (
        kind == "wall"
        and with_shapes
        and params.max_support_size_m < length <= np.sqrt(2.0) * params.max_support_size_m
        and length <= params.wall_min_aspect * float(size[1])
    ):
        # a pier seen from one corner is an L of two faces: the smallest rectangle round
        # it lies along its diagonal, longer than the pier (supports draw 30: a 2.0 x
        # 1.77 m pier boxed 2.66 x 1.34 m, longer than any support): its kind is
        # that of the rectangle the points lie on, if they do within a centimetre (an
        # arc of a large ring, a plinth's corner among sparse points, do not: draw 23)
        o_centre, o_angle, o_size = outline_rectangle(p)
        o_kind = str(island_kind(np.array([o_size[0]]), np.array([o_size[1]]), params)[0])
        o_rms = rect_rms(p, o_centre, o_angle, o_size.copy())[0]
        if o_kind != "wall" and o_rms <= SPARSE_RECT_RMS_M:
            kind, centre, angle, size, length = o_kind, o_centre, o_angle, o_size, float(o_size[0])
    circ, c_rms, r_rms, radius = nan, nan, nan, nan
    if kind == "support" and with_shapes:
        # the rectangle the points lie on: a pier seen from a corner is an L, whose
        # smallest enclosing rectangle is turned to its diagonal
        centre, angle, size = outline_rectangle(p)
        circ = circularity(p)
        circle = fit_circle(p)
        r_rms, rect = rect_rms(p, centre, angle, size.copy())
        if circle and circle.radius < length:
            c_rms = trimmed_rms(circle.residuals(p))
        # a partial ring (a column seen from one side: its hull is no circle) whose
        # circle lies within the noise of the ring test and beats the rectangle is a
        # column too: a rectangle fits a half ring of a small column almost as well
        on_ring = bool(circle) and (
            RING_RADIUS_M[0] <= circle.radius <= RING_RADIUS_M[1]
            and c_rms <= 0.01 + 0.03 * circle.radius
        )
        # the rectangle is also fitted to the points the circle explains: stray points
        # off both (a rope, a sign touching a square pier) set the rectangle's extent
        # and turned it to the diagonal, where the circle beat it
        cmp_rms = r_rms
        if circle and c_rms < r_rms:
            cmp_rms = min(r_rms, rectangle_rms_on_circle(p, circle.residuals(p), c_rms))
        if (
            circle
            and c_rms < cmp_rms
            and (circ <= params.circularity_max or c_rms < 0.5 * cmp_rms or on_ring)
        ):
            kind, centre, radius = "column", circle.center, circle.radius
        else:
            kind, centre, size = "pier", rect[:2], rect[2:]
    return Island(
        kind, idx, np.asarray(centre), radius, angle, np.asarray(size), circ, c_rms, r_rms
    )


def section_islands(
    xy: Array, params: SupportParams, distance_m: float, *, with_shapes: bool = True
) -> list[Island]:
    """Cluster a section into islands and classify them (noise, wall, column, pier).

    Parameters
    ----------
    xy
        ``(M, 2)`` section points, metres.
    params
        Size, aspect and circularity thresholds.
    distance_m
        Clustering distance, metres.
    with_shapes
        ``False`` skips the circle / rectangle fits (cheap pass for choosing the height;
        supports are then reported as ``support``).  With shapes, the points left over
        (noise islands, unclustered points) are grouped again at their own spacing:
        column rings from their arcs (:func:`~pyheracles.supports.rings.rings_from_arcs`)
        and sparse piers (:func:`sparse_islands`).
    """
    if len(xy) == 0:
        return []
    tree = cKDTree(xy)
    check_pair_memory(xy, tree, distance_m)
    labels = euclidean_clusters(xy, distance_m, params.min_points, tree=tree)
    order = np.argsort(labels, kind="stable")
    counts = np.bincount(labels)
    bounds = np.r_[0, np.cumsum(counts)]
    out: list[Island] = []
    for lab in range(1, len(counts)):  # loop over islands, not points
        idx = order[bounds[lab] : bounds[lab + 1]]
        out.append(classify_island(xy[idx], idx, params, with_shapes=with_shapes))
    if with_shapes:
        out = join_arcs(xy, labels, out, params)
        out = face_pairs(xy, out, params, distance_m)
        # the scattered points a ring took are no longer left over
        ringed = np.zeros(len(xy), dtype=bool)
        for i in out:
            if i.kind == "column":
                ringed[i.index] = True
        labels = np.where(ringed & (labels == 0), -1, labels)
        out = rings_from_arcs(xy, labels, out, params, distance_m)
        out = sparse_islands(xy, labels, out, params, distance_m)
        # last: the pier islands of sparse outlines have their dense faces as walls
        out = face_and_outline(xy, out, params, distance_m)
        out = face_and_sides(xy, out, params, distance_m)
    return out


#: Two wall islands are the long faces of one pier when they are parallel within this
#: angle, degrees.
FACE_PAIR_ANGLE_DEG = 5.0
#: A face is straight: trimmed RMS of its points to their line within this (metres) plus
#: 1 % of its length (an arc of a large ring is not).
FACE_STRAIGHT_RMS_M = 0.01
#: Each short side of a pier whose long faces are paired must hold at least this many
#: section points (grazed by the scan lines, it holds a few).
FACE_END_POINTS = 2


def face_line(p: Array) -> tuple[Array, Array, Array, float] | None:
    """Centre, unit direction, extent ``(t0, t1)`` along it and trimmed RMS to the line
    of the points ``p`` of a wall island, or None if they do not lie on a line
    (``FACE_STRAIGHT_RMS_M``)."""
    c = p.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((p - c).T))
    u = vec[:, 1]
    t = (p - c) @ u
    d = (p - c) @ vec[:, 0]
    rms = trimmed_rms(d)
    if rms > FACE_STRAIGHT_RMS_M + 0.01 * float(np.ptp(t)):
        return None
    return c, u, np.array([t.min(), t.max()]), rms


def ends_on_wall_lines(
    t: Array, s: Array, ends: tuple[float, float], depth: float, tol: float, bin_m: float
) -> bool:
    """Whether a short side of a face pair lies on a wall line running on beyond it.

    ``t``, ``s``: section points along the faces and across them (0 on the first face,
    ``depth`` on the second), metres.  The two reveals of the piece of a wall between two
    doors pair like the faces of a pier, their short sides on the wall's own faces:
    points within ``tol`` of the line of a short side (``t`` at one of ``ends``, the
    faces' extent: ``tol`` is the tolerance of their alignment),
    beyond the pair and at most ``WALL_LINE_GAP_M`` from it, covering
    ``WALL_LINE_COVER_M`` of that line in bins of ``bin_m`` (draw 31 of the supports
    family: a 0.3 m piece of a 1.2 m thick wall between two doors).
    """
    out = ((s < -tol) & (s >= -WALL_LINE_GAP_M)) | (
        (s > depth + tol) & (s <= depth + WALL_LINE_GAP_M)
    )
    need = max(2, int(np.ceil(WALL_LINE_COVER_M / bin_m)))
    for end in ends:
        on = out & (np.abs(t - end) <= tol)
        if len(np.unique(np.floor(s[on] / bin_m))) >= need:
            return True
    return False


def short_wall_faces(
    islands: list[Island], xy: Array, params: SupportParams
) -> dict[int, tuple[Array, Array, Array, float]]:
    """The straight faces (:func:`face_line`) of the wall islands no longer than
    ``max_support_size_m``, by island: what may be a face of a pier."""
    faces = {}
    for k, isl in enumerate(islands):
        if isl.kind == "wall" and float(np.max(isl.size)) <= params.max_support_size_m:
            line = face_line(xy[isl.index])
            if line is not None:
                faces[k] = line
    return faces


def face_pairs(
    xy: Array, islands: list[Island], params: SupportParams, distance_m: float
) -> list[Island]:
    """Piers seen from their two long sides: pairs of wall islands that are its faces.

    A pier whose long faces the scanners see square on while they graze its short
    sides has two dense straight faces and a few points on each short side (draw 34
    of the supports family: a 2.0 x 0.86 m pier, its faces two "walls" of 2 m).  Two
    straight wall islands no longer than ``max_support_size_m`` are one pier when they
    are parallel (``FACE_PAIR_ANGLE_DEG``), between ``min_support_size_m`` and
    ``max_support_size_m`` apart, end at the same places (within three clustering
    distances, at least 10 cm) and each short side between them holds
    ``FACE_END_POINTS`` section points off the faces (beyond three times their RMS, at
    least 2 cm); the pier island takes every section point of its rectangle.  The
    pieces of walls between openings pair too: the wall-piece tests of the supports
    (:func:`~pyheracles.supports.detect.wall_pieces`) handle them as any pier-like
    island.
    """
    faces = short_wall_faces(islands, xy, params)
    if len(faces) < 2:
        return islands
    tol = max(0.1, 3.0 * distance_m)
    cos_max = np.cos(np.radians(FACE_PAIR_ANGLE_DEG))
    pairs: list[tuple[float, int, int, NDArray[np.intp]]] = []
    keys = sorted(faces)
    for a_pos, a in enumerate(keys):  # a few dozen short walls at most
        ca, ua, ta, rms_a = faces[a]
        na = np.array([-ua[1], ua[0]])
        for b in keys[a_pos + 1 :]:
            cb, ub, _, rms_b = faces[b]
            if abs(float(ua @ ub)) < cos_max:
                continue
            off = float((cb - ca) @ na)
            if not params.min_support_size_m <= abs(off) <= params.max_support_size_m:
                continue
            tb = (xy[islands[b].index] - ca) @ ua
            if abs(tb.min() - ta[0]) > tol or abs(tb.max() - ta[1]) > tol:
                continue
            t0, t1 = min(ta[0], tb.min()), max(ta[1], tb.max())
            q = xy - ca
            t, s = q @ ua, (q @ na) * np.sign(off)
            inside = (t >= t0 - tol) & (t <= t1 + tol) & (s >= -tol) & (s <= abs(off) + tol)
            edge = max(0.02, 3.0 * max(rms_a, rms_b))  # off the faces' own points
            between = inside & (s > edge) & (s < abs(off) - edge)
            ends = (np.count_nonzero(between & (np.abs(t - t0) <= tol)),
                    np.count_nonzero(between & (np.abs(t - t1) <= tol)))  # fmt: skip
            if min(ends) < FACE_END_POINTS:
                continue
            if ends_on_wall_lines(t, s, (t0, t1), abs(off), tol, max(0.05, distance_m)):
                continue  # the reveals of a piece of wall between two doors
            misfit = abs(tb.min() - ta[0]) + abs(tb.max() - ta[1])
            pairs.append((misfit, a, b, np.flatnonzero(inside)))
    used: set[int] = set()
    piers: list[Island] = []
    for _, a, b, idx in sorted(pairs, key=lambda x: x[0]):  # best aligned first
        if a in used or b in used:
            continue
        isl = classify_island(xy[idx], idx, params)
        if isl.kind == "pier":
            used |= {a, b}
            piers.append(isl)
    if not piers:
        return islands
    return [i for k, i in enumerate(islands) if k not in used] + piers


def face_and_outline(
    xy: Array, islands: list[Island], params: SupportParams, distance_m: float
) -> list[Island]:
    """Piers whose densest face is a wall island of its own.

    A pier seen square on from one side has one dense straight face, longer than 1 m and
    thin, hence a "wall", while its other faces, grazed or seen from afar, make a pier
    island of their own beside it; that island then has a wall face alongside it and was
    a piece of a wall (draw 19 of the supports family: two 1.39 x 0.68 m piers of an
    open kiosk, their faces 1.39 x 0.07 m walls).  A straight wall island no longer than
    ``max_support_size_m`` is the face of a pier island when it lies within three
    clustering distances (at least 10 cm) of it, the pier island ends where the face
    ends (within the same distance; the near face of a thick wall's end runs on past
    its sparse end and far faces) and their points together make a pier whose outline
    they lie on (:data:`SPARSE_RECT_RMS_M` plus 2 % of its length): one pier island.
    The wall-piece tests of the supports
    (:func:`~pyheracles.supports.detect.wall_pieces`) then judge it as any pier island
    (a piece of a wall between openings has the wall's other pieces in line with it).
    """
    faces = short_wall_faces(islands, xy, params)
    piers = [k for k, i in enumerate(islands) if i.kind == "pier"]
    if not faces or not piers:
        return islands
    tol = max(0.1, 3.0 * distance_m)
    used: set[int] = set()
    joined: list[Island] = []
    for kp in piers:  # a few dozen piers at most
        own = islands[kp]
        tree = cKDTree(xy[own.index])
        for kw, (c, u, ext, _) in faces.items():
            if kw in used:
                continue
            d, _ = tree.query(xy[islands[kw].index], k=1, distance_upper_bound=tol)
            if not np.isfinite(d).any():
                continue  # not beside this pier
            t = (xy[own.index] - c) @ u  # the pier island along the face
            if abs(float(t.min()) - ext[0]) > tol or abs(float(t.max()) - ext[1]) > tol:
                continue  # a wall running on past the pier island, not its face
            idx = np.r_[own.index, islands[kw].index]
            isl = classify_island(xy[idx], idx, params)
            if isl.kind != "pier" or isl.rect_rms > SPARSE_RECT_RMS_M + 0.02 * float(isl.size[0]):
                continue
            used |= {kp, kw}
            joined.append(isl)
            break
    if not joined:
        return islands
    return [i for k, i in enumerate(islands) if k not in used] + joined


#: A face runs on past its end when section points lie on its line within this many
#: times its own point spacing beyond the end (at least two clustering distances, at
#: most ``FACE_RUN_GAP_MAX_M``).
FACE_RUN_SPACINGS = 4.0
FACE_RUN_GAP_MAX_M = 0.5


def face_runs_on(
    xy: Array,
    own: NDArray[np.intp],
    c: Array,
    u: Array,
    ext: Array,
    off: float,
    tol: float,
    *,
    both_ends: bool = True,
) -> bool:
    """Whether the line of a straight face (centre ``c``, direction ``u``, extent ``ext``
    along it, its points ``own``) goes on past one of its ends: section points within
    ``off`` of the line, beyond an end by at most ``FACE_RUN_SPACINGS`` times the face's
    own point spacing (at least ``tol``, at most ``FACE_RUN_GAP_MAX_M``).  A wall face
    scanned from afar breaks into islands at the gaps between its scan lines; a pier's
    outline turns at the ends of its face (the next pier of a row stands a bay away).
    ``both_ends=False`` looks past ``ext[1]`` only (a side face running back from a
    pier's face, whose other end is the face itself).
    """
    t_own = np.sort((xy[own] - c) @ u)
    step = float(np.median(np.diff(t_own))) if len(t_own) > 1 else 0.0
    if not np.isfinite(step):
        step = 0.0
    gap = min(max(tol, FACE_RUN_SPACINGS * step), FACE_RUN_GAP_MAX_M)
    q = xy - c
    t, s = q @ u, q @ np.array([-u[1], u[0]])
    line = np.abs(s) <= off
    line[own] = False
    beyond = (t > ext[1]) & (t <= ext[1] + gap)
    if both_ends:
        beyond |= (t < ext[0]) & (t >= ext[0] - gap)
    return bool(np.any(line & beyond))


def long_wall_on_line(xy: Array, walls: NDArray[np.intp], c: Array, u: Array, off: float) -> bool:
    """Whether the points ``walls`` (of the wall islands longer than any support) cover
    ``WALL_LINE_COVER_M`` of the line through ``c`` along ``u`` within ``off`` of it
    (in bins of ``WALL_LINE_COVER_M`` / 5): a face on the line of a wall's face is that
    wall's, between two of its openings (draw 34 of the supports family: the pieces of
    a side wall between its doors, a dense inner face and two reveals, were piers)."""
    if len(walls) == 0:
        return False
    q = xy[walls] - c
    on = np.abs(q @ np.array([-u[1], u[0]])) <= off
    bin_m = WALL_LINE_COVER_M / 5
    return len(np.unique(np.floor((q[on] @ u) / bin_m))) >= 5


def face_and_sides(
    xy: Array, islands: list[Island], params: SupportParams, distance_m: float
) -> list[Island]:
    """Piers seen square on from one side: a dense face and the sparse points of the two
    faces that run back from its ends.

    The scan lines that cross a pier's front face square on are close together; those
    that graze its two side faces are far apart, so the side faces' points are left over
    (noise, or grouped at no gap) while the front face, longer than 1 m and thin, is a
    "wall" (draws 11 and 30 of the supports family: piers of 2.0 x 1.2 m in a portico's
    front row, their side faces a point every 10 cm).  A straight wall island no longer
    than ``max_support_size_m`` (:func:`short_wall_faces`) not used by another rule is
    the face of a pier when, on one side of it, the points left over (not in any
    column, pier or wall island) hold at least ``FACE_END_POINTS`` within three clustering
    distances (at least 10 cm) of each of its two ends, running back at least
    ``min_support_size_m`` from it; the face and the left-over points between its ends
    on that side, up to the deepest of them, must make a pier whose outline they lie on
    (:data:`SPARSE_RECT_RMS_M` plus 2 % of its length).  A face whose line runs on past
    an end (:func:`face_runs_on`) is a piece of a longer wall face, not a pier's, and so
    is a face on the line of a long wall's face (:func:`long_wall_on_line`), or one whose
    side runs on a long wall's line (the inner corner of two walls), or whose back lies
    on a wall face running on past it
    (:func:`~pyheracles.supports.steps.back_on_wall_face`).  Each side is taken on its
    own line (:func:`~pyheracles.supports.steps.side_on_line`, within
    :func:`~pyheracles.supports.steps.line_tolerance`): the faces of the wall an anta
    ends, stepped back 10 cm from its sides, neither belong to them nor run on from
    them (draw 8).  The
    wall-piece tests of the supports (:func:`~pyheracles.supports.detect.wall_pieces`)
    then judge it as any pier island (the piece of a wall between two doors has the wall
    in line with it).
    """
    faces = short_wall_faces(islands, xy, params)
    if not faces:
        return islands
    left = np.ones(len(xy), dtype=bool)
    for i in islands:
        if i.kind != "noise":
            left[i.index] = False
    pool = np.flatnonzero(left)
    if len(pool) < 2 * FACE_END_POINTS:
        return islands
    tol = max(0.1, 3.0 * distance_m)
    long_walls = np.concatenate(
        [np.zeros(0, np.intp)]
        + [
            i.index
            for i in islands
            if i.kind == "wall" and float(np.max(i.size)) > params.max_support_size_m
        ]
    )
    used: set[int] = set()
    piers: list[Island] = []
    for kw, (c, u, ext, rms) in faces.items():  # a few dozen short walls at most
        nrm = np.array([-u[1], u[0]])
        if face_runs_on(xy, islands[kw].index, c, u, ext, max(0.03, 3.0 * rms), tol):
            continue  # a piece of a longer (sparse) face: the outline does not turn there
        if long_wall_on_line(xy, long_walls, c, u, max(0.03, 3.0 * rms)):
            continue  # a piece of a wall between openings, its face on the wall's line
        q = xy[pool] - c
        t, s = q @ u, q @ nrm
        edge = max(0.02, 3.0 * rms)  # off the face's own points
        off = line_tolerance(rms)
        near = (t >= ext[0] - tol) & (t <= ext[1] + tol) & (np.abs(s) > edge)
        near &= np.abs(s) <= params.max_support_size_m
        for side in (1.0, -1.0):
            on = near & (side * s > 0)
            # each side on its own line: a wall face stepped back from it (the wall
            # an anta ends) is not the side, nor does it run on from it
            sides = [side_on_line(t, on & (np.abs(t - e) <= tol), e, off) for e in ext]
            ends = [e for e, _ in sides]
            if min(np.count_nonzero(e) for e in ends) < FACE_END_POINTS:
                continue
            depths = [float(np.max(side * s[e])) for e in ends]
            if min(depths) < params.min_support_size_m:
                continue
            back = side * nrm  # the side faces run back from the face's ends
            if (
                any(
                    face_runs_on(
                        xy, pool[e], c + u * x, back, np.array([0.0, d]), off, tol, both_ends=False
                    )
                    for (e, x), d in zip(sides, depths, strict=True)
                )
                or any(long_wall_on_line(xy, long_walls, c + u * x, back, off) for _, x in sides)
                or back_on_wall_face(xy, c + back * max(depths), u, ext, off, tol)
            ):
                continue  # a side runs on past the back, or on a wall's line, or the
                # back on a wall face: a wall's
            take = pool[on & (side * s <= max(depths) + tol)]
            idx = np.r_[islands[kw].index, take]
            isl = classify_island(xy[idx], idx, params)
            if isl.kind != "pier" or isl.rect_rms > SPARSE_RECT_RMS_M + 0.02 * float(isl.size[0]):
                continue
            used.add(kw)
            piers.append(isl)
            break
    if not piers:
        return islands
    return [i for k, i in enumerate(islands) if k not in used] + piers


#: The points left over are grouped again at gaps doubling from twice the clustering
#: distance up to ``ARC_GAP_M``.
SPARSE_GAP_STEP = 2.0
#: A sparse group is a pier when its points lie this close (plus 2 % of its length) to a
#: rectangle, trimmed RMS, metres (the ring test of ``rings_from_arcs`` allows 1 cm + 3 %).
SPARSE_RECT_RMS_M = 0.01


def sparse_gaps(distance_m: float) -> list[float]:
    """Gaps at which the points left over are grouped again, largest first (metres)."""
    gaps = [ARC_GAP_M]
    g = SPARSE_GAP_STEP * distance_m
    while g < ARC_GAP_M / 1.2:
        gaps.append(g)
        g *= SPARSE_GAP_STEP
    return sorted(set(gaps), reverse=True) if distance_m < ARC_GAP_M else []


def sparse_islands(
    xy: Array,
    labels: NDArray[np.intp],
    islands: list[Island],
    params: SupportParams,
    distance_m: float,
    pooled: tuple[str, ...] = ("noise",),
) -> list[Island]:
    """Supports whose section points are further apart than the clustering distance.

    The clustering distance follows the densest surfaces; a support far from the
    scanners, or seen by one distant station, is crossed by scan lines further apart
    (the gaps between them grow with the range), so its section points are left
    unclustered or in noise islands.  These left-over points are grouped again at
    gaps growing from twice ``distance_m`` to ``ARC_GAP_M`` (:func:`sparse_gaps`), the
    largest first: each group of at least ``min_points`` is classified like any island;
    columns are kept, and piers whose points lie on a rectangle outline
    (``SPARSE_RECT_RMS_M``; twin columns grouped as one do not), and their points leave
    the pool; what is left (a support merged with a chair or a neighbour at the large
    gap) is grouped again at the next smaller one; the rest stays noise.  So every
    support is grouped at the local gap of its own scan lines, not one global spacing.
    ``pooled``: the kinds of islands whose points go back into the pool (an island of
    them that groups with nothing stays as it was; see :func:`regroup_pier_pieces`).
    """
    used = np.zeros(len(xy), dtype=bool)
    for i in islands:
        if i.kind not in pooled:
            used[i.index] = True
    found: list[Island] = []
    for sub in pool_groups(xy, used, distance_m, params.min_points, max(params.min_points, 4)):
        got = sparse_group(xy[sub], sub, params)
        found += got
        if got:
            used[sub] = True
    if not found:
        return islands
    taken = np.zeros(len(xy), dtype=bool)
    for i in found:
        taken[i.index] = True
    kept = [i for i in islands if i.kind not in pooled or not taken[i.index].any()]
    return kept + found


def pool_groups(
    xy: Array, used: NDArray[np.bool_], distance_m: float, min_points: int, min_left: int
) -> Iterator[NDArray[np.intp]]:
    """Groups of the points not ``used`` (indices into ``xy``), clustered again at each
    gap of :func:`sparse_gaps`, the largest first, while at least ``min_left`` points are
    left.

    The caller marks the points of a group it takes in ``used`` before asking for the
    next one: the pool of each smaller gap is what the larger ones left.
    """
    for gap in sparse_gaps(distance_m):  # a few scales, largest first
        left = np.flatnonzero(~used)
        if len(left) < min_left:
            return
        lab = gap_clusters(xy[left], gap, min_points)
        order = np.argsort(lab, kind="stable")
        bounds = np.r_[0, np.cumsum(np.bincount(lab))]
        for g in range(1, len(bounds) - 1):  # loop over groups
            yield left[order[bounds[g] : bounds[g + 1]]]


def regroup_pier_pieces(
    xy: Array,
    islands: list[Island],
    pieces: set[int],
    params: SupportParams,
    distance_m: float,
) -> tuple[list[Island], set[int]]:
    """Pier islands grouped again with their neighbours into whole rectangle outlines.

    The outline of a pier seen from one or two sides breaks at its corners, where the
    scan lines graze its faces (draws 12 and 14 of the supports family): each piece is
    an island of its own, a partial rectangle that is later joined, in every height
    layer, to something beyond its outline -- the pier's own other faces -- like a jamb
    to its wall.  The pier islands that are not pieces of walls (``pieces``, indices
    into ``islands``) go back into the pool of left-over points with the noise and are
    grouped again as in :func:`sparse_islands`: a group of them on one rectangle
    outline is one pier; a pier island that groups with nothing stays as it was.  The
    pieces of walls are held out (in line with the wall beside them, they would join
    into wall-thick rectangles between windows).

    Returns the islands and the indices of the wall pieces among them.
    """
    if not any(i.kind == "pier" for k, i in enumerate(islands) if k not in pieces):
        return islands, pieces
    held = [replace(i, kind="wall") if k in pieces else i for k, i in enumerate(islands)]
    back = {id(held[k]): islands[k] for k in pieces}
    out = sparse_islands(xy, np.zeros(0, np.intp), held, params, distance_m, ("noise", "pier"))
    new_pieces = {k for k, i in enumerate(out) if id(i) in back}
    return [back.get(id(i), i) for i in out], new_pieces


def sparse_group(p: Array, index: NDArray[np.intp], params: SupportParams) -> list[Island]:
    """The supports of one group of sparse section points: a ring (a few scan-line
    bunches fit a rectangle as well as a circle, the ring test decides), two rings side
    by side (twin columns), a column island, or a pier whose points lie on a rectangle
    outline (``SPARSE_RECT_RMS_M``); else none."""
    ring = ring_island(p, index, params)
    if ring is not None:
        return [ring]
    isl = classify_island(p, index, params)
    if isl.kind == "column":
        return [isl]
    if isl.kind != "pier":
        return []
    twins = twin_rings(p, index, params)
    if twins is not None:
        return list(twins)
    if isl.rect_rms <= SPARSE_RECT_RMS_M + 0.02 * float(isl.size[0]):
        return [isl]
    return []
