"""Section islands: Euclidean clustering of a horizontal slab, noise / wall / column / pier."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.geometry.fitting import fit_circle, min_area_rectangle
from pyheracles.geometry.sections import circularity
from pyheracles.segment.euclidean import euclidean_clusters
from pyheracles.supports.core import Array, Island, SupportParams, check_pair_memory, trimmed_rms
from pyheracles.supports.piers import rect_rms
from pyheracles.supports.rings import ARC_GAP_M, rings_from_arcs


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
    circ, c_rms, r_rms, radius = nan, nan, nan, nan
    if kind == "support" and with_shapes:
        circ = circularity(p)
        circle = fit_circle(p)
        r_rms, rect = rect_rms(p, centre, angle, size.copy())
        if circle and circle.radius < length:
            c_rms = trimmed_rms(circle.residuals(p))
        if circle and c_rms < r_rms and (circ <= params.circularity_max or c_rms < 0.5 * r_rms):
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
        out = rings_from_arcs(xy, labels, out, params, distance_m)
        out = sparse_islands(xy, labels, out, params, distance_m)
    return out


#: The points left over are grouped again at this many times their own median distance
#: to the third nearest left-over point (at most ``ARC_GAP_M``).
SPARSE_GAP_FACTOR = 2.5
#: A sparse group is a pier when its points lie this close (plus 2 % of its length) to a
#: rectangle, trimmed RMS, metres (the ring test of ``rings_from_arcs`` allows 1 cm + 3 %).
SPARSE_RECT_RMS_M = 0.01


def sparse_islands(
    xy: Array,
    labels: NDArray[np.intp],
    islands: list[Island],
    params: SupportParams,
    distance_m: float,
) -> list[Island]:
    """Supports whose section points are further apart than the clustering distance.

    The clustering distance follows the densest surfaces; a support far from the
    scanners, or seen by one distant station, has its section points further apart, so
    they are left unclustered or in noise islands.  These left-over points are grouped
    again at their own spacing (``SPARSE_GAP_FACTOR`` times the median distance to the
    third nearest left-over point, between ``distance_m`` and ``ARC_GAP_M``), and each
    group of at least ``min_points`` is classified like any island; columns are kept, and
    piers whose points lie on a rectangle outline (``SPARSE_RECT_RMS_M``; twin columns
    grouped as one do not), the rest stays noise.
    """
    used = np.zeros(len(xy), dtype=bool)
    for i in islands:
        if i.kind != "noise":
            used[i.index] = True
    left = np.flatnonzero(~used)
    if len(left) < max(params.min_points, 4):
        return islands
    q = xy[left]
    tree = cKDTree(q)
    d, _ = tree.query(q, k=4)
    gap = float(np.clip(SPARSE_GAP_FACTOR * np.median(d[:, 3]), distance_m, ARC_GAP_M))
    if gap <= distance_m * 1.01:
        return islands
    check_pair_memory(q, tree, gap)
    lab = euclidean_clusters(q, gap, params.min_points, tree=tree)
    order = np.argsort(lab, kind="stable")
    bounds = np.r_[0, np.cumsum(np.bincount(lab))]
    found: list[Island] = []
    for g in range(1, len(bounds) - 1):  # loop over groups
        sub = left[order[bounds[g] : bounds[g + 1]]]
        isl = classify_island(xy[sub], sub, params)
        # a sparse pier is a rectangle outline: two twin columns grouped as one are not
        if isl.kind == "column" or (
            isl.kind == "pier" and isl.rect_rms <= SPARSE_RECT_RMS_M + 0.02 * float(isl.size[0])
        ):
            found.append(isl)
    if not found:
        return islands
    taken = np.zeros(len(xy), dtype=bool)
    for i in found:
        taken[i.index] = True
    kept = [i for i in islands if i.kind != "noise" or not taken[i.index].any()]
    return kept + found
