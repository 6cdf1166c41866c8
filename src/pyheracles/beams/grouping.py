"""Grouping of straight facets into beams: shared edges, opposite faces, continuations."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.beams.model import StraightFacet

__all__ = [
    "UnionFind",
    "face_filled",
    "face_runs",
    "group_facets",
    "inconsistent",
    "pair_relation",
    "spans_barrier",
]


#: Length of the slices a gap between two pieces of one face is read in, metres.
FILL_SLICE_M = 0.05
#: A slice of a gap holds the face when it has at least this share of the points the
#: two pieces hold per slice on average.
FILL_DENSITY_SHARE = 0.25
#: A gap is filled by the face when at least this share of its slices hold the face.
FILLED_SLICE_SHARE = 0.8


class UnionFind:
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


def pair_relation(
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


def inconsistent(
    a: list[StraightFacet],
    b: list[StraightFacet],
    cos_par: float,
    plane_tol: float,
    max_width: float,
) -> bool:
    """Whether two groups of facets together hold faces no single beam has.

    Checked on every pair of facets with parallel normals and axes, one from
    each group.  In one plane, one beam has one face: two coplanar facets
    offset across their axis by more than their half-widths are faces of two
    members lying side by side (the undersides of two rafters).  In two
    parallel planes, a beam has two opposite faces of the same width, at most
    ``max_width`` apart, facing each other: a band twice as wide as the other
    (a strip of boarding over a rafter's underside) or offset across is not
    the opposite face.
    """
    for fa in a:
        across = np.cross(fa.normal, fa.axis)
        for fb in b:
            if abs(fa.normal @ fb.normal) < cos_par or abs(fa.axis @ fb.axis) < cos_par:
                continue
            d = fb.centre - fa.centre
            sep, lateral = abs(d @ fa.normal), abs(d @ across)
            if sep <= plane_tol:
                if lateral > 0.5 * (fa.width + fb.width):
                    return True
                continue
            wmin, wmx = sorted((fa.width, fb.width))
            if sep > max_width or wmin < 0.5 * wmx or lateral > 0.5 * wmx:
                return True
    return False


def spans_barrier(
    fa: StraightFacet, fb: StraightFacet, barrier: NDArray[np.float64] | None
) -> bool:
    """Whether a wide surface fills the slab between two parallel facets.

    Counted: ``barrier`` points strictly between the two planes (2 cm margin
    off each) over the facets' common length, across the facets' extent and
    up to half a facet width past it (the surface may close the slab at an
    edge, as boarding does above the gap between two rafters); True when they
    reach a fifth of the smaller facet's points.  Between the two opposite
    faces of one beam is timber, and beside it no wide surface.
    """
    if barrier is None or len(barrier) == 0:
        return False
    n = fa.normal
    ha, hb = float(fa.centre @ n), float(fb.centre @ n)
    lo, hi = min(ha, hb) + 0.02, max(ha, hb) - 0.02
    if hi <= lo:
        return False
    across = np.cross(fa.normal, fa.axis)
    ta = np.array([fa.centre @ fa.axis - 0.5 * fa.length, fa.centre @ fa.axis + 0.5 * fa.length])
    tb = np.array([fb.centre @ fa.axis - 0.5 * fb.length, fb.centre @ fa.axis + 0.5 * fb.length])
    t_lo, t_hi = max(ta.min(), tb.min()), min(ta.max(), tb.max())
    if t_hi <= t_lo:
        return False
    sa, sb = float(fa.centre @ across), float(fb.centre @ across)
    half = max(fa.width, fb.width)  # the surface may close the slab at an edge
    h = barrier @ n
    t = barrier @ fa.axis
    s = barrier @ across
    inside = (
        (h > lo) & (h < hi) & (t > t_lo) & (t < t_hi)
        & (s > min(sa, sb) - half) & (s < max(sa, sb) + half)
    )  # fmt: skip
    return bool(inside.sum() >= 0.2 * min(len(fa.index), len(fb.index)))


def group_facets(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    parallel_deg: float,
    contact_m: float,
    min_contact_fraction: float,
    width_range: tuple[float, float] = (0.04, 0.6),
    max_gap_m: float = 0.6,
    barrier: NDArray[np.float64] | None = None,
) -> NDArray[np.int32]:
    """Join straight facets into beams.

    Two facets with axes parallel within ``parallel_deg`` belong to one beam when

    - they are *adjacent faces*: points of one within ``contact_m`` of the other
      (a boundary-to-boundary distance, not between centroids) along at least
      ``min_contact_fraction`` of the shorter facet; or
    - they are *opposite faces* or *continuations* of one face across a
      crossing beam or an occlusion (see :func:`pair_relation`); two parallel
      faces with a wide surface between them (``barrier``: ``(m, 3)`` points
      of boarding, floor or wall strips, see
      :func:`~pyheracles.beams.surfaces.wide_surface_bands`) are the facing
      sides of two members across the gap the surface spans (two rafters
      under the boarding), not one beam (see :func:`spans_barrier`).

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
    uf = UnionFind(n)
    opposite = np.zeros((0, 2), dtype=np.int64)
    links: list[tuple[int, float, int, int, str]] = []
    widths = np.array([f.width for f in facets])

    def wmax(i: int, j: int) -> float:
        return float(max(widths[i], widths[j]))

    for i in range(n):
        par = np.abs(axes[i + 1 :] @ axes[i]) >= cos_par
        box = np.all(lo[i + 1 :] <= hi[i], axis=1) & np.all(hi[i + 1 :] >= lo[i], axis=1)
        ti = xyz[facets[i].index] @ axes[i]
        int_i = (float(np.quantile(ti, 0.01)), float(np.quantile(ti, 0.99)))
        for j in np.flatnonzero(par & box) + i + 1:
            tj = xyz[facets[j].index] @ axes[i]
            int_j = (float(np.quantile(tj, 0.01)), float(np.quantile(tj, 0.99)))
            rel = pair_relation(
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
            if rel == "opposite" and spans_barrier(facets[i], facets[j], barrier):
                continue
            if rel is not None:
                links.append((0 if rel == "continuation" else 1, wmax(i, j), i, j, rel))
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
                links.append((1, wmax(i, j), i, j, "contact"))
    # continuations first, then the links between the narrowest faces first
    # (beam faces are narrower than the strips of boarding beside them), each
    # joined unless it makes a group that no single beam can be
    members: dict[int, list[int]] = {i: [i] for i in range(n)}
    kept_opp = []
    for _, _, i, j, rel in sorted(links, key=lambda k: (k[0], k[1], k[2], k[3])):
        ri, rj = uf.find(i), uf.find(j)
        if ri != rj:
            fa = [facets[k] for k in members[ri]]
            fb = [facets[k] for k in members[rj]]
            if inconsistent(fa, fb, cos_par, plane_tol, width_range[1]):
                continue
            uf.union(i, j)
            root = uf.find(i)
            members[root] = members.pop(ri) + members.pop(rj)
        if rel == "opposite":
            kept_opp.append((i, j))
    if kept_opp:
        opposite = np.array(kept_opp, dtype=np.int64)
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


def face_filled(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    fill: NDArray[np.bool_],
    fa: StraightFacet,
    fb: StraightFacet,
    ta: tuple[float, float],
    tb: tuple[float, float],
    plane_tol: float,
) -> bool:
    """Whether the gap between two pieces of one face is filled by the face's points.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres.
    tree
        KD-tree on ``xyz``.
    fill
        ``(N,)`` the points that may show the face between the pieces (in no
        straight facet and in no wide surface).
    fa, fb
        The two pieces: coplanar, on one band line (:func:`pair_relation`).
    ta, tb
        Their extents along ``fa.axis`` (1 % and 99 % quantiles), metres.
    plane_tol
        Distance to ``fa``'s plane within which a point lies on the face, metres.

    Returns
    -------
    bool
        True when at least ``FILLED_SLICE_SHARE`` of the gap's slices
        (``FILL_SLICE_M`` long) hold, within the band of the narrower piece and
        on the plane, ``FILL_DENSITY_SHARE`` of the points the pieces hold per
        slice: a face seen head-on, whose range noise lies all across it,
        breaks into regions too small for a straight facet, yet its points go
        on; a shadow or the end of a member leaves the gap empty.
    """
    g0, g1 = min(ta[1], tb[1]), max(ta[0], tb[0])
    if g1 <= g0:
        return True
    across = np.cross(fa.normal, fa.axis)
    d = fb.centre - fa.centre
    # the band's centre line, halfway between the pieces' centre lines
    base = fa.centre + 0.5 * (d @ across) * across + 0.5 * (d @ fa.normal) * fa.normal
    base = base - (base @ fa.axis) * fa.axis
    half_w = 0.5 * min(fa.width, fb.width)
    n_sl = max(1, int(np.ceil((g1 - g0) / FILL_SLICE_M)))
    sl = (g1 - g0) / n_sl
    mids = g0 + (np.arange(n_sl) + 0.5) * sl
    centres = base + mids[:, None] * fa.axis
    near = tree.query_ball_point(centres, np.hypot(half_w, 0.5 * sl) + plane_tol)
    per_m = (len(fa.index) + len(fb.index)) / max(fa.length + fb.length, 1e-9)
    need = FILL_DENSITY_SHARE * per_m * sl
    held = 0
    for k, idx in enumerate(near):
        idx = np.asarray(idx, dtype=np.int64)
        idx = idx[fill[idx]]
        if len(idx) < need:
            continue
        q = xyz[idx] - centres[k]
        on = (
            (np.abs(q @ fa.normal) <= plane_tol)
            & (np.abs(q @ across) <= half_w)
            & (np.abs(q @ fa.axis) <= 0.5 * sl)
        )
        held += int(np.count_nonzero(on) >= need)
    return held >= FILLED_SLICE_SHARE * n_sl


def face_runs(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    which: NDArray[np.int64],
    *,
    parallel_deg: float,
    max_gap_m: float,
    width_range: tuple[float, float],
    fill: NDArray[np.bool_] | None = None,
    tree: cKDTree | None = None,
    max_filled_gap_m: float = 0.0,
) -> list[list[list[int]]]:
    """Pieces of one face: the facets ``which`` joined by continuation only.

    A beam seen on one face only (its sides too sparse, too grazing or hidden
    for a facet) leaves that face as straight facets that no group takes, often
    in pieces cut by crossing members.  Pieces that continue each other
    (:func:`pair_relation` ``"continuation"``: coplanar, on one band line, of
    similar width, gap at most ``max_gap_m``) are joined into a run.  With
    ``fill`` (the points in no facet and no wide surface) and ``tree`` (a
    KD-tree on ``xyz``), runs farther apart, up to ``max_filled_gap_m``, are
    grouped when the face's points fill the gap between two of their pieces
    (:func:`face_filled`).

    Returns
    -------
    list of list of list of int
        Per group, its runs (facet indices of each); groups largest (points)
        first, a group's runs largest first.  Without ``fill`` every group holds
        one run.
    """
    which = np.asarray(which, dtype=np.int64)
    if len(which) == 0:
        return []
    cos_par = np.cos(np.radians(parallel_deg))
    plane_tol = max(3.0 * float(np.median([facets[i].plane_rms for i in which])), 0.01)
    filled = fill is not None and tree is not None and max_filled_gap_m > max_gap_m
    runs_uf = UnionFind(len(which))
    filled_links: list[tuple[int, int]] = []
    spans = []
    for i in which:
        t = xyz[facets[i].index] @ facets[i].axis
        spans.append(t)
    for a, i in enumerate(which):
        fa = facets[i]
        ta = (float(np.quantile(spans[a], 0.01)), float(np.quantile(spans[a], 0.99)))
        for b in range(a + 1, len(which)):
            fb = facets[which[b]]
            if abs(fa.axis @ fb.axis) < cos_par:
                continue
            tb_all = xyz[fb.index] @ fa.axis
            tb = (float(np.quantile(tb_all, 0.01)), float(np.quantile(tb_all, 0.99)))
            rel = pair_relation(
                fa,
                fb,
                ta,
                tb,
                cos_par=cos_par,
                plane_tol=plane_tol,
                width_range=width_range,
                max_gap=max_filled_gap_m if filled else max_gap_m,
                min_overlap=1.0,
            )
            if rel != "continuation":
                continue
            if max(ta[0], tb[0]) - min(ta[1], tb[1]) <= max_gap_m:
                runs_uf.union(a, b)
            elif face_filled(
                xyz,
                tree,  # type: ignore[arg-type]
                fill,  # type: ignore[arg-type]
                fa,
                fb,
                ta,
                tb,
                plane_tol,
            ):
                filled_links.append((a, b))
    groups_uf = UnionFind(len(which))
    for a in range(len(which)):
        groups_uf.union(a, runs_uf.find(a))
    for a, b in filled_links:
        groups_uf.union(a, b)
    size = {int(i): len(facets[i].index) for i in which}
    runs: dict[int, list[int]] = {}
    for a, i in enumerate(which):
        runs.setdefault(runs_uf.find(a), []).append(int(i))
    groups: dict[int, list[list[int]]] = {}
    for root, run in runs.items():
        groups.setdefault(groups_uf.find(root), []).append(run)
    out = [sorted(g, key=lambda r: -sum(size[i] for i in r)) for g in groups.values()]
    return sorted(out, key=lambda g: -sum(size[i] for r in g for i in r))
