"""Wide surfaces and loose objects: what looks like a beam face but is not one.

A straight band cut from the underside of roof boarding between two rafters,
from a floor or from the face of a wall is as straight and as planar as a beam
face, and its width (the gap between two rafters) can be any timber size.
What tells it apart is its *extent*: the surface goes on past the band's
edges, coplanar, along most of its length (the next board beyond the rafter,
the rest of the floor, the wall under a plate).  A beam face ends at its
edges; past them, in its plane, there is air (except locally, where another
member crosses in a joint).

:func:`wide_surface_bands` measures that by probing the plane beside each
band's two edges for cloud points; :func:`resting_loose` applies the same
test at the underside of a found beam that touches no other beam (timber
stored on the floor: the floor goes on around it).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.beams.cuboids import edge_coverage
from pyheracles.beams.model import BeamCuboid, StraightFacet

__all__ = [
    "cuboid_contacts",
    "hull_strip",
    "plane_occupancy",
    "resting_loose",
    "room_side",
    "seen_from_behind",
    "stands_proud",
    "wide_surface_bands",
]

#: Probes per side across the window beside an edge.
_N_ACROSS = 10
#: A side whose probes find points at least this often is a surface going on.
WIDE_OCCUPANCY = 0.5
#: Share of the far cloud on one side of a plane that makes that side the room's.
ROOM_RATIO = 2.0
#: Every this-many-th cloud point is looked at beside a covered edge (:func:`stands_proud`).
PROUD_STRIDE = 8
#: Points nearer than this to a band's plane are on it (:func:`stands_proud`), metres:
#: half the narrowest member (``BeamParams.min_beam_width_m``, 4 cm).
PROUD_MARGIN_M = 0.02


def plane_occupancy(
    tree: cKDTree,
    origin: NDArray[np.float64],
    along: NDArray[np.float64],
    across: NDArray[np.float64],
    t_range: tuple[float, float],
    s_offsets: NDArray[np.float64],
    radius: float,
    step: float,
    counts: tuple[NDArray[np.int64], NDArray[np.bool_]] | None = None,
    thickness: float | None = None,
    any_line: bool = False,
) -> float:
    """Longest run of hit rows along the most covered line of a plane strip, as a share.

    Probes sit on the grid ``origin + t * along + s * across`` for ``t`` every
    ``step`` over ``t_range`` (the rows) and ``s`` in ``s_offsets`` (the lines
    along ``along``, metres); a probe finds a point within ``radius`` and
    within ``thickness`` (default ``radius / 2``) of the plane, and a row is
    hit on a line when it is hit there and on the two next lines (a coplanar
    surface at least two line spacings wide, not the line where a surface crossing the plane meets
    it: boarding above a rafter's side face).  On each
    line the longest run of consecutive hit rows (a single missed row
    bridged) is measured, and the longest of all returned over the number of
    rows: a surface going on past an edge is often shadowed near the edge (by
    the member whose face the strip borders) but covers a line further out
    along the whole strip, while members crossing the strip (posts, struts
    and rafters of a truss in the plane of a tie) cover each line over their
    own width only, one run per member.
    ``counts`` (optional): ``(owner, ok)``, the group of every cloud point
    and whether each group's points count as found (``ok[owner[i]]``).
    With ``any_line`` a row is hit where it is hit on any line (three
    neighbouring lines together), and the longest run of such rows is
    returned: a member standing in front of the surface casts its shadow
    across the strip at a slant (a common rafter in front of a gable wall),
    so that no single line is covered along half the strip though every row
    is, beside the shadow.  Members crossing the strip still cover the rows
    of their own width only.
    """
    t = np.arange(t_range[0] + 0.5 * step, t_range[1], step)
    if len(t) == 0:
        t = np.array([0.5 * (t_range[0] + t_range[1])])
    probes = (
        origin[None, None, :]
        + t[:, None, None] * along[None, None, :]
        + s_offsets[None, :, None] * across[None, None, :]
    ).reshape(-1, 3)
    dist, idx = tree.query(probes, k=1, distance_upper_bound=radius, workers=1)
    hit = np.isfinite(dist)
    normal = np.cross(along, across)
    off_plane = np.abs((tree.data[idx[hit]] - probes[hit]) @ normal)
    hit[hit] = off_plane <= (0.5 * radius if thickness is None else thickness)
    if counts is not None:
        owner, ok = counts
        hit[hit] = ok[owner[idx[hit]]]
    hit = hit.reshape(len(t), len(s_offsets))
    # a surface, not the line where another surface crosses the plane: three
    # neighbouring lines hit together
    hit = hit[:, :-2] & hit[:, 1:-1] & hit[:, 2:]
    if any_line:
        hit = hit.any(axis=1, keepdims=True)
    filled = hit.copy()
    filled[1:-1] |= hit[:-2] & hit[2:]
    best = 0
    for col in filled.T:
        edges = np.flatnonzero(np.diff(np.concatenate([[0], col.astype(np.int8), [0]])))
        if len(edges):
            best = max(best, int((edges[1::2] - edges[::2]).max()))
    return best / len(t)


def _local_spacing(tree: cKDTree, pts: NDArray[np.float64]) -> float:
    sample = pts[:: max(1, len(pts) // 200)]
    d, _ = tree.query(sample, k=2, workers=1)
    return float(np.median(d[:, 1]))


def room_side(
    probe: NDArray[np.float64],
    centre: NDArray[np.float64],
    normal: NDArray[np.float64],
    depth_m: float,
    ratio: float = ROOM_RATIO,
) -> float:
    """Which side of a plane the frame was scanned from: +1 along ``normal``, -1, or 0.

    The room side holds at least ``ratio`` times more of the cloud (``probe``,
    a sample of it) farther than ``depth_m`` from the plane than the other: the
    frame is scanned from inside the room, and behind a face on the hull (the
    underside of a rafter, boarding, a wall plate) the cloud ends within a
    beam depth.  0 where neither side does (a plane inside the room).
    """
    h = (probe - centre) @ normal
    pos, neg = int(np.sum(h > depth_m)), int(np.sum(h < -depth_m))
    if pos >= ratio * max(neg, 1):
        return 1.0
    if neg >= ratio * max(pos, 1):
        return -1.0
    return 0.0


def seen_from_behind(
    cub: BeamCuboid,
    facets: list[StraightFacet],
    tree: cKDTree,
    probe: NDArray[np.float64],
    depth_m: float,
    parallel_deg: float = 5.0,
    margin_m: float = PROUD_MARGIN_M,
    max_cover: float = 0.2,
) -> bool:
    """Whether a box lies in front of the faces it was fitted to: an inside corner.

    A member is seen from the room: its body lies behind each seen face, on
    the side away from the scanners.  Where two surfaces of the room's hull
    meet at an inside corner (a gable wall under the boarding), their strips
    along the corner are two straight bands at an angle, and the box fitted to
    them lies on the room's side of both: it is the air in the corner, seen
    from behind: two surfaces going on past the strips' edges.  The room's side of
    each facet's plane is :func:`room_side`
    (``probe``, a sample of the cloud; ``depth_m``, the deepest member
    section); a facet with no room's side (a face inside the room) does not
    count.  The box is such a corner when it lies on the room's side of every
    facet that has one, these facets lie on at least two faces that are not
    parallel (``parallel_deg``, degrees), and behind each of them the cloud
    (``tree``) holds nothing within ``depth_m`` (farther than ``margin_m``
    from the plane) over more than ``max_cover`` of its length (10 cm bins):
    the hull ends the scan; and its plane goes on past one of its edges (within
    half a metre) over all but ``max_cover`` of its length: a surface, not a
    member's face (two members alone in a cloud, the far one taken for the
    room, have faces that end at their edges).  Behind a member's face grouped with the strip of
    a wall head it rests on (a plate's inner side) lies the member's own top
    or the wall's face: that box is a member fitted wrongly, not air.
    """
    if cub.faces_seen < 2 or len(facets) < 2:
        return False
    cos_par = np.cos(np.radians(parallel_deg))
    away: list[tuple[StraightFacet, float]] = []
    for f in facets:
        front = room_side(probe, f.centre, f.normal, depth_m)
        if front == 0:
            continue
        if np.sign(float((cub.centre - f.centre) @ f.normal)) != front:
            return False  # the box is behind this face, as behind a member's face
        away.append((f, front))
    normals = np.array([f.normal for f, _ in away]).reshape(-1, 3)
    if len(normals) < 2 or np.min(np.abs(normals @ normals[0])) >= cos_par:
        return False
    return all(
        _behind_cover(tree, f, front, depth_m, margin_m) <= max_cover
        and _beside_cover(tree, f, margin_m) >= 1.0 - max_cover
        for f, front in away
    )


def hull_strip(
    f: StraightFacet,
    box_centre: NDArray[np.float64],
    tree: cKDTree,
    probe: NDArray[np.float64],
    depth_m: float,
    margin_m: float = PROUD_MARGIN_M,
    max_cover: float = 0.2,
) -> bool:
    """Whether a facet of a box is a strip of the room's hull (boarding, a wall), box in front.

    The facet has a room's side (:func:`room_side`, ``probe`` a sample of the
    cloud, ``depth_m`` the deepest member section) and the box's centre lies on
    it; behind the facet the cloud (``tree``) holds nothing within ``depth_m``
    (farther than ``margin_m`` from its plane) over more than ``max_cover`` of
    its length; and its plane goes on past one of its edges over all but
    ``max_cover`` of it: the tests :func:`seen_from_behind` makes of each face
    of an inside corner, on one facet.
    """
    front = room_side(probe, f.centre, f.normal, depth_m)
    if front == 0 or np.sign(float((box_centre - f.centre) @ f.normal)) != front:
        return False
    return bool(
        _behind_cover(tree, f, front, depth_m, margin_m) <= max_cover
        and _beside_cover(tree, f, margin_m) >= 1.0 - max_cover
    )


def _beside_cover(tree: cKDTree, f: StraightFacet, margin_m: float, window_m: float = 0.5) -> float:
    """Share of a facet's length where its plane goes on past one of its edges (within
    ``window_m``; points within ``margin_m`` of the plane, 10 cm bins)."""
    across = np.cross(f.normal, f.axis)
    across /= np.linalg.norm(across)
    reach = 0.5 * f.width + margin_m + window_m
    t = np.arange(-0.5 * f.length, 0.5 * f.length + reach, reach)
    hits = tree.query_ball_point(f.centre + t[:, None] * f.axis, r=reach, workers=1)
    idx = np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in hits] + [[]]))
    rel = tree.data[idx.astype(np.int64)] - f.centre
    tt, ss, hh = rel @ f.axis, rel @ across, rel @ f.normal
    sel = (np.abs(tt) <= 0.5 * f.length) & (np.abs(hh) <= margin_m)
    out = np.abs(ss) - 0.5 * f.width
    sel &= (out > 2.0 * margin_m) & (out <= window_m)
    rng = (-0.5 * f.length, 0.5 * f.length)
    return max(
        edge_coverage(tt[sel & (ss > 0)], rng, 0.1), edge_coverage(tt[sel & (ss < 0)], rng, 0.1)
    )


def _behind_cover(
    tree: cKDTree, f: StraightFacet, front: float, depth_m: float, margin_m: float
) -> float:
    """Share of a facet's length with cloud points behind its plane (within ``depth_m``)."""
    across = np.cross(f.normal, f.axis)
    across /= np.linalg.norm(across)
    reach = 0.5 * f.width + margin_m  # the band and its edges
    radius = float(np.hypot(reach, depth_m))
    t = np.arange(-0.5 * f.length, 0.5 * f.length + radius, radius)
    hits = tree.query_ball_point(f.centre + t[:, None] * f.axis, r=radius, workers=1)
    idx = np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in hits] + [[]]))
    rel = tree.data[idx.astype(np.int64)] - f.centre
    tt, ss, hh = rel @ f.axis, rel @ across, -front * (rel @ f.normal)
    sel = (np.abs(tt) <= 0.5 * f.length) & (np.abs(ss) <= reach)
    sel &= (hh > margin_m) & (hh <= depth_m)
    return edge_coverage(tt[sel], (-0.5 * f.length, 0.5 * f.length), 0.1)


def stands_proud(
    tree: cKDTree,
    facet: StraightFacet,
    front: float,
    s_window: tuple[float, float],
    t_range: tuple[float, float],
    depth_m: float,
    margin_m: float,
    step_m: float = 0.1,
) -> bool:
    """Whether what lies beside a band's edge is behind its plane, not in front of it.

    The undersides of common rafters side by side are coplanar, and the next
    one lies within a few decimetres of the band's edge, as the next strip of
    boarding does beyond a rafter.  What tells a member's face from a strip of
    boarding is what lies between them, off the plane: beside a rafter's
    underside, the boarding between the rafters and the rafter's own sides
    lie *behind* the plane (away from the room), along the whole length;
    beside a strip of boarding, the rafter bounding it lies *in front*.

    Parameters
    ----------
    tree
        KD-tree on the cloud.
    facet
        The band.
    front
        +1 / -1: the room's side of the plane along ``facet.normal``
        (:func:`room_side`).
    s_window
        Offsets across the band (from its centre, along
        ``normal x axis``, metres) of the strip beside the edge.
    t_range
        The band's extent along its axis, metres from its centre.
    depth_m
        Points farther than this from the plane are not counted (the deepest
        member), metres.
    margin_m
        Points nearer than this to the plane are on it (the coplanar surface
        itself), metres.
    step_m
        Bins along the length for the coverage, metres.

    Returns
    -------
    bool
        True when the points behind the plane cover at least half of the
        band's length and more than twice what the points in front cover
        (members crossing in front, a purlin under the rafters, cover a short
        stretch each), and the plane next to the edge (the first band width,
        at least 5 cm, of the strip) is empty over at least half of the
        length: a strip of a wall at the floor goes on flush, and the tilt of
        so narrow a strip's plane puts the rest of the wall behind it.
    """
    across = np.cross(facet.normal, facet.axis)
    across /= np.linalg.norm(across)
    s_mid = 0.5 * (s_window[0] + s_window[1])
    half_s = 0.5 * abs(s_window[1] - s_window[0])
    radius = float(np.hypot(half_s, depth_m)) + step_m
    t = np.arange(t_range[0], t_range[1] + radius, radius)
    centres = facet.centre + t[:, None] * facet.axis + s_mid * across
    hits = tree.query_ball_point(centres, r=radius, workers=1)
    idx = np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in hits] + [[]]))
    idx = idx.astype(np.int64)
    rel = tree.data[idx] - facet.centre
    tt, ss, hh = rel @ facet.axis, rel @ across, front * (rel @ facet.normal)
    sel = (tt >= t_range[0]) & (tt <= t_range[1])
    sel &= (ss >= min(s_window)) & (ss <= max(s_window))
    sel &= (np.abs(hh) > margin_m) & (np.abs(hh) <= depth_m)
    n_bins = max(int(np.ceil((t_range[1] - t_range[0]) / step_m)), 1)

    def cover(mask: NDArray[np.bool_]) -> float:
        bins = np.floor((tt[mask] - t_range[0]) / step_m).astype(np.int64)
        return len(np.unique(bins)) / n_bins

    behind, ahead = cover(sel & (hh < 0)), cover(sel & (hh > 0))
    if behind < 0.5 or behind <= 2.0 * ahead:
        return False
    # beside a member's face its plane is empty up to the next member; a strip
    # of a wall at the floor, or of the floor at a wall, is flush with the rest
    out = np.sign(s_window[1] - s_window[0]) * (ss - s_window[0])  # from the window's start
    near = (out >= 0.0) & (out <= max(facet.width, 0.05))
    flush = (tt >= t_range[0]) & (tt <= t_range[1]) & near & (np.abs(hh) <= margin_m)
    return cover(flush) < 0.5


def wide_surface_bands(
    tree: cKDTree,
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    *,
    window_m: float = 0.5,
    occupancy: float = WIDE_OCCUPANCY,
    parallel_deg: float = 5.0,
    depth_m: float = 0.6,
) -> NDArray[np.bool_]:
    """Which straight facets are strips of a wider surface (boarding, floor, wall).

    Parameters
    ----------
    tree
        KD-tree on ``xyz`` (the whole cloud, not only the facets).
    xyz
        ``(N, 3)`` points, metres.
    facets
        Straight facets (:class:`StraightFacet`).
    window_m
        Smallest width of the strip probed beside each edge, metres; the strip
        is at least twice as wide as the band itself.
    occupancy
        A side is *covered* when at least this share of its probes find a
        point; a band with a covered side is a strip of a wider surface.
    parallel_deg
        Points of another straight facet count only when its axis is parallel
        to the band's within this angle, degrees: the next strip of boarding
        beyond a rafter runs along the band, while the coplanar members of a
        truss beside a tie (posts, rafters, struts) cross it.  A facet found
        to be a strip of a wider surface itself counts whatever its direction,
        when it lies in the band's plane (a second look at the bands next to
        such strips: a gable wall cut into strips across its band by the
        shadows of the common rafters in front of it).
    depth_m
        The deepest member section, metres: a covered side does not make the
        band a strip when what lies between them within this depth is behind
        the band's plane, away from the room (:func:`stands_proud`: the next
        common rafter's underside beyond the boarding between them).

    Returns
    -------
    ``(n_facets,)`` bool, True for a strip of a wider surface.

    Notes
    -----
    The probe radius is 1.5 times the band's own point spacing (at least
    1.5 cm): the neighbouring surface is scanned from about as far as the band.
    The strip starts two probe radii past the edge, so the band's own
    adjacent faces (which leave the plane at the edge) are not counted.
    """
    out = np.zeros(len(facets), dtype=bool)
    owner = np.full(len(xyz) + 1, -1, dtype=np.int64)  # + 1: the "no point" index
    for i, f in enumerate(facets):
        owner[f.index] = i
    axes = np.array([f.axis for f in facets]).reshape(-1, 3)
    cos_par = np.cos(np.radians(parallel_deg))
    probe = xyz[:: max(1, len(xyz) // 50000)]
    # what lies beside a covered edge: a point per 10 cm of length is enough
    sparse: list[cKDTree] = []

    def strip_of_surface(i: int, ok: NDArray[np.bool_]) -> bool:
        f = facets[i]
        counts = (owner, ok)
        pts = xyz[f.index]
        across = np.cross(f.normal, f.axis)
        across /= np.linalg.norm(across)
        rel = pts - f.centre
        t = rel @ f.axis
        s = rel @ across
        t_lo, t_hi = np.quantile(t, [0.02, 0.98])
        s_lo, s_hi = np.quantile(s, [0.01, 0.99])
        radius = max(1.5 * _local_spacing(tree, pts), 0.015)
        width = max(window_m, 2.0 * float(s_hi - s_lo))
        start = 2.0 * radius
        if width <= start:
            return False
        offs = start + (np.arange(_N_ACROSS) + 0.5) * (width - start) / _N_ACROSS
        step = max(0.1, 2.0 * radius)
        front = None  # the room's side of the band's plane, when first needed
        for sign, edge in ((1.0, s_hi), (-1.0, s_lo)):
            occ = plane_occupancy(
                tree,
                f.centre,
                f.axis,
                across,
                (float(t_lo), float(t_hi)),
                edge + sign * offs,
                radius,
                step,
                counts,
                any_line=True,
            )
            if occ < occupancy:
                continue
            if front is None:
                front = room_side(probe, f.centre, f.normal, depth_m)
            if not sparse:
                sparse.append(cKDTree(xyz[::PROUD_STRIDE]))
            window = (float(edge + sign * start), float(edge + sign * width))
            margin = max(0.5 * radius, PROUD_MARGIN_M)
            proud = front != 0 and stands_proud(
                sparse[0], f, front, window, (float(t_lo), float(t_hi)), depth_m, margin
            )
            if not proud:
                return True
        return False

    parallel = [np.append(np.abs(axes @ f.axis) >= cos_par, True) for f in facets]
    for i in range(len(facets)):
        ok = parallel[i].copy()  # [-1]: in no facet
        ok[i] = False
        out[i] = strip_of_surface(i, ok)
    # the pieces of a surface cut along other directions (a gable wall beside its
    # band, cut into strips by the shadows across it) are that surface, not members
    # crossing the band's plane: a second look beside the bands next to them
    if out.any() and not out.all():
        lo = np.array([xyz[f.index].min(axis=0) for f in facets])
        hi = np.array([xyz[f.index].max(axis=0) for f in facets])
        wide = np.flatnonzero(out)
        normals = np.array([f.normal for f in facets])
        centres = np.array([f.centre for f in facets])
        for i in np.flatnonzero(~out):
            f = facets[i]
            reach = max(window_m, 2.0 * f.width)
            near = np.all((lo[wide] <= hi[i] + reach) & (hi[wide] >= lo[i] - reach), axis=1)
            # in the band's plane (a surface going on, not a face across it)
            near &= np.abs(normals[wide] @ f.normal) >= cos_par
            near &= np.abs((centres[wide] - f.centre) @ f.normal) <= PROUD_MARGIN_M
            near &= ~parallel[i][wide]
            if not near.any():
                continue
            ok = parallel[i].copy()
            ok[wide[near]] = True
            ok[i] = False
            out[i] = strip_of_surface(i, ok)
    return out


def cuboid_contacts(beams: list[BeamCuboid], gap_m: float) -> list[set[int]]:
    """Neighbours of each cuboid: the others whose surfaces come within ``gap_m``.

    Tested on the corners and edge midpoints of the smaller box against the
    larger one's signed distance, and on a dense sample of each box's axis
    segment, which catches crossings and butt joints alike.
    """
    n = len(beams)
    out: list[set[int]] = [set() for _ in range(n)]
    samples = []
    for b in beams:
        u = np.linspace(-0.5, 0.5, max(int(np.ceil(b.length / 0.05)), 2) + 1)
        # points on the four long edges and the axis
        pts = []
        for a, c in ((-1, -1), (-1, 1), (1, -1), (1, 1), (0, 0)):
            off = 0.5 * (a * b.width * b.axes[:, 1] + c * b.height * b.axes[:, 2])
            pts.append(b.centre + off + u[:, None] * b.length * b.axis)
        samples.append(np.vstack(pts))
    for i in range(n):
        for j in range(i + 1, n):
            dij = beams[j].signed_distance(samples[i]).min()
            dji = beams[i].signed_distance(samples[j]).min()
            if min(dij, dji) <= gap_m:
                out[i].add(j)
                out[j].add(i)
    return out


def resting_loose(
    tree: cKDTree,
    beams: list[BeamCuboid],
    contacts: list[set[int]],
    *,
    reach_m: float = 0.06,
    window_m: float = 0.2,
    occupancy: float = WIDE_OCCUPANCY,
) -> NDArray[np.bool_]:
    """Beams that are loose objects: in a group of touching beams that all lie on a surface.

    A beam *lies on a surface* when it is about horizontal and a surface goes
    on past its sides at the level of its underside (within ``reach_m``: the
    underside is hidden, its level estimated): timber stored on the floor, a
    strip of masonry.  Touching beams form groups (``contacts``, from
    :func:`cuboid_contacts`); a group whose every beam lies on a surface is
    not part of the frame, whose rafters, posts and braces lie on none.  A
    lone beam with nothing around its underside (a single beam scanned on
    its own) is kept.  Timber stacked on stored timber, or laid between two
    pieces that hide the floor beside it, lies on the pile: a flat beam
    touching a lying one with its underside no higher than that one's top
    (within ``reach_m``) lies too, repeated through the pile.
    """
    n = len(beams)
    lying = np.zeros(n, dtype=bool)
    flat = np.zeros(n, dtype=bool)
    low = np.zeros(n)  # lowest and highest level of each cuboid, metres
    high = np.zeros(n)
    for i, b in enumerate(beams):
        half_z = 0.5 * (
            abs(b.axis[2]) * b.length + abs(b.axes[2, 1]) * b.width + abs(b.axes[2, 2]) * b.height
        )
        low[i], high[i] = b.centre[2] - half_z, b.centre[2] + half_z
        # the underside: the cross-section direction pointing most downwards
        cands = [(b.axes[:, 1], b.width, b.height), (b.axes[:, 2], b.height, b.width)]
        d, extent, side_extent = max(cands, key=lambda c: abs(c[0][2]))
        if abs(d[2]) < 0.7 or abs(b.axis[2]) > 0.2:
            continue  # not lying: an inclined or vertical member rests on no floor
        flat[i] = True
        down = -d * np.sign(d[2])
        side = np.cross(b.axis, down)
        bottom = b.centre + down * 0.5 * extent
        start = 0.5 * side_extent + reach_m
        offs = start + (np.arange(_N_ACROSS) + 0.5) * window_m / _N_ACROSS
        half = 0.5 * b.length
        for sign in (1.0, -1.0):
            occ = plane_occupancy(
                tree,
                bottom,
                b.axis,
                side,
                (-half, half),
                sign * offs,
                reach_m,
                0.1,
                thickness=reach_m,
            )
            if occ >= occupancy:
                lying[i] = True
                break
    # on the pile: a flat beam resting on (or beside) a lying one it touches
    changed = True
    while changed:
        changed = False
        for i in np.flatnonzero(flat & ~lying):
            if any(lying[k] and low[i] <= high[k] + reach_m for k in contacts[i]):
                lying[i] = True
                changed = True
    out = np.zeros(n, dtype=bool)
    seen = np.zeros(n, dtype=bool)
    for i in range(n):
        if seen[i]:
            continue
        comp, stack = [], [i]
        seen[i] = True
        while stack:
            k = stack.pop()
            comp.append(k)
            for j in contacts[k]:
                if not seen[j]:
                    seen[j] = True
                    stack.append(j)
        if lying[comp].all():
            out[comp] = True
    return out
