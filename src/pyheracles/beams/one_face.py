"""Cuboids of beams seen on one face: a convex band, its sides going back behind it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.beams.bands import edge_line_direction
from pyheracles.beams.facets import half_max_edges
from pyheracles.beams.model import BeamCuboid, StraightFacet

__all__ = [
    "NOISE_TAIL_MARGINS",
    "SIDE_RUN_SHARE",
    "SIDE_RUN_WINDOW_M",
    "edge_coverage",
    "fit_one_face_cuboid",
    "going_back",
    "side_run",
    "spans_between",
]


#: A side going back from a one-face band's edge must reach past this many noise
#: margins (3 sigma of the face's scatter each) behind its plane: of points past
#: 3 sigma of Gaussian noise, 90 % lie within 3.64 sigma (1.21 margins); the band's
#: own scatter, or its surface going on at a tilt of a few degrees, reaches no farther.
NOISE_TAIL_MARGINS = 1.5


#: The points of a side going back from a band's edge are read in windows of this
#: many metres (no fewer than 3 profile bins) ...
SIDE_RUN_WINDOW_M = 0.03
#: ... and the side ends at the first window holding less than this share of the
#: fullest window before it (the plateau of :func:`half_max_edges` is the bins
#: above a quarter of the fullest one).
SIDE_RUN_SHARE = 0.25


def side_run(depth: NDArray[np.float64], bin_m: float, min_points: int = 15) -> NDArray[np.float64]:
    """The depths (metres behind a face's plane) of a side's points up to the side's end.

    A side face leaves the band's edge and is seen from there back to the beam's
    hidden corner, without a gap.  Another surface behind the beam (a stored
    timber, a wall), apart from it by a gap holding a few stray points, may hold
    more points in a narrower range than the side: the half-density level of the
    whole profile was then that surface's, and the depth its far edge (roof draw
    6: a common rafter's piece seen on its side, its underside 9 cm deep, a pile
    of 105 points 24-26 cm behind the face, depth 0.255 m for 0.087, and the
    piece was not joined to the rest of the rafter).  Walking from the face,
    the side ends at the first ``SIDE_RUN_WINDOW_M`` window holding less than
    ``SIDE_RUN_SHARE`` of the fullest window before it, once ``min_points`` of its
    points lie before that window; the depths before the end of that window are
    returned (a step edge keeps its half-density point).  A side seen on a few
    points only (at a grazing angle, or hidden by the members meeting it) is no
    run of its own: the few points near the face and then the hidden corner's
    surface (the boarding on a rafter's top) are read whole (roof draw 8: common
    rafters 0.053-0.073 m deep for 0.107, four points before the gap).
    """
    if len(depth) == 0:
        return depth
    d0 = float(depth.min())
    nb = int(np.ceil((float(depth.max()) - d0) / bin_m)) + 1
    counts = np.bincount(((depth - d0) / bin_m).astype(np.int64), minlength=nb).astype(float)
    k = max(round(SIDE_RUN_WINDOW_M / bin_m), 3)
    window = np.convolve(counts, np.ones(k), mode="full")[k - 1 : k - 1 + nb]  # bins i..i+k-1
    before = np.concatenate([[0.0], np.cumsum(counts)[:-1]])  # points before each bin
    low = np.flatnonzero(
        (window < SIDE_RUN_SHARE * np.maximum.accumulate(window)) & (before >= min_points)
    )
    if len(low) == 0:
        return depth
    return depth[depth < d0 + (int(low[0]) + k) * bin_m]


def edge_coverage(t: NDArray[np.float64], t_range: tuple[float, float], step: float) -> float:
    """Share of the length ``t_range`` whose ``step`` bins hold at least one of ``t``."""
    span = t_range[1] - t_range[0]
    if len(t) == 0 or span <= 0:
        return 0.0
    occupied = len(np.unique(np.floor((t - t_range[0]) / step)))
    return float(min(1.0, occupied * step / span))


def going_back(
    t: NDArray[np.float64],
    depth: NDArray[np.float64],
    t_range: tuple[float, float],
    step: float,
    noise_m: float,
) -> float:
    """Coverage of a band's length by a side going back from its edge (0: no side).

    ``t``: the side points' offsets along the band, ``depth``: how far behind
    the band's plane they lie, metres.  A side face leaving the edge is
    seen over some depth; points that reach no further than ``noise_m`` behind
    the plane (90 % of them) are the tail of the band's own scatter beside its
    edge, or its surface going on at a slight tilt (roof seed 4: a sliver of
    boarding 4 cm wide along a rafter, its plane tilted by 6 degrees, the
    boarding beyond it 2 cm behind that plane), no side: coverage 0.
    """
    if len(t) == 0 or float(np.quantile(depth, 0.9)) < noise_m:
        return 0.0
    return edge_coverage(t, t_range, step)


def _near(tree: cKDTree, start: NDArray, end: NDArray, radius: float) -> NDArray[np.int64]:
    """Indices of the tree's points within ``radius`` of the segment ``start``-``end``."""
    length = float(np.linalg.norm(end - start))
    n = max(int(np.ceil(length / radius)) + 1, 2)
    centres = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    hits = tree.query_ball_point(centres, r=radius * 1.05, workers=1)
    if not any(len(h) for h in hits):
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in hits]))


def fit_one_face_cuboid(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    facets: list[StraightFacet],
    probe: NDArray[np.float64],
    *,
    bin_m: float,
    max_depth_m: float,
    min_side_points: int = 15,
    min_cover: float = 0.2,
    min_elongation: float = 6.0,
    room_ratio: float = 2.0,
    min_fill: float = 0.7,
) -> BeamCuboid | None:
    """Cuboid of a beam seen on one face only (its pieces ``facets``), or ``None``.

    A straight band of beam width in one plane is a beam seen from one side
    when it is *convex*: its body lies behind the face, away from the scanner.
    Along the band's two edges, the cloud points off its plane are the beam's
    own side faces when they lie behind it, and the sides of two neighbouring
    members when they lie in front (a strip of boarding seen between two
    rafters is a concave channel: ``None``).  The front (the scanner's side)
    is the side of the plane holding at least ``room_ratio`` times more of
    the cloud (``probe``, a sample of it) farther than ``max_depth_m`` from
    the plane: the frame is scanned from inside the room, and behind a face
    on the hull (the underside of a rafter, boarding, a wall plate) the cloud
    ends within a beam depth, but for what pierces the roof (a chimney).
    Where neither side does (a face inside the room), the side points decide
    alone: a band whose edge points leave the plane on one side only is
    convex towards the other, or on both sides but along ``room_ratio`` times
    more of the length on one (a member crossing near the face covers its own
    width; the body's sides run along the band); a band from whose edges
    nothing leaves on either side is a beam whose sides were not seen (a thin
    slab, its depth not measured).  A band is a channel (``None``) when points come
    forward from its edges and neither edge has a side going back over
    ``min_cover`` of the length (:func:`going_back`: reaching past
    ``NOISE_TAIL_MARGINS`` noise margins, not the scatter of the band's own
    points nor its surface going on at a slight tilt).

    The face's width is read at half density across the band over the band's
    and the unassigned cloud points on its plane.  The depth behind the face
    comes from its side points (the far half-density edge of their offsets
    behind the plane, the smaller of the two edges) when an edge holds at least
    ``min_side_points`` of them over ``min_cover`` of the length (10 cm bins)
    and they end before ``0.9 max_depth_m`` (a surface through the edge, such
    as boarding on a rafter's top or masonry under a plate, runs on and
    measures nothing); otherwise the depth is not known, the cuboid is a thin
    slab on the face and ``height_measured`` is False.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points, metres.
    tree
        KD-tree on ``xyz``.
    facets
        Straight facets of the one face (continuation pieces).
    probe
        ``(m, 3)`` sample of the whole cloud (front side).
    bin_m
        Profile bin, metres.
    max_depth_m
        Largest beam section, metres.
    min_elongation
        The face is at least this many times as long as it is wide (one face is
        weaker evidence of a member than two).
    room_ratio
        Share of the far cloud that makes one side of the plane the front.
    min_fill
        Share of the tenths of the face's width whose point count reaches 30 %
        of the fullest tenths (90 % quantile): a face is filled across, a
        ladder's two rails with rungs between them are not.
    """
    w = np.array([len(f.index) for f in facets], dtype=float)
    ref = facets[int(np.argmax(w))]
    n = np.sum(
        [f.normal * np.sign(f.normal @ ref.normal) * k for f, k in zip(facets, w, strict=True)],
        axis=0,
    )
    n /= np.linalg.norm(n)
    a = np.sum(
        [f.axis * np.sign(f.axis @ ref.axis) * k for f, k in zip(facets, w, strict=True)], axis=0
    )
    a -= (a @ n) * n
    a /= np.linalg.norm(a)
    across = np.cross(n, a)
    pts = np.vstack([xyz[f.index] for f in facets])
    c = pts.mean(axis=0)
    rel = pts - c
    # the direction of the whole face's edges: the pieces' own directions are
    # measured over their short lengths, and a face flush with the band pulls them
    ang = edge_line_direction(rel @ np.column_stack([a, across]), 0.0, bin_m)
    a = np.cos(ang) * a + np.sin(ang) * across
    across = np.cross(n, a)
    t, s, h = rel @ a, rel @ across, rel @ n
    h0 = float(np.median(h))
    rms = float(np.sqrt(np.mean((h - h0) ** 2)))
    t_lo, t_hi = (float(v) for v in np.quantile(t, [0.005, 0.995]))
    s_lo, s_hi = half_max_edges(s, bin_m)
    start, end = c + a * t_lo, c + a * t_hi
    side = _near(tree, start, end, 0.5 * (s_hi - s_lo) + max_depth_m)
    r_side = xyz[side] - c
    t_s, s_s, h_s = r_side @ a, r_side @ across, r_side @ n - h0
    along = (t_s >= t_lo) & (t_s <= t_hi)
    # the width over every point on the plane (edge strips of blended normals)
    reach = max(0.05, 10.0 * bin_m)
    flat = along & (np.abs(h_s) <= max(3.0 * rms, bin_m))
    flat &= (s_s >= s_lo - reach) & (s_s <= s_hi + reach)
    if flat.sum() > len(pts):
        s_lo, s_hi = half_max_edges(s_s[flat], bin_m)
    face_w = s_hi - s_lo
    if face_w <= 0 or t_hi - t_lo < min_elongation * face_w:
        return None
    # a face is filled across its width; two rails with rungs between them (a
    # ladder) or two members with a gap are dense at the edges only
    s_face = s_s[flat] if flat.sum() > len(pts) else s
    cells = np.histogram(s_face, bins=10, range=(s_lo, s_hi))[0]
    if np.mean(cells >= 0.3 * np.quantile(cells, 0.9)) < min_fill:
        return None
    e = max(2.0 * bin_m, 0.015)
    margin = max(3.0 * rms, 2.0 * bin_m, 0.01)
    at_edge = along & ((np.abs(s_s - s_lo) <= e) | (np.abs(s_s - s_hi) <= e))
    off_lo = at_edge & (h_s < -margin) & (h_s >= -max_depth_m)
    off_hi = at_edge & (h_s > margin) & (h_s <= max_depth_m)
    step = max(0.1, 10.0 * bin_m)
    rng = (t_lo, t_hi)
    cover_lo = edge_coverage(t_s[off_lo], rng, step)
    cover_hi = edge_coverage(t_s[off_hi], rng, step)
    h_probe = (probe - c) @ n - h0
    far_pos = int(np.sum(h_probe > max_depth_m))
    far_neg = int(np.sum(h_probe < -max_depth_m))
    if far_pos >= room_ratio * max(far_neg, 1):
        front = 1.0
    elif far_neg >= room_ratio * max(far_pos, 1):
        front = -1.0
    elif min(cover_lo, cover_hi) < min_cover <= max(cover_lo, cover_hi):
        front = 1.0 if cover_lo > cover_hi else -1.0
    elif max(cover_lo, cover_hi) >= room_ratio * min(cover_lo, cover_hi):
        # the body's own sides run along the whole band; what comes off the other
        # side is a member crossing near the face, as long as it is wide (roof
        # draw 3: a king post seen on one face, its side going back over the
        # whole length, a rafter 0.22-0.58 m in front of it over a quarter)
        front = 1.0 if cover_lo > cover_hi else -1.0
    elif max(cover_lo, cover_hi) < min_cover:
        # nothing leaves either edge (a tie inside the room seen on its side, its
        # top and underside at grazing angles: roof draw 14, 3 points along 3.9 m):
        # a band with no channel walls, its depth unknown; the thin slab lies on
        # the side of the plane holding more of the cloud (its placement moves
        # the slab by its own depth, a few millimetres)
        front = 1.0 if far_pos >= far_neg else -1.0
    else:
        return None
    cover_ahead = cover_hi if front > 0 else cover_lo
    back = off_lo if front > 0 else off_hi
    # per edge: a side going back from one edge makes the band convex even when
    # a surface comes forward from the other (the boarding on a rafter's top
    # edge, seen from its side face); a channel has nothing going back but the
    # tail of its own scatter (NOISE_TAIL_MARGINS)
    back_cover = max(
        going_back(t_s[sel], -front * h_s[sel], rng, step, NOISE_TAIL_MARGINS * margin)
        for sel in (back & (np.abs(s_s - edge) <= e) for edge in (s_lo, s_hi))
    )
    if cover_ahead >= min_cover and back_cover < min_cover:
        return None  # a concave channel: the sides of two other members come forward
    depths = []
    for edge in (s_lo, s_hi):
        sel = back & (np.abs(s_s - edge) <= e)
        if sel.sum() >= min_side_points and edge_coverage(t_s[sel], rng, step) >= min_cover:
            far = half_max_edges(side_run(-front * h_s[sel], bin_m, min_side_points), bin_m)[1]
            if far < 0.9 * max_depth_m:
                depths.append(far)
    measured = bool(depths)
    depth = float(min(depths)) if measured else 2.0 * margin
    centre = (
        c + a * 0.5 * (t_lo + t_hi) + across * 0.5 * (s_lo + s_hi) + n * (h0 - front * 0.5 * depth)
    )
    if abs(across[2]) <= abs(n[2]):  # the face's width is the more horizontal size
        u, width, height = across, face_w, depth
    else:
        u, width, height = n, depth, face_w
    v = np.cross(a, u)
    cub = BeamCuboid(
        centre=centre,
        axes=np.column_stack([a, u, v]),
        length=float(t_hi - t_lo),
        width=float(width),
        height=float(height),
        rms=0.0,
        n_facets=len(facets),
        faces_seen=1,
        height_measured=measured,
    )
    dist = np.abs(cub.signed_distance(pts))
    return replace(cub, rms=float(np.sqrt(np.mean(dist**2))))


def spans_between(
    cub: BeamCuboid, beams: list[BeamCuboid], reach_m: float, cos_parallel: float
) -> bool:
    """Whether both ends of ``cub`` abut beams crossing it (a member framed between two).

    A one-face band must be twice as elongated as a straight facet to count as a
    member (one face is weak evidence), but a short member framed between two
    others (a queen post from the tie up to the straining beam, 0.97 m for a
    0.25 m face in roof draw 22) is as long as the joints at its ends let it be:
    its length says nothing about what it is.  Each end (the centre of the
    cuboid's end face) lies within ``reach_m`` of a beam of ``beams`` whose axis
    is not parallel to its own (``|cos| < cos_parallel``; a parallel beam there
    is the same line going on, a piece of one member).
    """
    ends = cub.centre + np.outer([-0.5, 0.5], cub.axis * cub.length)
    found = np.zeros(2, dtype=bool)
    for b in beams:
        if abs(float(b.axis @ cub.axis)) >= cos_parallel:
            continue
        found |= b.signed_distance(ends) <= reach_m
        if found.all():
            return True
    return False
