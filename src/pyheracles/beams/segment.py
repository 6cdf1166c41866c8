"""Driver of the step, :func:`segment_beams`, and the assignment of points to cuboids."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pyheracles.beams.bands import split_facet
from pyheracles.beams.cuboids import (
    collinear,
    fit_beam_cuboid,
    fit_one_face_cuboid,
    join_pieces,
    merge_and_absorb,
    thinner_than,
)
from pyheracles.beams.deflection import BoxIndex
from pyheracles.beams.facets import (
    face_noise_thresholds,
    planar_parts,
    plane_layers,
    wide_surface_points,
)
from pyheracles.beams.frame import FrameParams, frame_members
from pyheracles.beams.grouping import face_runs, group_facets
from pyheracles.beams.hull_strips import HullStripParams, on_hull_strip
from pyheracles.beams.joints import find_joints
from pyheracles.beams.model import BeamCuboid, BeamParams, BeamResult, StraightFacet
from pyheracles.beams.one_face import spans_between
from pyheracles.beams.piece_joins import piece_faces
from pyheracles.beams.sparse_faces import SparseFaceParams, with_sparse_regions
from pyheracles.beams.surfaces import (
    cuboid_contacts,
    resting_loose,
    seen_from_behind,
    wide_surface_bands,
)
from pyheracles.beams.thinning import thin_to_spacing
from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.geometry.neighbours import as_xyz, build_tree, point_spacing
from pyheracles.segment.regiongrow import Regions, region_growing

__all__ = [
    "add_one_face_beams",
    "assign_to_cuboids",
    "candidates",
    "covered",
    "extend_along_axis",
    "extend_once",
    "keep_beams",
    "scatter",
    "segment_beams",
]


#: Share of the section across a hidden face whose strip along that face's edges
#: does not lengthen a beam (the floor beside a timber lying on it).
HIDDEN_EDGE_SHARE = 0.25
#: Past a beam's end a slice holding one point only does not continue the beam's
#: faces (scattered mixed pixels along the faces' planes bridged the gaps one by one,
#: down through a floor), unless a tenth of the faces' density over the last stretch
#: inside the end (``max_gap / 2``) is at most one point a slice (a sparse far end).
CONTINUATION_DENSITY_SHARE = 0.1


def assign_to_cuboids(
    xyz: NDArray[np.float64],
    beams: list[BeamCuboid],
    tol: float,
    index: BoxIndex | None = None,
) -> NDArray[np.int32]:
    """Each point to the cuboid whose surface is nearest, if within ``tol``.

    ``index``: a :class:`~pyheracles.beams.deflection.BoxIndex` of ``xyz`` to reuse.
    """
    best = np.full(len(xyz), np.inf)
    labels = np.zeros(len(xyz), dtype=np.int32)
    for i, b in enumerate(beams):
        cand = candidates(xyz, b, tol, index)
        if len(cand) == 0:
            continue
        d = np.abs(b.signed_distance(xyz[cand]))
        better = (d <= tol) & (d < best[cand])
        best[cand[better]] = d[better]
        labels[cand[better]] = i + 1
    return labels


def candidates(
    xyz: NDArray[np.float64], cub: BeamCuboid, margin: float, index: BoxIndex | None = None
) -> NDArray[np.int64]:
    """Sorted indices of the points in the cuboid's axis-aligned bounding box + margin.

    A box test is cheaper than a KD-tree ball query for long beams (the ball
    around a 6 m beam holds most of a roof).  With ``index`` (a
    :class:`~pyheracles.beams.deflection.BoxIndex` of ``xyz``) only the points in
    the box's narrowest coordinate range are tested (the same indices; on a roof
    of 1.5 M points and a hundred members the whole-cloud test took a quarter of
    the step); without it every point is.
    """
    corners = cub.corners()
    lo, hi = corners.min(axis=0) - margin, corners.max(axis=0) + margin
    if index is not None:
        return index.query(lo, hi)
    inside = np.all((xyz >= lo) & (xyz <= hi), axis=1)
    return np.flatnonzero(inside)


def extend_along_axis(
    xyz: NDArray[np.float64],
    free: NDArray[np.bool_],
    cub: BeamCuboid,
    tol: float,
    max_gap: float,
    spacing: float,
    max_rounds: int = 8,
    index: BoxIndex | None = None,
) -> BeamCuboid:
    """Lengthen a cuboid over the points that continue its faces past its ends.

    Short beam ends (overhangs, the part beyond a crossing beam) and the far,
    sparse ends of long members often give no straight facet of their own;
    their points lie on the beam's extended faces.  The cuboid grows, slice by
    slice (5 cm, or 5 point spacings), over the points (not claimed by another
    beam's facets, and in no wide surface) within ``tol`` of its surface
    extended, while they are contiguous (empty over at most ``max_gap / 2``,
    the size of a crossing beam, or 10 point spacings); a slice holding a
    single point is empty unless the faces are that sparse at the end
    (``CONTINUATION_DENSITY_SHARE``): a few mixed pixels along the faces'
    planes are no faces going on, nor is a floor crossing them.  Only the
    faces the member is seen on count (at least a tenth of its own points lie
    on them), and points along the edges of a hidden face are ignored: the
    floor beside a timber lying on it is in the plane of the timber's hidden
    underside.  The cross-section is kept.  The
    test is on the positions only: normals of the few points of a sparse far
    end are too noisy to say which face they lie on.  One round looks
    ``max_gap`` past each end; rounds are repeated (at most ``max_rounds``)
    while an end moves by more than a slice.  ``index``: a
    :class:`~pyheracles.beams.deflection.BoxIndex` of ``xyz`` to reuse.
    """
    for _ in range(max_rounds):
        longer = extend_once(xyz, free, cub, tol, max_gap, spacing, index)
        if longer.length - cub.length <= max(0.05, 5 * spacing):
            return longer
        cub = longer
    return cub


def extend_once(
    xyz: NDArray[np.float64],
    free: NDArray[np.bool_],
    cub: BeamCuboid,
    tol: float,
    max_gap: float,
    spacing: float,
    index: BoxIndex | None = None,
) -> BeamCuboid:
    """One round of :func:`extend_along_axis`: up to ``max_gap`` past each end."""
    longer = replace(cub, length=cub.length + 2 * max_gap)
    cand = candidates(xyz, longer, tol, index)
    cand = cand[free[cand]]
    if len(cand) == 0:
        return cub
    pts = xyz[cand]
    local = (pts - cub.centre) @ cub.axes
    t = local[:, 0]
    on = np.abs(longer.signed_distance(pts)) <= tol
    # the lateral face of every point: 0 / 1 the low / high side across, 2 / 3 up
    half_uv = 0.5 * np.array([cub.width, cub.height])
    gap = np.abs(np.abs(local[:, 1:]) - half_uv)
    nearest = np.argmin(gap, axis=1)
    rows = np.arange(len(local))
    face = 2 * nearest + (local[rows, 1 + nearest] > 0)
    # on the face itself, not in the strip along its edges (the floor beside a
    # timber lying on it is in the plane of the timber's hidden underside)
    interior = np.abs(local[rows, 2 - nearest]) <= half_uv[1 - nearest] - tol
    half = 0.5 * cub.length
    inside = on & interior & (np.abs(t) <= half)
    shares = np.bincount(face[inside], minlength=4) / max(int(inside.sum()), 1)
    on &= shares[face] >= 0.1
    for f in np.flatnonzero(shares < 0.1):  # nor along the edges of a hidden face
        # a strip a quarter of the section wide: the hidden face's level is
        # estimated (the floor under a lying timber may sit a centimetre inside it)
        sign, k = (1.0 if f % 2 else -1.0), 1 + f // 2
        size = [cub.width, cub.height][k - 1]
        strip = max(tol, HIDDEN_EDGE_SHARE * size)
        on &= np.abs(local[:, k] - sign * 0.5 * size) > strip
    step = max(0.5 * max_gap, 10 * spacing)
    sl = max(0.05, 5 * spacing)
    ends = []
    for sign in (1.0, -1.0):
        a = sign * t
        beyond = a[on & (a > half - tol)]
        end = half
        if len(beyond) >= 20:
            n_sl = int(np.ceil((half + max_gap - (half - tol)) / sl)) + 1
            k_on = np.bincount(((beyond - (half - tol)) / sl).astype(np.int64), minlength=n_sl)
            # a slice holding a single point (a mixed pixel) does not go on with the
            # faces, unless a tenth of their density over the last stretch inside the
            # end is one point a slice or less (a sparse far end)
            near = int(np.count_nonzero(on & (a > half - step) & (a <= half - tol)))
            share = CONTINUATION_DENSITY_SHARE * near * sl / max(step - tol, sl)
            least = min(2.0, max(1.0, share))
            last, empty = -1, 0.0
            for i in range(n_sl):
                if k_on[i] < least:
                    empty += sl
                    if empty > step:
                        break
                    continue
                empty = 0.0
                last = i
            run = beyond[beyond < (half - tol) + (last + 1) * sl] if last >= 0 else beyond[:0]
            if len(run) >= 20:
                end = max(half, float(np.quantile(run, 0.995)))
        ends.append(end)
    hi, lo = ends[0], -ends[1]
    return replace(cub, centre=cub.centre + cub.axis * 0.5 * (hi + lo), length=float(hi - lo))


def covered(cub: BeamCuboid, beams: list[BeamCuboid], tol: float) -> bool:
    """Whether most of ``cub``'s centre line lies within ``tol`` of (or inside) one of ``beams``."""
    u = np.linspace(-0.45, 0.45, 19)[:, None]
    line = cub.centre + u * cub.length * cub.axis
    for b in beams:
        if np.mean(b.signed_distance(line) <= tol) >= 0.5:
            return True
    return False


def add_one_face_beams(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    facets: list[StraightFacet],
    facet_beam: NDArray[np.int32],
    cuboids: list[BeamCuboid],
    p: BeamParams,
    bin_m: float,
    tol: float,
    free: NDArray[np.float64] | None = None,
    fill: NDArray[np.bool_] | None = None,
    reach_m: float | None = None,
) -> tuple[list[BeamCuboid], NDArray[np.int32]]:
    """Beams seen on one face: runs of the straight facets no beam took.

    The pieces of one face (:func:`~pyheracles.beams.grouping.face_runs`; with
    ``fill``, the mask of the points in no facet and no wide surface, pieces up
    to ``max_shadow_m`` apart whose gap the face's points fill are one run) make
    a beam when they form a convex band (:func:`fit_one_face_cuboid`) whose
    centre line is not already in a found beam; largest runs first.  A run
    lying on the face of a beam found on several faces, extended by twice
    ``max_gap_m`` at each end, is a piece of it past the end its facets
    reached: it joins that beam (``free``: the points in no facet, for its
    refit by :func:`fit_beam_cuboid`).  A run
    collinear with a one-face beam already made, or lying on its face
    extended by twice ``max_gap_m`` at each end (a piece cut off by a shadow
    or a crossing member), joins it and the cuboid is fitted again (on
    several faces, :func:`fit_beam_cuboid`, when the pieces lie on faces that
    are not parallel).  With ``reach_m``, a run too short for a one-face beam
    but as elongated as a straight facet is one when both its ends lie within
    ``reach_m`` of beams crossing it (:func:`~pyheracles.beams.one_face.spans_between`).
    """
    out = list(cuboids)
    fb = facet_beam.copy()
    left = np.flatnonzero(fb == 0)
    probe = xyz[:: max(1, len(xyz) // 50000)]
    groups = face_runs(
        xyz,
        facets,
        left,
        parallel_deg=p.parallel_deg,
        max_gap_m=p.max_gap_m,
        width_range=(p.min_beam_width_m, p.max_beam_width_m),
        fill=fill,
        tree=tree,
        max_filled_gap_m=p.max_shadow_m,
    )
    cos_par = np.cos(np.radians(p.parallel_deg))

    def fit(run: list[int], elongation: float) -> BeamCuboid | None:
        return fit_one_face_cuboid(
            xyz,
            tree,
            [facets[i] for i in run],
            probe,
            bin_m=bin_m,
            max_depth_m=p.max_beam_width_m,
            min_elongation=elongation,
        )

    # runs whose gaps the face's points fill are one face when it makes one band;
    # otherwise (e.g. a side face whose pieces fit no band together) they are
    # taken run by run, as pieces apart
    runs: list[list[int]] = []
    for g in groups:
        joined = [i for r in g for i in r]
        if len(g) > 1 and fit(joined, 2.0 * p.min_elongation) is not None:
            runs.append(joined)
        else:
            runs.extend(g)
    # largest first (ties: the lowest facet first, the order of the runs alone)
    runs.sort(key=lambda r: (-sum(len(facets[i].index) for i in r), min(r)))

    def fit_pieces(run: list[int]) -> BeamCuboid | None:
        # pieces of two non-parallel faces (the underside here, a side there,
        # along a member whose faces are shadowed in turn) define the section:
        # a beam seen on two faces, not one face averaged over both
        normals = np.array([facets[i].normal for i in run])
        if np.min(np.abs(normals @ normals[0])) < cos_par:
            try:
                return fit_beam_cuboid(xyz, [facets[i] for i in run], bin_m=bin_m, free=free)
            except DegenerateGeometryError:
                return None
        return fit(run, 0.0)

    added: dict[int, list[int]] = {}  # beam (0-based) -> its facets
    n_multi = len(out)

    def place(run: list[int], cub: BeamCuboid) -> None:
        # a piece of a face already taken, cut off by a shadow or a crossing member
        pts = xyz[np.concatenate([facets[i].index for i in run])]
        for k, prev in added.items():
            longer = replace(out[k], length=out[k].length + 4.0 * p.max_gap_m)
            on = float(np.median(np.abs(longer.signed_distance(pts)))) <= tol
            if on or collinear(out[k], cub, cos_par, 2.0 * p.max_gap_m):
                merged = fit_pieces(prev + run)
                if merged is not None:
                    out[k] = merged
                    added[k] = prev + run
                    fb[run] = k + 1
                    return
        out.append(cub)
        added[len(out) - 1] = list(run)
        fb[run] = len(out)

    framed: list[tuple[list[int], BeamCuboid]] = []  # short runs and their cuboids
    for run in runs:
        pts = xyz[np.concatenate([facets[i].index for i in run])]
        # a face of a beam found on several faces, past the end its facets reached
        host = None
        for k in range(n_multi):
            b = out[k]
            if abs(b.axis @ facets[run[0]].axis) < cos_par:
                continue
            longer = replace(b, length=b.length + 4.0 * p.max_gap_m)
            if float(np.median(np.abs(longer.signed_distance(pts)))) <= tol:
                host = k
                break
        if host is not None:
            members = [facets[i] for i in np.flatnonzero(fb == host + 1)] + [facets[i] for i in run]
            try:
                out[host] = fit_beam_cuboid(xyz, members, bin_m=bin_m, free=free)
            except DegenerateGeometryError:
                continue
            fb[run] = host + 1
            continue
        cub = fit(run, 2.0 * p.min_elongation)
        if cub is None and reach_m is not None:
            # too short for a one-face beam: judged once every longer run is placed
            short = fit(run, p.min_elongation)
            if short is not None:
                framed.append((run, short))
            continue
        if cub is not None and not covered(cub, out, tol):
            place(run, cub)
    # a short band framed between two crossing beams is as long as its joints let
    # it be: a straight facet's elongation is then enough (until none is added)
    while framed:
        rest = [(run, cub) for run, cub in framed if not spans_between(cub, out, reach_m, cos_par)]
        if len(rest) == len(framed):
            break
        for run, cub in framed:
            if any(run is r for r, _ in rest) or covered(cub, out, tol):
                continue
            place(run, cub)
        framed = rest
    return out, fb


def keep_beams(
    cuboids: list[BeamCuboid], facet_beam: NDArray[np.int32], keep: NDArray[np.bool_]
) -> tuple[list[BeamCuboid], NDArray[np.int32]]:
    """The cuboids where ``keep``, and each facet's beam renumbered (0: a dropped beam's)."""
    if keep.all():
        return cuboids, facet_beam
    renumber = np.concatenate([[0], np.cumsum(keep) * keep]).astype(np.int32)
    return [c for c, k in zip(cuboids, keep, strict=True) if k], renumber[facet_beam]


def scatter(values: NDArray, index: NDArray[np.int64], n: int) -> NDArray:
    """``values`` of a subset (``index``) spread over ``n`` points, zeros elsewhere."""
    out = np.zeros((n, *values.shape[1:]), dtype=values.dtype)
    out[index] = values
    return out


def segment_beams(
    xyz: ArrayLike | PointCloud,
    params: BeamParams | None = None,
    *,
    tree: cKDTree | None = None,
    rng: np.random.Generator | int | None = 0,
) -> BeamResult:
    """Segment the beams of a timber framework and fit a cuboid to each.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates in metres (local frame) or a :class:`PointCloud`.
    params
        :class:`BeamParams`.
    tree
        Shared KD-tree on ``xyz``.
    rng
        Seed for the subsampling of the direction search.

    Returns
    -------
    BeamResult
        Per-point beam labels aligned with the input (0 = remainder), one
        :class:`BeamCuboid` per beam, the intermediate facets, timings.

    Raises
    ------
    InputError
        Empty or non-finite input, only wide planar surfaces (a floor, walls),
        or no planar facet at all (the message says so: the cloud holds no
        beam faces at this density / noise).
    """
    source = None
    if isinstance(xyz, PointCloud):
        xyz.validate(what="framework cloud")
        source = xyz.source
        arr = xyz.xyz
    else:
        arr = as_xyz(xyz)
    p = (params or BeamParams()).validate()
    if len(arr) < 4 * p.min_facet_points:
        raise InputError(
            f"the cloud has {len(arr)} points; beam segmentation needs at least "
            f"{4 * p.min_facet_points}",
            path=source,
            hint="give a denser cloud (in Python: lower BeamParams.min_facet_points)",
        )
    gen = np.random.default_rng(rng)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    full = arr
    if tree is None:
        tree = build_tree(full)
    spacing = point_spacing(full, tree)
    keep = np.arange(len(full))
    if p.thin_spacing_m is not None and spacing < p.thin_spacing_m:
        # to the target spacing where the scan is denser; sparse parts kept whole
        keep = thin_to_spacing(full, tree, p.thin_spacing_m, gen)
    if len(keep) < len(full):
        arr = full[keep]
        tree = build_tree(arr)
        spacing = point_spacing(arr, tree)
    # wide surfaces first (coarse, voxel level), then the facets of the rest with
    # thresholds from the rest: floors and walls do not set the beams' noise level
    coarse = region_growing(arr, replace(p.region, level="voxel", voxel_m=None), tree=tree)
    wide_pts = wide_surface_points(arr, coarse.labels, tree, max_width_m=p.max_beam_width_m)
    cand = np.flatnonzero(~wide_pts)
    if len(cand) < 4 * p.min_facet_points:
        raise InputError(
            "no beam faces: the cloud holds only wide planar surfaces (floor, walls, boarding)"
            f" and {len(cand)} other points",
            path=source,
            hint="check that the cloud shows the frame's members",
        )
    sub_xyz = arr[cand]
    sub_tree = build_tree(sub_xyz)
    region_p = p.region
    if region_p.angle_deg is None or region_p.curvature_max is None:
        # from the candidate surfaces (not the floor and walls), capped below
        # the step of the normals round a beam's edge
        ang, curv = face_noise_thresholds(sub_xyz, sub_tree, region_p.k, gen)
        region_p = replace(
            region_p,
            angle_deg=region_p.angle_deg if region_p.angle_deg is not None else ang,
            curvature_max=(region_p.curvature_max if region_p.curvature_max is not None else curv),
        )
    sub = region_growing(sub_xyz, region_p, tree=sub_tree)
    sub_labels, sub_normals, sub_curv = sub.labels, sub.normals, sub.curvature
    if p.sparse_faces:
        # sparse parts no facet took (a far slope's narrow faces, where k neighbours
        # reach round the edges): grown again with fewer neighbours
        sub_labels, sub_normals, sub_curv = with_sparse_regions(
            arr, tree, spacing, cand, sub, gen, SparseFaceParams()
        )
    regions = Regions(
        labels=scatter(sub_labels, cand, len(arr)),
        normals=scatter(sub_normals, cand, len(arr)),
        curvature=scatter(sub_curv, cand, len(arr)),
        params=sub.params,
    )
    timings["facets"] = time.perf_counter() - t0
    if regions.n_regions == 0:
        raise InputError(
            "no planar facet found: the cloud has no smooth surfaces at this density",
            path=source,
            hint="check that the cloud shows the beams' faces, or raise --angle",
        )
    t1 = time.perf_counter()
    order = np.argsort(regions.labels, kind="stable")
    bounds = np.searchsorted(regions.labels[order], np.arange(regions.n_regions + 2))
    facets: list[StraightFacet] = []
    for r in range(1, regions.n_regions + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < p.min_facet_points:
            continue
        for part in planar_parts(regions.normals, idx, p.min_facet_points, gen):
            for layer in plane_layers(arr, part, p.min_facet_points):
                facets.extend(split_facet(arr, layer, p, spacing_m=spacing, parent=r, rng=gen))
    # strips of boarding, floor or wall: the surface goes on past the band's edges
    wide = wide_surface_bands(tree, arr, facets)
    barrier_idx = [f.index for f, w in zip(facets, wide, strict=True) if w]
    barrier = arr[np.concatenate(barrier_idx)] if barrier_idx else None
    facets = [f for f, w in zip(facets, wide, strict=True) if not w]
    timings["split"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    contact = p.contact_m
    if contact is None:
        sample = arr[:: max(1, len(arr) // 20000)]
        r_k = float(np.median(tree.query(sample, k=p.region.k, workers=-1)[0][:, -1]))
        contact = max(2.0 * r_k, 4.0 * spacing, 0.02)
    group = group_facets(
        arr,
        facets,
        parallel_deg=p.parallel_deg,
        contact_m=contact,
        min_contact_fraction=p.min_contact_fraction,
        width_range=(p.min_beam_width_m, p.max_beam_width_m),
        max_gap_m=p.max_gap_m,
        barrier=barrier,
    )
    timings["group"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    bin_m = max(spacing, 0.004)
    # free: points in no facet that may still belong to a beam (not wide surfaces)
    free_mask = ~wide_pts
    for idx in barrier_idx:
        free_mask[idx] = False
    for f in facets:
        free_mask[f.index] = False
    free = arr[free_mask]
    facet_beam = merge_and_absorb(arr, facets, group, p, bin_m, free)
    cuboids: list[BeamCuboid] = []
    final = np.zeros(len(facets), dtype=np.int32)
    for g in range(1, int(facet_beam.max(initial=0)) + 1):
        members = [facets[i] for i in np.flatnonzero(facet_beam == g)]
        try:
            cub = fit_beam_cuboid(arr, members, bin_m=bin_m, free=free)
        except DegenerateGeometryError:
            continue
        cuboids.append(cub)
        final[facet_beam == g] = len(cuboids)
    facet_beam = final
    rms = [f.plane_rms for f, g in zip(facets, facet_beam, strict=True) if g > 0]
    tol = p.surface_tolerance_m
    if tol is None:
        tol = max(3.0 * float(np.median(rms)) if rms else 0.0, 0.01)
    if p.one_face:
        cuboids, facet_beam = add_one_face_beams(
            arr,
            tree,
            facets,
            facet_beam,
            cuboids,
            p,
            bin_m,
            tol,
            free,
            fill=free_mask,
            reach_m=max(contact, 2.0 * tol),
        )
    claimed = np.zeros(len(arr), dtype=np.int32)  # beam of each facet point
    for f, g in zip(facets, facet_beam, strict=True):
        claimed[f.index] = g
    # the wide surfaces (floor, walls, boarding and their strips) are no beam's
    # faces: a beam's faces do not go on through the floor it stands on
    claimed[wide_pts] = -1
    for idx in barrier_idx:
        claimed[idx] = -1
    index = BoxIndex(arr)  # box queries of every cuboid, on the kept points
    cuboids = [
        extend_along_axis(
            arr,
            (claimed == 0) | (claimed == i + 1),
            c,
            tol,
            p.max_gap_m,
            spacing,
            # a band seen on one face may be a strip of a surface (the floor
            # between stored timbers): one round, as far as a crossing member
            max_rounds=8 if c.faces_seen >= 2 else 1,
            index=index,
        )
        for i, c in enumerate(cuboids)
    ]
    # pieces of one member whose lengthened ends now meet, or lie apart by a shadow
    # (two pieces seen on one face: when they show one face, on one line, of one width)
    cuboids, new_id = join_pieces(
        cuboids,
        np.cos(np.radians(p.parallel_deg)),
        p.max_gap_m,
        p.max_shadow_m,
        faces=piece_faces(arr, facets, facet_beam, cuboids) if p.join_faces else None,
        plane_tol=tol,
    )
    facet_beam = new_id[facet_beam]
    # boxes thinner than any member: facets of a beam grouped with a strip of something else
    thin = np.array([thinner_than(c, p.min_beam_width_m) for c in cuboids], dtype=bool)
    cuboids, facet_beam = keep_beams(cuboids, facet_beam, ~thin)
    # the inside corner of two surfaces (a gable wall under the boarding): the box
    # lies on the room's side of the faces it was fitted to, a member behind them
    probe = arr[:: max(1, len(arr) // 50000)]
    behind = np.array(
        [
            seen_from_behind(
                c,
                [f for f, g in zip(facets, facet_beam, strict=True) if g == i + 1],
                tree,
                probe,
                p.max_beam_width_m,
                p.parallel_deg,
            )
            for i, c in enumerate(cuboids)
        ],
        dtype=bool,
    )
    cuboids, facet_beam = keep_beams(cuboids, facet_beam, ~behind)
    # a member's face grouped with the strip of boarding beside it: the box is the
    # air in that inside corner, the face is the member's found apart
    corner = np.array(
        [
            on_hull_strip(
                arr,
                cuboids,
                i,
                [f for f, g in zip(facets, facet_beam, strict=True) if g == i + 1],
                tree,
                probe,
                tol,
                HullStripParams(depth_m=p.max_beam_width_m, parallel_deg=p.parallel_deg),
            )
            for i in range(len(cuboids))
        ],
        dtype=bool,
    )
    cuboids, facet_beam = keep_beams(cuboids, facet_beam, ~corner)
    # timber stored on the floor: it and what it touches lie on a surface going on around
    contacts = cuboid_contacts(cuboids, max(contact, 2.0 * tol))
    loose = resting_loose(tree, cuboids, contacts)
    cuboids, facet_beam = keep_beams(cuboids, facet_beam, ~loose)
    if p.frame_only and len(cuboids) >= 2:
        # loose timber, a ladder, what no frame holds: not members (to the remainder)
        fp = FrameParams()
        _, member = frame_members(cuboids, find_joints(cuboids, fp.joints), fp)
        if member.any():
            cuboids, facet_beam = keep_beams(cuboids, facet_beam, member)
    labels = assign_to_cuboids(full, cuboids, tol, index if full is arr else None)
    timings["cuboids"] = time.perf_counter() - t3
    straight = np.zeros(len(arr), dtype=np.int32)
    for i, f in enumerate(facets):
        straight[f.index] = i + 1
    facet_labels = regions.labels
    if len(keep) < len(full):  # intermediate labels: from the nearest kept point
        _, near = tree.query(full, k=1, workers=-1)
        facet_labels, straight = facet_labels[near], straight[near]
    resolved = replace(p, region=regions.params, contact_m=contact, surface_tolerance_m=tol)
    return BeamResult(
        labels=labels,
        beams=tuple(cuboids),
        facet_labels=facet_labels,
        straight_labels=straight,
        facet_beam=facet_beam,
        params=resolved,
        timings=timings,
    )
