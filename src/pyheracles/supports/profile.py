"""A support's own measured profile: what it stands on, what it carries, how far it reaches.

Three measurements on the points of one cookie (the points around one section shape,
with their offset ``rho`` from that shape and their angle around it):

* :func:`carried_surface` -- the lowest surface above the section that the support
  carries: the first height layer in which one horizontally connected piece of points
  runs from within the cookie's buffer out into the ring around it (an architrave, a
  beam, a ceiling, the springing of a vault; the roof of a kiosk when no attic split
  was made), unless the support's own surface goes on above it (eaves lower than the
  column tops, a fence rail).  A broken column or one under the open sky carries
  nothing.  This
  replaces the attic limit and the body top as the top of a support: a support keeps
  its full height up to what it carries, whatever an attic split said.
* :func:`surface_tolerance` -- how far above a floor (below a ceiling) points still
  belong to that surface: three robust standard deviations of its heights.
* :func:`band_reach` -- per height layer, how far from the section shape the support
  reaches: from the median over the angular sectors of the innermost offset (square
  plinths and abaci are reached at their corners, a chair or a fence in a few sectors
  does not move the median).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from pyheracles.geometry.groups import group_medians
from pyheracles.supports.core import Array, Scales

#: A carried surface must cover at least this many 10-degree sectors of the ring (a
#: scaffold tube or a sign arm touching a column covers one; a beam end two and more).
MIN_CARRIED_SECTORS = 2
#: A support goes on above a surface when its own surface is found in one of this many
#: layers above it.
CONTINUE_LAYERS = 3
#: A square part (plinth, abacus) reaches sqrt(2) times its face distance at its corners.
CORNER_FACTOR = float(np.sqrt(2.0))


def surface_tolerance(z: Array, level: float, cell: float, bounds: tuple[float, float]) -> float:
    """Three robust standard deviations of the heights ``z`` within ``cell`` of ``level``,
    clipped to ``bounds`` (metres)."""
    near = z[np.abs(z - level) <= cell]
    if len(near) < 10:
        return bounds[1]
    sigma = 1.4826 * float(np.median(np.abs(near - np.median(near))))
    return float(np.clip(3.0 * sigma, *bounds))


@dataclass(frozen=True)
class LayerPieces:
    """Horizontally connected pieces of a cookie's points, layer by layer.

    Cells of ``cell`` metres (horizontal) by ``cell`` (height) from ``z0`` up; pieces are
    8-connected components of occupied cells within one layer.  Per cell: ``layer``,
    ``rmin`` (smallest offset), ``piece``; per piece: ``reach_in`` (smallest offset),
    ``ring_sectors`` (10-degree sectors of the ring it covers); per point: ``cell_of``.
    """

    cell: float
    z0: float
    layer: NDArray[np.int64]
    rmin: Array
    piece: NDArray[np.intp]
    reach_in: Array
    ring_sectors: NDArray[np.int64]
    cell_of: NDArray[np.intp]
    point_layer: NDArray[np.int64]


def layer_pieces(
    xy: Array, z: Array, rho: Array, centre: Array, buffer: float, ring: float, cell: float
) -> LayerPieces:
    """:class:`LayerPieces` of cookie points (offsets ``rho`` from the section shape;
    ring points beyond ``buffer + ring / 2`` count for ``ring_sectors``)."""
    q = xy - centre
    ij = np.floor(q / cell).astype(np.int64)
    ij -= ij.min(axis=0) - 1  # a margin of one cell: neighbours never wrap
    z0 = float(z.min())
    k = np.floor((z - z0) / cell).astype(np.int64)
    nj = int(ij[:, 1].max()) + 2
    ni = int(ij[:, 0].max()) + 2
    key = (k * ni + ij[:, 0]) * nj + ij[:, 1]
    cells, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    m = len(cells)
    rmin = np.full(m, np.inf)
    np.minimum.at(rmin, inv, rho)
    src, dst = [], []
    for di, dj in ((0, 1), (1, -1), (1, 0), (1, 1)):  # 8-neighbours within one layer
        nb = cells + di * nj + dj
        pos = np.minimum(np.searchsorted(cells, nb), m - 1)
        hit = cells[pos] == nb
        src.append(np.flatnonzero(hit))
        dst.append(pos[hit])
    a, b = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(m, m))
    lab = connected_components(graph, directed=False)[1]
    n_lab = int(lab.max()) + 1
    reach_in = np.full(n_lab, np.inf)
    np.minimum.at(reach_in, lab, rmin)
    sec = np.floor((np.arctan2(q[:, 1], q[:, 0]) + np.pi) / (2 * np.pi) * 36).astype(np.int64)
    out_pt = rho > buffer + 0.5 * ring
    cover = np.zeros((n_lab, 36), dtype=bool)
    cover[lab[inv[out_pt]], sec[out_pt] % 36] = True
    return LayerPieces(cell, z0, cells // (ni * nj), rmin, lab, reach_in, cover.sum(axis=1), inv, k)


def carried_surface(
    xy: Array,
    z: Array,
    rho: Array,
    centre: Array,
    buffer: float,
    ring: float,
    sc: Scales,
    h_from: float,
) -> tuple[float, NDArray[np.bool_]]:
    """Underside of the lowest surface a support carries above ``h_from`` (inf if none).

    Parameters
    ----------
    xy, z, rho
        Cookie points: horizontal coordinates, heights, offsets from the section shape
        (metres, > 0 outside it).
    centre
        Centre of the section shape.
    buffer, ring
        The cookie's buffer and the width of the ring beyond it (metres).
    sc
        Lengths from the point spacing (cells of ``max(0.05, 3 x spacing)``).
    h_from
        Start of the search (the top of the section slab), metres.

    Returns
    -------
    z_carried : float
        Low quantile (2 %) of the heights of the carried piece's ring points in its
        lowest layer, or ``inf``.
    carried : (M,) bool
        The points of the carried pieces (every layer), to be left out of the support.
    """
    carried = np.zeros(len(z), dtype=bool)
    sel = np.flatnonzero(z > h_from)
    if len(sel) < 10:
        return np.inf, carried
    lp = layer_pieces(xy[sel], z[sel], rho[sel], centre, buffer, ring, max(0.05, 3.0 * sc.spacing))
    spanning = (lp.reach_in <= buffer) & (lp.ring_sectors >= MIN_CARRIED_SECTORS)
    if not spanning.any():
        return np.inf, carried
    # A support passing through a surface (eaves hanging lower than the column tops, a
    # fence rail, a gallery) goes on above it: pieces of its own surface (within tol of
    # the section shape) that belong to no spanning piece, in the layers just above.
    own = ~spanning[lp.piece] & (lp.rmin <= sc.tol)
    own_layers = np.unique(lp.layer[own])
    k_low = -1
    for kc in np.unique(lp.layer[spanning[lp.piece]]):  # candidate layers, low to high
        above = own_layers[(own_layers > kc) & (own_layers <= kc + CONTINUE_LAYERS)]
        if len(above) == 0:
            k_low = int(kc)
            break
    if k_low < 0:
        return np.inf, carried
    span_pt = spanning[lp.piece[lp.cell_of]] & (lp.point_layer >= k_low)
    low = span_pt & (lp.point_layer == k_low) & (rho[sel] > buffer)
    z_c = float(np.quantile(z[sel][low], 0.02)) if low.any() else lp.z0 + k_low * lp.cell
    carried[sel[span_pt]] = True
    return z_c, carried


def attached_share(
    xy: Array,
    z: Array,
    rho: Array,
    centre: Array,
    buffer: float,
    ring: float,
    sc: Scales,
    z_range: tuple[float, float],
) -> float:
    """Share of the height layers in ``z_range`` in which a support is joined to something
    that runs out through its ring (0..1).

    A support stands free over most of its height; a door or window jamb, a reveal or a
    piece of a ruined wall cut off in the section is a wall edge: in most layers the
    wall runs on from its own surface (within ``2 x tol`` of the section shape) out
    into the ring, in at least ``MIN_CARRIED_SECTORS`` sectors.  Floors, ceilings and
    the clutter touching a column fill a few layers only.
    """
    sel = np.flatnonzero((z > z_range[0]) & (z < z_range[1]))
    if len(sel) < 10 or z_range[1] <= z_range[0]:
        return 0.0
    lp = layer_pieces(xy[sel], z[sel], rho[sel], centre, buffer, ring, max(0.05, 3.0 * sc.spacing))
    joined = (lp.reach_in <= 2.0 * sc.tol) & (lp.ring_sectors >= MIN_CARRIED_SECTORS)
    n_layers = max(1, int(np.ceil((z_range[1] - z_range[0]) / lp.cell)))
    return float(len(np.unique(lp.layer[joined[lp.piece]]))) / n_layers


def angular_sector(ang: Array, sectors: int) -> NDArray[np.intp]:
    """Sector (``0 .. sectors - 1``) of each angle ``ang`` (radians, -pi..pi) in a
    circle cut into ``sectors`` equal sectors from -pi."""
    return np.floor((ang + np.pi) / (2 * np.pi) * sectors).astype(np.intp) % sectors


def band_reach(
    rho: Array,
    ang: Array,
    z: Array,
    layer: float,
    sectors: int,
    radius: float,
    tol: float,
) -> Array:
    """Largest offset from the section shape kept in each point's height layer (metres).

    Per layer, the innermost offset of every occupied angular sector (the largest of the
    layer and its two neighbours); their median is the layer's face distance ``e``.  A
    layer within ``tol`` of the section shape (``e <= tol``: the shaft) reaches
    ``e + tol``; a wider one is a square part (plinth, base, abacus, impost) that reaches
    ``CORNER_FACTOR`` times its face distance from the axis at its corners:
    ``CORNER_FACTOR x (e + radius) - radius + tol`` (``radius`` 0 for offsets from a
    rectangle).  The reach of a layer is the largest of its own and its two neighbours'
    (a plinth's top face is reached from the plinth's sides below it).  A chair, a fence
    or a sign touching a support fills a few sectors of a layer and does not move the
    median.
    """
    if len(rho) == 0:
        return np.zeros(0)
    li = np.floor((z - z.min()) / layer).astype(np.intp)
    si = angular_sector(ang, sectors)
    nl = int(li.max()) + 1
    rmin = np.full((nl, sectors), np.inf)
    np.minimum.at(rmin, (li, si), rho)
    # per sector the largest innermost offset of the layer and its neighbours: the face of
    # a plinth, not its top face blurred into the layer by the noise, sets a plinth layer
    pad = np.full((1, sectors), -np.inf)
    finite = np.where(np.isfinite(rmin), rmin, -np.inf)
    near = np.maximum(np.maximum(finite, np.r_[finite[1:], pad]), np.r_[pad, finite[:-1]])
    have = np.isfinite(near).any(axis=1)
    e = np.zeros(nl)
    if have.any():
        e[have] = np.nanmedian(np.where(np.isfinite(near[have]), near[have], np.nan), axis=1)
    e = np.maximum(e, 0.0)
    square = CORNER_FACTOR * (e + radius) - radius + tol
    reach = np.where(e <= tol, e + tol, square)
    up = np.r_[reach[1:], -np.inf]
    down = np.r_[-np.inf, reach[:-1]]
    return np.maximum(np.maximum(reach, up), down)[li]


#: A wall cell holds points in at least this share of a support's height layers.
WALL_CELL_SHARE = 0.5


def wall_beside(
    xy: Array,
    z: Array,
    rho: Array,
    centre: Array,
    radius: float,
    sc: Scales,
    z_range: tuple[float, float],
) -> tuple[Array, float] | None:
    """The wall plane a column stands in, from the wall itself, not from a point count.

    Cells of ``max(0.05, 3 x spacing)`` of the cookie's points that are not the column's
    (offset from its circle ``rho`` beyond ``2 x tol`` plus a cell: its own surface and
    noise are not a wall): a wall fills a cell over most of the height layers of
    ``z_range`` (``WALL_CELL_SHARE``; the caller gives the upper half of the column), a
    floor, a chair or a fence does not.  The wall cells must lie on one line (RMS within
    a cell) with a run of at least four cells at most two cells apart (the tubes of a
    scaffold tower are single cells), and the column's circle must reach that line (its
    axis within ``radius + 2 x tol`` of it): the column is engaged in the wall even where
    the junction is in the shadow.

    Returns
    -------
    (normal, d) or None
        Unit normal of the face pointing to the column's axis and the face offset
        (``normal . x = d`` on the face).
    """
    c = max(0.05, 3.0 * sc.spacing)
    sel = (z > z_range[0]) & (z < z_range[1]) & (rho > 2.0 * sc.tol + c)
    n_layers = int(np.ceil((z_range[1] - z_range[0]) / c))
    if np.count_nonzero(sel) < 20 or n_layers < 4:
        return None
    q = xy[sel] - centre
    ij = np.floor(q / c).astype(np.int64)
    ij -= ij.min(axis=0)
    k = np.floor((z[sel] - z_range[0]) / c).astype(np.int64)
    nj = int(ij[:, 1].max()) + 1
    cell = ij[:, 0] * nj + ij[:, 1]
    pairs = np.unique(cell * (n_layers + 1) + k)
    cells, n_occ = np.unique(pairs // (n_layers + 1), return_counts=True)
    wall = cells[n_occ >= WALL_CELL_SHARE * n_layers]
    if len(wall) < 4:
        return None
    pts = np.c_[wall // nj, wall % nj].astype(np.float64) * c + c / 2
    pts += np.floor(q.min(axis=0) / c) * c  # back to offsets from the centre
    m = pts.mean(axis=0)
    _, vec = np.linalg.eigh(np.cov((pts - m).T))
    n = vec[:, 0]
    d = float(n @ m)
    if np.sqrt(np.mean((pts @ n - d) ** 2)) > c or abs(d) > radius + 2.0 * sc.tol:
        return None
    # a face is continuous: a run of at least four wall cell positions along it, at most
    # two cells apart
    # (the vertical tubes of a scaffold tower round a column are single cells a metre
    # apart, on a line too)
    along = np.unique(np.round(pts @ np.array([-n[1], n[0]]) / c))  # cell positions
    breaks = np.flatnonzero(np.diff(along) > 2.0 + 1e-9)
    runs = np.diff(np.r_[0, breaks + 1, len(along)])
    if runs.max() < 4:
        return None
    if d > 0:  # the normal points from the face to the axis (the centre is the origin)
        n, d = -n, -d
    return n, d + float(n @ centre)


#: Height above a support's top searched for something resting over it, metres.
OVERHEAD_M = 0.5
#: Angular sectors of the overhead search.
OVERHEAD_SECTORS = 36


def overhead_cover(z: Array, ang: Array, top: float) -> float:
    """Share of the angular sectors round a support holding points of its cookie's ring
    within :data:`OVERHEAD_M` above its top ``top`` (0..1); ``z``, ``ang``: heights and
    angles round the section shape of the ring's points (beyond the buffer: a capital
    or an abacus the support's own points did not keep is not in the ring).

    A broken column's top is open; the post of a pulpit has its tub over it, whose
    sides stand round the post in every sector (its underside, level with the
    scanners, is not seen: the post carries nothing)."""
    above = (z > top) & (z <= top + OVERHEAD_M)
    if not above.any():
        return 0.0
    sec = angular_sector(ang[above], OVERHEAD_SECTORS)
    return len(np.unique(sec)) / OVERHEAD_SECTORS


#: Share of a piece's points on its faces (within a cell of the median offset of their
#: sector) for it to be made of upright faces.
UPRIGHT_SHARE = 0.8
#: A piece of a support cut off at one of its ends (a plinth, an abacus) covers at least
#: this share of the angular sectors its neighbouring end covers.
END_SECTOR_SHARE = 0.5


def end_pieces(
    z: Array,
    rho: Array,
    ang: Array,
    lab: NDArray[np.int32],
    kept: NDArray[np.bool_],
    cell: float,
    sectors: int,
) -> NDArray[np.bool_]:
    """Pieces of a support cut off from it at its foot or its head by a face the scanners
    did not see: the top of a plinth, the underside of an abacus (``kept`` grown by them).

    ``lab``: the support's points clustered in 3D (0: none), ``kept``: the points of the
    pieces joined to its section; ``z``, ``rho``, ``ang``: heights, offsets from the
    section shape and angles about it.  The pieces that go on above the kept head from
    within two layers of ``cell`` of it (or below the kept foot) and are made of
    upright faces (:func:`upright_pieces`) are
    added when together they stand round the support: their points fill at least
    :data:`END_SECTOR_SHARE` of the angular sectors the kept points fill in the two
    layers at that end.  A square plinth 2.5 r wide stands out of its shaft by more than
    the clustering's gap: without its top face its sides were clusters of their own and
    left out (supports draw 23: plinths and abaci of 1 m columns, 12-17 % of their
    points).  Repeated, so that a base and the plinth under it are both added.
    """
    out = kept.copy()
    n_lab = int(lab.max(initial=0)) + 1
    if not out.any() or n_lab == 1:
        return out
    sec = angular_sector(ang, sectors)
    z_lo = np.full(n_lab, np.inf)
    z_hi = np.full(n_lab, -np.inf)
    np.minimum.at(z_lo, lab, z)
    np.maximum.at(z_hi, lab, z)
    cand = np.zeros(n_lab, dtype=bool)
    cand[lab[~out]] = True
    cand[0] = False
    cand &= upright_pieces(rho, sec, lab, n_lab, sectors, cell)
    ids = np.flatnonzero(cand)
    while len(ids):
        lo, hi = float(z[out].min()), float(z[out].max())
        up = (np.abs(z_lo[ids] - hi) <= 2 * cell) & (z_hi[ids] > hi)  # from the head up
        down = (np.abs(z_hi[ids] - lo) <= 2 * cell) & (z_lo[ids] < lo)  # from the foot down
        ends = ((up, out & (z >= hi - 2 * cell)), (down, out & (z <= lo + 2 * cell)))
        added = np.zeros(len(ids), dtype=bool)
        for near, end in ends:
            if not near.any():
                continue
            theirs = np.isin(lab, ids[near])
            mine = np.unique(sec[end])
            if len(np.intersect1d(mine, sec[theirs])) >= END_SECTOR_SHARE * len(mine):
                out |= theirs
                added |= near
        if not added.any():
            break
        ids = ids[~added]
    return out


def upright_pieces(
    rho: Array,
    sec: NDArray[np.intp],
    lab: NDArray[np.int32],
    n_lab: int,
    sectors: int,
    cell: float,
) -> NDArray[np.bool_]:
    """Per label of ``lab`` (0 .. n_lab - 1), whether its points are upright faces about a
    support: at least :data:`UPRIGHT_SHARE` of them lie within ``cell`` of the median
    offset ``rho`` of the label's points in their angular sector ``sec`` (a floor or a
    ceiling spreads from the support out to the cookie's edge; the noisy fringe of a
    floor touching a plinth's foot leaves most of its face)."""
    key = lab.astype(np.int64) * sectors + sec
    med = group_medians(rho, key, n_lab * sectors)
    on = np.abs(rho - med[key]) <= cell
    n = np.bincount(lab, minlength=n_lab)
    return np.bincount(lab, weights=on, minlength=n_lab) >= UPRIGHT_SHARE * np.maximum(n, 1)


#: A layer is narrower than the support below it when at least this share of the angular
#: sectors it shares with the layers below (and at least ``MIN_NARROW_SECTORS``) hold
#: points well inside the support's outline there.
NARROW_SHARE = 0.25
MIN_NARROW_SECTORS = 3
#: ... unless its points lie on that outline (within ``tol``) in at least this share of
#: those sectors: the support goes on there (an outlier cluster inside a shaft).
ON_OUTLINE_SHARE = 0.5
#: Layers below a layer whose outline is the support's there (the outer envelope of
#: their innermost offsets per sector).
OUTLINE_LAYERS = 4
#: A sector's outline is carried up through layers without its points for at most this
#: height, metres.
OUTLINE_STALE_M = 1.0


def held_narrow(rmin: Array, filled: Array, k: int, tol: float) -> bool:
    """Whether the layers from ``k`` up stay narrower than the support's own outline
    under ``k`` in more than :data:`OUTLINE_LAYERS` of ``2 x OUTLINE_LAYERS`` layers
    (``rmin``: innermost offset per layer and sector, ``filled``: the same carried up
    over empty layers, :func:`head_cut`).

    The outline under ``k`` is, per sector, the innermost of the :data:`OUTLINE_LAYERS`
    layers below the layer under ``k`` (where the underside of what the support carries
    lies): a scaffold board round a shaft widens one or two of them, not all.  What
    :func:`head_cut` compares a layer with follows what stands on the support: the
    faces of a girder across a column, a prism of their own, become that outline four
    layers above its underside, and the girder then seems to go on as the column
    (supports draw 13: girders over 20 columns kept with them, 2-4 layers narrow).
    """
    below = filled[max(0, k - 1 - OUTLINE_LAYERS) : max(0, k - 1)]
    below = np.where(np.isfinite(below), below, np.inf)
    own = below.min(axis=0) if len(below) else np.full(rmin.shape[1], np.inf)
    up = rmin[k : k + 2 * OUTLINE_LAYERS]
    both = np.isfinite(up) & np.isfinite(own)[None, :]
    gap = np.where(both, up - np.where(np.isfinite(own), own, 0.0)[None, :], 0.0)
    narrow = both & (gap < -tol) & (up < -tol)
    on = both & (np.abs(gap) <= tol)
    n_both, n_narrow = both.sum(axis=1), narrow.sum(axis=1)
    flag = (n_narrow >= MIN_NARROW_SECTORS) & (n_narrow >= NARROW_SHARE * n_both)
    flag &= on.sum(axis=1) < ON_OUTLINE_SHARE * n_both
    return int(np.count_nonzero(flag)) > OUTLINE_LAYERS


def head_cut(
    rho: Array,
    ang: Array,
    z: Array,
    h_from: float,
    h_to: float,
    layer: float,
    sectors: int,
    tol: float,
) -> float:
    """Height at which what stands on a support begins, read from inside its outline
    (metres; inf when nothing does).

    A support's own surface in an angular sector about its section shape goes up at
    the offset ``rho`` it has in the layers below (a taper or a lean moves it by
    millimetres per layer; a capital widens it): nothing of the support lies more than
    ``tol`` inside that outline.  Above its top the scanners see what it carries
    from below, over the support's own plan: the springing of a groin vault rising from
    its abacus, the side faces of a girder across it, the underside of a beam, are
    points well inside the outline of the layers below in many sectors at once, and
    over the support's section (the mixed pixels under an abacus 1.2 m wide lie inside
    the abacus's outline, outside the shaft: supports draw 11).  From
    ``h_from`` (above the section) up, in layers of ``layer``: a layer narrows when its
    innermost offsets lie more than ``tol`` inside the section shape and inside the
    outer envelope of those of
    the :data:`OUTLINE_LAYERS` layers below (a sector's last layers with points, up to
    :data:`OUTLINE_STALE_M` below: the capital's shadow leaves layers empty) in at
    least :data:`NARROW_SHARE` of the sectors both hold (and :data:`MIN_NARROW_SECTORS`),
    while its points lie on that outline in fewer than :data:`ON_OUTLINE_SHARE` of them
    (a cluster of outliers inside a shaft, supports draw 13, leaves the shaft's surface
    all round it); the first of two narrowing layers in a row marks the top, and the
    layer under it, where the carried surface's underside lies, is left out too, if
    more than :data:`OUTLINE_LAYERS` of the ``2 x OUTLINE_LAYERS`` layers from there up
    narrow (clutter that widened the outline below, a scaffold board round a shaft,
    makes the shaft above it narrower than the outline for ``OUTLINE_LAYERS`` layers
    at most: supports draw 22), or if they narrow against the outline under that layer
    (:func:`held_narrow`: a girder's faces become the outline four layers up).  Only
    points below ``h_to`` (the underside of the
    spanning surface it carries) count.  The
    spanning test of :func:`carried_surface` did not see these: a vault funnel rises
    0.8-1.8 m within a column's cookie before it reaches the ring around it, and a
    girder's faces over a column look like the column going on up (supports draws 15,
    39: vault points 30 % of a column; draw 13: girders and joists over 20 columns).
    """
    sel = (z >= h_from) & (z < h_to)
    if np.count_nonzero(sel) < 10:
        return np.inf
    li = np.floor((z[sel] - h_from) / layer).astype(np.intp)
    nl = int(li.max()) + 1
    if nl < OUTLINE_LAYERS + 2:
        return np.inf
    rmin = np.full((nl, sectors), np.inf)
    np.minimum.at(rmin, (li, angular_sector(ang[sel], sectors)), rho[sel])
    # per sector, the offsets of its last layers with points (the shadow of a capital
    # leaves layers empty under what stands on it), at most OUTLINE_STALE_M below
    seen = np.isfinite(rmin)
    rows = np.where(seen, np.arange(nl)[:, None], -1)
    last = np.maximum.accumulate(rows, axis=0)
    stale = np.arange(nl)[:, None] - last > max(OUTLINE_LAYERS, OUTLINE_STALE_M / layer)
    filled = np.where((last >= 0) & ~stale, rmin[np.maximum(last, 0), np.arange(sectors)], -np.inf)
    ref = np.full((nl, sectors), -np.inf)
    for k in range(1, OUTLINE_LAYERS + 1):  # envelope of the layers below each layer
        ref[k:] = np.maximum(ref[k:], filled[:-k])
    both = np.isfinite(rmin) & np.isfinite(ref)
    narrow = both & (rmin < ref - tol) & (rmin < -tol)  # and inside the section shape
    on = both & (np.abs(rmin - ref) <= tol)  # the support's surface going on
    n_both = both.sum(axis=1)
    n_narrow = narrow.sum(axis=1)
    flag = (n_narrow >= MIN_NARROW_SECTORS) & (n_narrow >= NARROW_SHARE * n_both)
    flag &= on.sum(axis=1) < ON_OUTLINE_SHARE * n_both
    flag[:OUTLINE_LAYERS] = False  # the outline is measured first
    run = flag[:-1] & flag[1:]
    if not run.any():
        return np.inf
    k = int(np.argmax(run))
    # and the narrowing lasts longer than the outline's memory: a scaffold board round a
    # shaft widens its outline for a layer or two, and the shaft above it is narrower
    # than that outline for OUTLINE_LAYERS layers at most
    if np.count_nonzero(flag[k : k + 2 * OUTLINE_LAYERS]) <= OUTLINE_LAYERS and not (
        held_narrow(rmin, filled, k, tol)
    ):
        return np.inf
    return h_from + (k - 1) * layer
