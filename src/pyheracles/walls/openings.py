"""Openings: edges refined from the face points, lights of one window merged."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.walls.model import Array, Opening

__all__ = [
    "face_edge_table",
    "face_edges",
    "face_spacing",
    "head_reach",
    "head_sill",
    "isolated_out",
    "merge_lights",
    "pick_edges",
    "refine_edges",
    "splay_in",
]


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
            side = (
                0 <= gap_u <= max_mullion_m
                and overlap(a.z_min, a.z_max, b.z_min, b.z_max) >= min_overlap
            )
            stacked = (
                0 <= gap_z <= max_mullion_m
                and overlap(a.u_min, a.u_max, b.u_min, b.u_max) >= min_overlap
            )
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


def refine_edges(
    uz: Array,
    face_of: NDArray[np.int64],
    u0: float,
    u1: float,
    z0: float,
    z1: float,
    c: float,
    at_foot: bool,
    jambs: tuple[float, float] | None = None,
) -> tuple[float, float, float, float]:
    """Edges of an opening from the face points around it (finer than the grid).

    Each face is measured on its own (see :func:`face_edges`), at its own point
    spacing, and the opening through the wall is where all faces are open: the
    innermost jambs, the lowest head and the highest sill of the faces measured (a
    reveal splayed towards one face widens that face's opening only).  A measured edge
    is a correction of the grid's: outwards within two cells of it (points of the wall
    beyond are no edge of it), inwards within two cells and the face's point spacing
    (:func:`face_spacing`), as the grid's hole of a sparse face reaches into
    the gaps between its points along the edge, up to the inner face's wider hole
    through a splayed reveal; a head also upwards as far as :func:`head_reach` lets
    the face measure it (the apex of a pointed head, closed in the grid); an edge
    nothing measures keeps the grid's value.  See :func:`face_edge_table` and
    :func:`pick_edges` for the two steps.
    """
    found, spacing = face_edge_table(uz, face_of, u0, u1, z0, z1, c, at_foot, jambs)
    edges, _ = pick_edges(found, spacing, (u0, u1, z0, z1), c)
    return edges


def face_edge_table(
    uz: Array,
    face_of: NDArray[np.int64],
    u0: float,
    u1: float,
    z0: float,
    z1: float,
    c: float,
    at_foot: bool,
    jambs: tuple[float, float] | None = None,
) -> tuple[Array, Array]:
    """Each face's edges of an opening (:func:`face_edges`, its lone points left out
    by :func:`isolated_out`): ``(F, 4)`` jambs, sill and head (m, NaN: not measured)
    in the order of ``np.unique(face_of)``, and each face's point spacing (m)."""
    per_face = [isolated_out(uz[face_of == f], c) for f in np.unique(face_of)]
    found = np.array([face_edges(q, u0, u1, z0, z1, c, at_foot, jambs)
                      for q in per_face]).reshape(-1, 4)  # fmt: skip
    spacing = np.array([face_spacing(q) for q in per_face])
    return found, spacing


Edges = tuple[float, float, float, float]


def pick_edges(found: Array, spacing: Array, grid: Edges,
               c: float) -> tuple[Edges, NDArray[np.int64]]:  # fmt: skip
    """The opening's edges from each face's (``found``, ``spacing``:
    :func:`face_edge_table`) about the ``grid``'s ``(u0, u1, z0, z1)`` (cell ``c``), as
    :func:`refine_edges` says, and the row of the face that set each (-1: the grid's)."""
    reach = 2 * c + spacing
    up = np.maximum(2 * c, [head_reach(c, sp) for sp in spacing])  # outwards, the head
    out, src = [], []
    for k, (pick, inward) in enumerate(((np.argmax, 1), (np.argmin, -1), (np.argmax, 1),
                                        (np.argmin, -1))):  # fmt: skip
        col = found[:, k]
        move = inward * (col - grid[k])  # > 0: into the opening
        ok = np.isfinite(col) & (move >= (-up if k == 3 else -2 * c)) & (move <= reach)
        if np.any(ok):
            rows = np.flatnonzero(ok)
            best = int(rows[pick(col[ok])])
            out.append(float(col[best]))
            src.append(best)
        else:
            out.append(grid[k])
            src.append(-1)
    return (out[0], out[1], out[2], out[3]), np.array(src, dtype=np.int64)


def splay_in(face: Array, reveals: Array, adopted: NDArray[np.bool_]) -> float:
    """How far (m) a face's hole stands outside the opening through the wall: the
    least of its jambs' distances outside the reveals' (``face``, ``reveals``: jambs,
    sill and head; ``adopted``: which of the reveals' the opening took), NaN where no
    jamb of both is measured.

    A splayed reveal widens the hole of the face it runs to on every side: its jambs,
    which the straight reveals put back (:func:`~pyheracles.walls.reveals.reveal_edges`),
    and its sill and head, which they seldom see (a sill's straight part faces up, a
    soffit behind a deep splay is out of sight from below)."""
    d = np.array([reveals[0] - face[0], face[1] - reveals[1]])
    ok = np.isfinite(d) & adopted[:2]
    return float(d[ok].min()) if ok.any() else float("nan")


def isolated_out(uz: Array, c: float, factor: float = 3.0) -> Array:
    """One face's points ``(u, z)`` without those standing alone: farther from their
    second nearest neighbour than ``factor`` times the face's spacing
    (:func:`face_spacing`) and than a grid cell ``c`` (m).

    A face is scanned in lines and columns, and each of its points has neighbours at
    its spacing; a mixed pixel or a multipath return on its plane inside an opening
    stands alone there (church draw 5: one 11 cm above a sill, 3.7 cm between the
    face's points, put the sill 7 cm high).  A face scanned from near, its points a
    few millimetres apart along its lines and more across them, has no point alone
    that far from the others at its edges (church draw 15: 2 mm, its sill and head
    lost under three times that), and nothing under a cell matters on the grid.
    """
    from scipy.spatial import cKDTree

    if len(uz) < 10:
        return uz
    d, _ = cKDTree(uz).query(uz, k=3)
    return uz[d[:, 2] <= max(factor * face_spacing(uz), c)]


def face_spacing(uz: Array) -> float:
    """Point spacing of one face's points ``(u, z)`` (m): the median distance to the
    fourth nearest neighbour (the spacing between scan lines, not along them); 0 for
    fewer than 10 points."""
    from scipy.spatial import cKDTree

    if len(uz) < 10:
        return 0.0
    d, _ = cKDTree(uz).query(uz, k=5)
    return float(np.median(d[:, 4]))


def face_edges(
    uz: Array,
    u0: float,
    u1: float,
    z0: float,
    z1: float,
    c: float,
    at_foot: bool,
    jambs: tuple[float, float] | None = None,
) -> tuple[float, float, float, float]:
    """Edges of an opening from the points of one face around it (NaN: not measured).

    The jambs are the nearest points left and right of the centre along the jambs
    (``jambs``: the heights where the opening has its full width; default its upper
    part): per row the innermost point, then a high order statistic over the rows.  Rows and the
    columns of :func:`head_sill` are as tall (wide) as the face's local point spacing
    and at least a quarter cell, so that a sparse face is not read between its points.
    """
    nan = float("nan")
    if len(uz) < 10:
        return nan, nan, nan, nan
    cells = np.unique(np.floor(uz / c).astype(np.int64), axis=0)
    step = max(0.25 * c, 1.5 * float(np.sqrt(len(cells) * c * c / len(uz))))
    h = z1 - z0
    uc = 0.5 * (u0 + u1)
    lo_z = z1 - 0.45 * h if at_foot else z0 + 0.25 * h
    hi_z = z1 - 0.1 * h
    r0 = r1 = nan
    sp = face_spacing(uz)
    if jambs is not None:
        lo_z = max(lo_z, jambs[0]) if at_foot else max(z0 + 0.05 * h, jambs[0])
        hi_z = min(hi_z, jambs[1])
    if hi_z - lo_z >= 2 * c or jambs is None:  # too short a band: the grid edges stand
        band_z = (uz[:, 1] > lo_z) & (uz[:, 1] < hi_z)
        reach = 2 * c + 2 * sp  # the next column out, for the gap at the jamb
        left = uz[band_z & (uz[:, 0] < uc) & (uz[:, 0] > u0 - reach)]
        right = uz[band_z & (uz[:, 0] > uc) & (uz[:, 0] < u1 + reach)]
        n_left = np.count_nonzero(left[:, 0] > u0 - 2 * c)
        n_right = np.count_nonzero(right[:, 0] < u1 + 2 * c)
        if n_left >= 5 and n_right >= 5:
            row = max(c, step, 1.5 * sp)  # every column of a sparse face in each row
            r0 = _row_innermost(left, row, np.maximum, u0 - 2 * c)
            r1 = _row_innermost(right, row, np.minimum, u1 + 2 * c)
    m0, m1 = (u0 if np.isnan(r0) else r0), (u1 if np.isnan(r1) else r1)
    s0, s1 = head_sill(uz, m0, m1, z0, z1, c, step, at_foot, sp)
    return r0, r1, s0, s1


def _row_innermost(uz: Array, c: float, innermost: np.ufunc, limit: float) -> float:
    """The jamb from the innermost ``u`` of each row of height ``c``.

    No face point lies inside the opening, so each row's innermost point is at the jamb
    or short of it by up to the face's spacing along ``u`` there.  Where the rows'
    innermost points spread over that spacing (scan lines crossing the jamb at varying
    phase) their 90th (left, ``np.maximum``) or 10th (right) percentile is the edge (the
    last tenth allows for a few stray points); where they do not (columns of a scan at a
    fixed azimuth, parallel to the jamb) the edge is anywhere in the gap to the next
    column, and half the gap not covered by the spread is added (the gap's middle).
    The gap is the median over the rows of the distance from the innermost point to the
    next one outwards; the spread, twice the distance from the median to the 90th
    percentile (robust to rows missing the innermost column).  Rows whose innermost
    point is beyond ``limit`` (outwards) are no jamb rows (the points beyond serve for
    the gaps only).
    """
    sign = 1.0 if innermost is np.maximum else -1.0
    v = sign * uz[:, 0]  # increasing into the opening
    rows = np.floor(uz[:, 1] / c).astype(np.int64)
    order = np.lexsort((-v, rows))  # per row, innermost first
    r, vs = rows[order], v[order]
    starts = np.flatnonzero(np.r_[True, np.diff(r) != 0])
    nxt = np.r_[starts[1:], len(vs)]
    keep = vs[starts] >= sign * limit
    starts, nxt = starts[keep], nxt[keep]
    if len(starts) == 0:
        return float("nan")
    inner = vs[starts]
    gaps = []
    for a, b in zip(starts, nxt, strict=True):
        far = vs[a] - vs[a + 1 : b]
        far = far[far > 0.25 * c]  # the next column, not a point beside the innermost
        if len(far):
            gaps.append(float(far.min()))
    q90, q50 = np.percentile(inner, [90, 50])
    gap = float(np.median(gaps)) if len(gaps) >= 3 else 0.0
    edge = q90 + 0.5 * max(0.0, gap - 2.0 * (q90 - q50))
    return float(sign * edge)


def head_reach(c: float, spacing: float) -> float:
    """How far above the grid's head (m) a face with point ``spacing`` (m) may put the
    head of an opening, on a grid of cell ``c`` (m): a cell, and up to three more less
    twice the spacing.

    The narrow apex of a pointed head is closed in the grid (a gap a cell or two
    wide, stray returns of the soffit near the plane): church draws 0, 2, 3, 6 and 9
    had pointed heads 6-14 cm short, their faces' points seen at the apex but beyond
    a cell above the grid's head.  A face measures the head from the lowest point of
    each column, up to its spacing above the edge, the highest of them taken: a
    sparse face (the splayed inner face of a high window, a face scanned from afar)
    would put it that much too high, so it is allowed less.
    """
    return c + max(0.0, 3.0 * c - 2.0 * spacing)


def head_sill(
    uz: Array,
    u0: float,
    u1: float,
    z0: float,
    z1: float,
    c: float,
    step: float,
    at_foot: bool,
    spacing: float = 0.0,
) -> tuple[float, float]:
    """Sill and head of an opening from one face's points below and above its centre
    (NaN: not measured).

    The head is the highest of the lowest points of the columns (``step`` wide, each
    the lowest of it and its two neighbours) across the central band, no higher than
    :func:`head_reach` above the grid's head (``spacing``: the face's point spacing,
    m): a pointed or round head peaks at its centre, and the lowest point of the whole
    band lies on its flanks, short of the apex.  The sill is put by the columns'
    highest points below the centre as a jamb is by its rows' innermost points
    (:func:`_row_innermost`: scan lines crossing the sill at varying heights, or at
    fixed heights with the gap to the next line below), no higher than half the
    spacing above their median: each column's highest point is up to the spacing below
    the sill (church draws 1 and 4: sills of sparse faces 6-9 cm low from the median),
    and mixed pixels standing on a sill, on the plane, move the median little (doors
    reaching the wall's foot are not measured there).
    """
    nan = float("nan")
    uc, zc, w = 0.5 * (u0 + u1), 0.5 * (z0 + z1), u1 - u0
    reach = head_reach(c, spacing)
    band_u = np.abs(uz[:, 0] - uc) < max(0.05 * w, c, step)
    up = band_u & (uz[:, 1] > zc) & (uz[:, 1] < z1 + reach + c)
    down = band_u & (uz[:, 1] < zc) & (uz[:, 1] > z0 - 2 * c)
    head = sill = nan
    if np.count_nonzero(up) >= 3:
        col = np.floor(uz[up, 0] / step).astype(np.int64)
        order = np.lexsort((uz[up, 1], col))
        first = np.flatnonzero(np.r_[True, np.diff(col[order]) != 0])
        low = uz[up, 1][order][first]
        if len(low) >= 3:  # lower envelope over three columns: a sparse column's
            low = np.minimum(np.minimum(low[:-2], low[1:-1]), low[2:])  # lowest is high
        head = min(float(low.max()), z1 + reach)
    if not at_foot and np.count_nonzero(down) >= 3:
        col = np.floor(uz[down, 0] / step).astype(np.int64)
        order = np.lexsort((-uz[down, 1], col))
        first = np.flatnonzero(np.r_[True, np.diff(col[order]) != 0])
        tops = uz[down, 1][order][first]
        below = uz[band_u & (uz[:, 1] < zc)]  # with the points under the tops: the gaps
        edge = _row_innermost(below[:, ::-1], step, np.maximum, z0 - 2 * c)
        sill = min(edge, float(np.median(tops)) + 0.5 * spacing)
    return sill, head
