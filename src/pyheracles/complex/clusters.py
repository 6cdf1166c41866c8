"""Objects from a polygon's candidate points: clusters, scattered points (foliage), hulls."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.complex.eaves import eave_points
from pyheracles.complex.params import EXACT_LIMIT, ComplexParams
from pyheracles.segment.euclidean import euclidean_clusters, voxel_clusters

__all__ = [
    "EDGE_SHARE",
    "POROUS_NEIGHBOURS",
    "POROUS_RADIUS_M",
    "SOLID_SHARE",
    "TOP_NEIGHBOURS",
    "cluster",
    "floating_clusters",
    "hull",
    "level_heights",
    "local_top",
    "object_points",
    "porous_points",
    "scattered_points",
    "select_clusters",
    "solid_structures",
    "vote_scattered",
]


def cluster(xyz: NDArray[np.float64], params: ComplexParams) -> NDArray[np.int32]:
    d = float(params.cluster_distance_m)  # type: ignore[arg-type]
    use_voxel = params.clustering == "voxel" or (
        params.clustering == "auto" and len(xyz) > EXACT_LIMIT
    )
    if use_voxel:
        return voxel_clusters(xyz, d / 2.0, 1)
    return euclidean_clusters(xyz, d, 1)


def scattered_points(
    xyz: NDArray[np.float64],
    pts: NDArray[np.int64],
    params: ComplexParams,
    multi_echo: NDArray[np.bool_] | None,
    porous: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """Flag scattered (foliage-like) points among a layer's candidates.

    The surface variation is computed on voxel centroids (voxel a third of the
    clustering distance) and given back to the voxel's points: the same scale
    whatever the density, and a 10-100x smaller neighbour search on dense
    photogrammetric clouds.  ``porous`` (over ``pts``, see
    :func:`porous_points`) are scattered too.
    """
    if params.scatter_max is None:
        return np.zeros(len(pts), dtype=bool)
    flag = np.zeros(len(pts), dtype=bool) if porous is None else porous.copy()
    if len(pts) < 12:
        return flag
    from pyheracles.geometry.neighbours import estimate_normals

    p = xyz[pts]
    voxel = float(params.cluster_distance_m) / 3.0  # type: ignore[arg-type]
    ijk = np.floor((p - p.min(axis=0)) / voxel).astype(np.int64)
    dims = ijk.max(axis=0) + 1
    keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    centroids = np.column_stack([np.bincount(inverse, weights=p[:, j]) / counts for j in range(3)])
    if len(centroids) < 12:
        return flag
    _, curvature_v = estimate_normals(centroids, k=12)
    curvature = curvature_v[inverse]
    flag |= curvature > params.scatter_max
    if multi_echo is not None and params.multi_echo_scatter_max is not None:
        flag |= multi_echo[pts] & (curvature > params.multi_echo_scatter_max)
    return flag


#: Neighbours (the point itself excluded) of the porosity vote: 16 keep most of the eave
#: line of a roof (pass-through returns on an edge) out of it on AHN3 tile 1, 7 did not.
POROUS_NEIGHBOURS = 16
#: Farthest neighbour of the porosity vote, metres: about a crown's radius.  On a sparse
#: survey (0.1-0.4 points/m^2) the 16 nearest points reach 3.5-5.5 m, over a whole building,
#: and a crown's few returns were outvoted by the roof's under it (complex family draws
#: 2 and 4).  On AHN3 tile 1 (about 12 points/m^2) the 16 lie within it.
POROUS_RADIUS_M = 3.0


def porous_points(
    xyz: NDArray[np.float64], through: NDArray[np.bool_], share: float | None
) -> NDArray[np.bool_]:
    """Points of porous surfaces (foliage): amid points the pulses went on beyond.

    A pulse that goes on beyond a point (``through``: not its last return) saw
    a porous surface there, or an edge.  A point counts as porous when at
    least ``share`` of the point and its :data:`POROUS_NEIGHBOURS` nearest
    points (3D, among ``xyz``) within :data:`POROUS_RADIUS_M` are pass-through:
    a crown's last returns (the pulses that ended in it) lie amid its
    pass-through returns, while the pass-through returns of a roof's eave line
    lie amid the roof's last returns, and a roof under a crown amid its own.
    Only the neighbours within the radius vote: on a sparse survey the nearest
    16 span a building and the crown over it, and the point with none near
    it is judged by its own echo.  ``share=None`` flags the pass-through
    points themselves.
    """
    if share is None or not through.any():
        return through.copy()
    from scipy.spatial import cKDTree

    k = min(POROUS_NEIGHBOURS + 1, len(xyz))
    _, idx = cKDTree(xyz).query(xyz, k=k, distance_upper_bound=POROUS_RADIUS_M)
    idx = np.asarray(idx).reshape(len(xyz), k)
    voters = (idx < len(xyz)).sum(axis=1)  # the point itself always
    hits = np.append(through, False)[idx].sum(axis=1)  # idx == len(xyz): none that near
    return hits >= share * voters


def object_points(
    xyz: NDArray[np.float64],
    cand: NDArray[np.int64],
    cand_dist: NDArray[np.float64],
    scattered: NDArray[np.bool_],
    params: ComplexParams,
    porous: NDArray[np.bool_] | None = None,
    solid: NDArray[np.bool_] | None = None,
    terrain: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
) -> NDArray[np.bool_]:
    """Mask over ``cand`` of the points that make the polygon's object.

    Clusters are grown from the smooth points (those amid scattered points
    over the surface beside them excepted, see :func:`vote_scattered`);
    scattered points then join through chains of scattered points near the
    footprint (see below).  Points outside the polygon more than
    ``params.outside_above_top_m`` above the top of the object's points inside
    it (99th percentile) are dropped.  ``params`` resolved (see
    :func:`pyheracles.complex.resolve_params`).
    ``porous`` (over ``cand``, a subset of ``scattered``) marks the points of
    porous surfaces (see :func:`porous_points`): they join only up to
    ``params.scatter_rise_m`` above the object's surface beside them.
    ``solid`` (over ``cand``) marks the points where a pulse ended (its last or only
    return), when the cloud has echoes: where the surface variation flags every
    candidate, the solid points that are not porous make the core instead.  Where
    fewer than :data:`EDGE_SHARE` of the object's points are smooth (a thin tower is
    all edges), the scattered points joined raise its top once for the solid ones.
    ``terrain`` gives the terrain height under XY positions (see
    :func:`level_heights`): the ring's height limit is then measured over it where the
    object is the more level so.
    """
    keep = np.zeros(len(cand), dtype=bool)
    cand_in = cand_dist == 0.0
    if params.scatter_vote_neighbours is not None:
        flipped = vote_scattered(xyz[cand], scattered, cand_in, params)
        scattered = scattered | flipped
    core = ~scattered
    if not core.any() and solid is not None and porous is not None:
        # On a sparse survey (0.1-0.3 points/m^2) the 12 neighbours of the surface
        # variation span a whole small building, platform and roof together, and every
        # point looks scattered: the building got no object (complex draw 9: a pavilion
        # of 13 points, all single returns).  There the echoes decide: a point where
        # its pulse ended, amid others that ended (not porous), is a solid surface; a
        # crown's last returns lie amid its pass-through returns and stay out.
        core = solid & ~porous
        scattered = ~core
    if core.sum() == 0:
        return keep
    labels = cluster(xyz[cand[core]], params)
    near_poly = cand_dist <= 0.5 * float(params.buffer_m)  # type: ignore[arg-type]
    keep[core] = select_clusters(labels, cand_in[core], near_poly[core], params)
    if params.outside_above_top_m is not None:
        # a crown over the roof's edge, apart from it, runs on off the polygon
        reach = 2.0 * float(params.attach_distance_m)  # type: ignore[arg-type]
        floating = floating_clusters(
            xyz[cand[core]], labels, cand_in[core], near_poly[core],
            params.outside_above_top_m, reach,
        )  # fmt: skip
        keep[np.flatnonzero(core)[floating]] = False
    if params.outside_above_top_m is not None and (keep & cand_in).sum() >= 3:
        # outside the polygon, nothing of the feature rises above its top inside it
        # (eaves and facades stand lower): there, it is the crown of a tree beside it.
        # The polygon's top, not the one beside the point: the inside points of a wall
        # digitised off its axis are its lower face (complex draws 24, 26).  Heights over
        # the terrain where the object is the more level so: the upper end of a wall
        # climbing a slope stood over the top of its points inside the polygon, lower
        # down the slope (complex draw 5, W05)
        kept = np.flatnonzero(keep)
        inner = cand_in[kept]
        if not inner.all():
            z = level_heights(xyz[cand[kept]], terrain, inner)
            top_in = float(np.percentile(z[inner], 99))
            keep[kept[~inner & (z > top_in + params.outside_above_top_m)]] = False
    loose = np.flatnonzero(scattered)
    if not keep.any() or len(loose) == 0:
        return keep
    # Scattered points join the object when they lie within ``scatter_offset_m``
    # of the footprint and below the object's top and are linked to it through
    # such points (a rough roof, the arrises of a thin wall).  A crown over a
    # roof rises above it, and one rooted outside lies off the footprint:
    # neither is taken, even where it touches the object.  Links are twice the
    # clustering distance: such points are sparse.
    reach = 2.0 * float(params.attach_distance_m)  # type: ignore[arg-type]
    rise = 0.5 * reach
    if params.scatter_above_top_m is not None:
        rise = min(rise, params.scatter_above_top_m)  # edges rise no higher on sparse surveys
    top = float(np.percentile(xyz[cand[keep], 2], 99)) + rise
    near_edge = cand_dist[loose] <= float(params.scatter_offset_m)  # type: ignore[arg-type]
    eligible = loose[near_edge & (xyz[cand[loose], 2] <= top)]
    if params.scatter_rise_m is not None and porous is not None and porous[eligible].any():
        # foliage over a roof rises above the roof beside it; an eave does not.
        # Rough solid parts (a dormer's, a chimney's edges) may: only porous points
        # are held to the surface beside them.
        surface = local_top(xyz[cand[keep]], xyz[cand[eligible], :2], reach)
        high = xyz[cand[eligible], 2] > surface + params.scatter_rise_m
        eligible = eligible[~(high & porous[eligible])]
    n_core = int(keep.sum())
    _join_scattered(xyz, cand, keep, eligible, cand_in, solid, porous, reach, params)
    if solid is not None and n_core < EDGE_SHARE * keep.sum():
        # A thin, tall part is all edges: the few smooth points are its lowest part, and
        # its top stood above theirs (complex draw 23: a gate tower's 9 top points left
        # out).  Where most of the object is scattered points, those just joined raise
        # the top once, for solid returns only (a crown's pulses go on through it); a
        # roof with a crown over it is mostly smooth, and its top stays.
        raised = float(np.percentile(xyz[cand[keep], 2], 99)) + rise
        later = loose[near_edge & ~keep[loose] & solid[loose]]
        if porous is not None:
            later = later[~porous[later]]
        later = later[(xyz[cand[later], 2] > top) & (xyz[cand[later], 2] <= raised)]
        _join_scattered(xyz, cand, keep, later, cand_in, solid, porous, reach, params)
    if params.eave_tolerance_m is not None:
        # beyond scatter_offset_m, scattered points join only where they run on the
        # object's own roof surface outward (its eaves), linked to it as above
        out = loose[~keep[loose] & ~cand_in[loose] & (xyz[cand[loose], 2] <= top)]
        eave = eave_points(
            xyz[cand[out]], xyz[cand[keep]], xyz[cand[~keep]], reach,
            params.eave_tolerance_m,
        )
        _join_scattered(xyz, cand, keep, out[eave], cand_in, solid, porous, reach, params)
    return keep


def level_heights(
    xyz: NDArray[np.float64],
    terrain: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None,
    part: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """Heights of ``xyz``: their Z or their heights over the terrain, whichever the object's
    ``part`` (a mask over ``xyz``) is the more level in.

    A wall climbing a slope is level over the terrain (its top follows the ground), a roof
    over sloping ground in Z.  Level: the smaller spread between the 10th and 90th
    percentiles.  ``terrain`` gives the terrain height under XY positions (NaN where
    unknown); ``None`` or NaN anywhere: Z.
    """
    z = xyz[:, 2]
    if terrain is None or not part.any():
        return z
    h = z - terrain(xyz[:, :2])
    if not np.isfinite(h).all():
        return z
    spread = lambda v: float(np.subtract(*np.percentile(v, [90, 10])))  # noqa: E731
    return h if spread(h[part]) < spread(z[part]) else z


def _join_scattered(
    xyz: NDArray[np.float64],
    cand: NDArray[np.int64],
    keep: NDArray[np.bool_],
    eligible: NDArray[np.int64],
    cand_in: NDArray[np.bool_],
    solid: NDArray[np.bool_] | None,
    porous: NDArray[np.bool_] | None,
    reach: float,
    params: ComplexParams,
) -> None:
    """Set ``keep`` (in place) on the ``eligible`` scattered candidates linked to the object.

    Groups of them (clusters at twice the clustering distance) join when one of their
    points lies within ``reach`` of a kept point; the others when they make a solid part
    of the feature (:func:`solid_structures`).
    """
    if len(eligible) == 0:
        return
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(xyz[cand[keep]]).query(xyz[cand[eligible]], k=1, distance_upper_bound=reach)
    link = replace(params, cluster_distance_m=2.0 * float(params.cluster_distance_m))  # type: ignore[arg-type]
    sub = cluster(xyz[cand[eligible]], link)
    touching = np.bincount(sub, weights=np.isfinite(dist).astype(np.float64)) > 0
    keep[eligible[touching[sub]]] = True
    if solid is not None:
        rest = eligible[~touching[sub]]
        keep[rest[solid_structures(sub[~touching[sub]], cand_in[rest], solid[rest],
                                   None if porous is None else porous[rest],
                                   int(params.min_cluster_points))]] = True  # type: ignore[arg-type]


#: Largest share of an object's points that may be smooth for the top to be raised by the
#: scattered points joined to it (see :func:`object_points`).
EDGE_SHARE = 0.5


#: Least share of a separate group of scattered points that must be solid returns (the
#: pulse ended there, amid others that ended) for the group to be a part of the feature.
SOLID_SHARE = 0.8


def solid_structures(
    groups: NDArray[np.int32],
    inside: NDArray[np.bool_],
    solid: NDArray[np.bool_],
    porous: NDArray[np.bool_] | None,
    min_points: int,
) -> NDArray[np.bool_]:
    """Mask of the scattered points, not linked to the object, that make a part of it.

    A thin, tall part of a feature (one of a gate's two towers, a pillar) is all edges
    to the surface variation: its points are scattered and, out of reach of the rest of
    the object, joined nothing (complex family draw 16: a gate tower of 30 points, 18 in
    the remainder).  A group of them (``groups``: their clusters at the linking
    distance) is a part of the feature when it has at least ``min_points`` points, lies
    mostly (>= 50 %) inside the polygon and its points are solid returns
    (:data:`SOLID_SHARE`: where a pulse ended and not amid pass-through returns): a
    crown there is porous, its pulses go on through it.
    """
    if len(groups) == 0:
        return np.zeros(0, dtype=bool)
    ok = solid if porous is None else solid & ~porous
    n = np.bincount(groups)
    n_in = np.bincount(groups, weights=inside.astype(np.float64), minlength=len(n))
    n_ok = np.bincount(groups, weights=ok.astype(np.float64), minlength=len(n))
    part = (n >= min_points) & (n_in >= 0.5 * n) & (n_ok >= SOLID_SHARE * n)
    return part[groups]


def vote_scattered(
    xyz: NDArray[np.float64],
    scattered: NDArray[np.bool_],
    inside: NDArray[np.bool_],
    params: ComplexParams,
) -> NDArray[np.bool_]:
    """Smooth points amid scattered ones (a crown's chance-flat patches), over one polygon.

    A point whose ``params.scatter_vote_neighbours`` nearest candidates (3D,
    the point itself excluded) are at least ``params.scatter_vote_share``
    scattered, and which stands more than ``params.scatter_rise_m`` above the
    other smooth points beside it (:func:`local_top`, within twice the attach
    distance), lies in foliage however flat its own neighbourhood looks: left
    smooth, such points chain a crown to the roof under it (complex family draw
    18: a crown 2-9 m over a 3 m roof joined it through a few of them, and its
    scattered points then lay below the object's top).  A facade under its
    eave or the edge of a dormer does not stand above the smooth points beside
    it and stays smooth (AHN3 tile 1 lost 3-8 % of some roofs without this
    test).  Flipped points are scattered, not porous: they may still join
    the object below its top.  The vote is dropped for
    the polygon when it would turn more than ``1 - params.scatter_vote_keep`` of
    the smooth points inside the polygon (a sparse survey's roof, whose surface
    variation means little, a gate's thin towers).  Only the neighbours within the
    clustering distance vote, and a point with none that near keeps its own answer: on
    a sparse survey the nearest candidates of a lone point of a wall lay 30-50 m off, in
    a crown (complex draw 5, W03).

    Returns
    -------
    numpy.ndarray
        Mask over ``xyz`` of the smooth points the vote makes scattered.
    """
    k = params.scatter_vote_neighbours
    flipped = np.zeros(len(xyz), dtype=bool)
    if k is None or len(xyz) <= k or not scattered.any() or scattered.all():
        return flipped
    from scipy.spatial import cKDTree

    # only the neighbours within the clustering distance vote: on a sparse survey the
    # nearest candidates of a lone point lie tens of metres off (a crown elsewhere)
    radius = float(params.cluster_distance_m)  # type: ignore[arg-type]
    _, idx = cKDTree(xyz).query(xyz, k=k + 1, distance_upper_bound=radius)
    idx = idx[:, 1:]
    voters = (idx < len(xyz)).sum(axis=1)
    hits = np.append(scattered, False)[idx].sum(axis=1)  # idx == len(xyz): none that near
    vote = (voters > 0) & (hits >= params.scatter_vote_share * voters)
    flipped = vote & ~scattered
    rest = ~scattered & ~flipped
    if flipped.any() and rest.any():
        # only points standing above the smooth surface beside them: a crown over a
        # roof, not a facade under its eave or the edge of a dormer
        reach = 2.0 * float(params.attach_distance_m)  # type: ignore[arg-type]
        rise = params.scatter_rise_m if params.scatter_rise_m is not None else 0.0
        at = np.flatnonzero(flipped)
        surface = local_top(xyz[rest], xyz[at, :2], reach)
        flipped[at[xyz[at, 2] <= surface + rise]] = False
    smooth_in = int((~scattered & inside).sum())
    if smooth_in - int((flipped & inside).sum()) < params.scatter_vote_keep * smooth_in:
        flipped[:] = False
    return flipped


#: Kept points (nearest in XY) whose highest bounds a scattered point.
TOP_NEIGHBOURS = 4


def local_top(
    xyz: NDArray[np.float64], at: NDArray[np.float64], radius_m: float
) -> NDArray[np.float64]:
    """Height of the surface of ``xyz`` at each XY of ``at``.

    The highest of the :data:`TOP_NEIGHBOURS` points of ``xyz`` nearest in
    XY (a wall's face points stand under its top: the highest of a few), of
    those within ``radius_m``; ``-inf`` where none is.
    """
    from scipy.spatial import cKDTree

    k = min(TOP_NEIGHBOURS, len(xyz))
    _, idx = cKDTree(xyz[:, :2]).query(at, k=k, distance_upper_bound=radius_m)
    idx = np.asarray(idx).reshape(len(at), k)
    z = np.append(xyz[:, 2], -np.inf)[idx]  # idx == len(xyz) where none is within the radius
    return z.max(axis=1)


def select_clusters(
    labels: NDArray[np.int32],
    inside: NDArray[np.bool_],
    near: NDArray[np.bool_],
    params: ComplexParams,
) -> NDArray[np.bool_]:
    """Mask of the points in the clusters that belong to the polygon's feature.

    Kept: the cluster with most points inside the polygon; every cluster that
    lies mostly (>= 50 %) within half a buffer of it (``near``), however
    small (a chimney, sparse facade points, the far side of a thin wall
    digitised off its axis); every cluster with at least
    ``min_cluster_points`` inside and an inside fraction >= ``keep_fraction``.
    """
    if len(labels) == 0:
        return np.zeros(0, dtype=bool)
    n = np.bincount(labels)
    n_in = np.bincount(labels, weights=inside.astype(np.float64), minlength=len(n))
    n_near = np.bincount(labels, weights=near.astype(np.float64), minlength=len(n))
    frac = np.divide(n_in, n, out=np.zeros(len(n)), where=n > 0)
    keep = (n_near >= 0.5 * n) & (n > 0)
    keep |= (n_in >= params.min_cluster_points) & (frac >= params.keep_fraction)
    best = int(np.argmax(n_in))
    keep[best] = True
    return keep[labels]


def floating_clusters(
    xyz: NDArray[np.float64],
    labels: NDArray[np.int32],
    inside: NDArray[np.bool_],
    near: NDArray[np.bool_],
    rise_m: float,
    reach_m: float,
) -> NDArray[np.bool_]:
    """Mask of the points of the clusters floating over the object's main cluster.

    :func:`select_clusters` keeps every cluster lying mostly near the polygon,
    however small.  A tree crown over the edge of a roof, apart from the roof
    (on a dense survey the clustering distance is under the gap between them),
    is such a cluster (complex draw 18: a crown 2-3.5 m over a gate's roof).  A
    cluster other than the main one (most points inside the polygon) is a crown's
    when it runs on off the polygon (a point beyond ``near``), its lowest point
    stands more than ``rise_m`` above the main cluster's top (99th percentile), and
    every point of it stands more than ``rise_m`` above the main cluster's surface
    beside it (:func:`local_top` within ``reach_m``).  A chimney or a dormer apart
    from the roof stands inside the polygon; the upper part of a wall climbing a
    slope, apart from its lower part, has none of it beside it; a storey standing
    out over the outline (AHN3 tile 1) reaches down to the main cluster's top.
    """
    n = np.bincount(labels)
    n_in = np.bincount(labels, weights=inside.astype(np.float64), minlength=len(n))
    best = int(np.argmax(n_in))
    main = labels == best
    far = np.bincount(labels, weights=(~near).astype(np.float64), minlength=len(n)) > 0
    far[best] = False
    at = np.flatnonzero(far[labels])
    if len(at) == 0 or not main.any():
        return np.zeros(len(labels), dtype=bool)
    top = float(np.percentile(xyz[main, 2], 99))
    low = np.full(len(n), np.inf)
    np.minimum.at(low, labels, xyz[:, 2])
    surface = local_top(xyz[main], xyz[at, :2], reach_m)
    over = np.zeros(len(labels), dtype=bool)
    over[at] = np.isfinite(surface) & (xyz[at, 2] > surface + rise_m)
    n_over = np.bincount(labels, weights=over.astype(np.float64), minlength=len(n))
    out = far & (n_over == n) & (low > top + rise_m)
    return out[labels]


def hull(xy: NDArray[np.float64]) -> Any:
    """2D convex hull polygon (qhull picks the vertices, shapely builds the polygon)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return shapely.Polygon(xy[ConvexHull(xy).vertices])
    except (QhullError, ValueError):  # collinear or too few points
        return shapely.convex_hull(shapely.multipoints(xy))
