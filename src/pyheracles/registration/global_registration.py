"""Markerless global registration of two overlapping clouds in arbitrary poses.

No tie points, no initial transform: the clouds may be in any relative
rotation and translation.  The pipeline (Rusu et al. 2009; Zhou, Park & Koltun
2016; Yang, Shi & Carlone 2020):

1. **Scale.**  One voxel size for both clouds, from the occupied surface and the
   measured point spacing (:func:`~pyheracles.registration.features.choose_voxel`):
   about ``target_points`` voxels per cloud, never below twice the spacing.
2. **Descriptors.**  Voxel centroids, PCA normals of ``normal_neighbours``
   neighbours, sign-invariant FPFH at ``feature_radius_voxels`` voxels
   (:mod:`~pyheracles.registration.features`).
3. **Matching.**  Mutual nearest neighbours in descriptor space (Hellinger
   distance: square roots of the histograms), optionally with Lowe's ratio
   test; one-way matches are added when too few are mutual
   (:mod:`~pyheracles.registration.matching`).
4. **Robust estimation.**  Pairwise length-consistency graph and graph-guided
   RANSAC (:mod:`~pyheracles.registration.consensus`): survives 95-99 % wrong
   matches; several distinct hypotheses are kept.
5. **Verification.**  The hypothesis of the best coarse overlap and *every*
   hypothesis of a different pose whose consensus is beyond chance are refined by a
   short point-to-plane ICP on the *full* clouds and scored by the share of source
   points within a fine gate (3 x spacing) of the target; the best-scoring one is
   refined by the full robust (Tukey) ICP of :mod:`~pyheracles.registration.icp`,
   the best score among the rivals still distinct after refinement sets the margin.
   The target's self-similarities (its descriptors matched with those of its other
   parts: the turn of a symmetric building, the shift from bay to bay) composed with
   the first-ranked pose are rivals too: where the target repeats itself, the pose
   the data support nearly as well may have too few feature matches to be found
   as a hypothesis of its own.
6. **Decision.**  The result is accepted only when the overlap share, the
   consensus (against the clique size expected by chance), the geometric
   conditioning of the overlap (the six motions must all be constrained) and
   the margin over the best *different* pose are all sufficient.  Otherwise the
   status says why (``"no overlap"`` or ``"ambiguous"``) and the caller must
   not use the transform.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pyheracles import progress
from pyheracles.cloud import PointCloud
from pyheracles.errors import EstimationError, InputError
from pyheracles.geometry.neighbours import octree_pca, point_spacing
from pyheracles.registration.consensus import (
    ConsensusParams,
    RigidHypothesis,
    robust_rigid,
)
from pyheracles.registration.features import (
    choose_voxel,
    fpfh_descriptors,
    unoriented_normals,
    voxel_downsample,
)
from pyheracles.registration.icp import ICPParams, ICPResult, estimate_normals, icp
from pyheracles.registration.matching import match_descriptors, nearest_far_descriptors
from pyheracles.resources import one_blas_thread

__all__ = [
    "GlobalRegistrationParams",
    "GlobalRegistrationResult",
    "global_registration",
    "match_descriptors",
    "motion_conditioning",
]

#: Statuses of :class:`GlobalRegistrationResult`.
STATUSES = ("ok", "no overlap", "ambiguous")

#: Targets of at most this many points get all their normals at once for the
#: verification (beyond it the ICP samples touch a small share of the target).
_ALL_NORMALS_UP_TO = 200_000

#: Points of the target matched with its other parts in the search for its symmetries.
_SELF_MATCH_ROWS = 2_000


@dataclass(frozen=True)
class GlobalRegistrationParams:
    """Parameters of :func:`global_registration`.

    Attributes
    ----------
    voxel_m
        Voxel size, metres; ``None``: from the clouds (about ``target_points``
        voxels each, at least ``2 x`` the larger point spacing).
    target_points
        Downsampled points per cloud when ``voxel_m`` is ``None``.
    normal_neighbours
        Neighbours for the PCA normals of the downsampled points.
    feature_radius_voxels
        FPFH support radius, voxels.
    feature_max_neighbours
        At most this many neighbours per FPFH.
    ratio
        Lowe's ratio test on descriptor distances (``None``: off; e.g. 0.9).
    min_mutual
        When fewer mutual matches than this exist, one-way matches are added.
    max_correspondences
        Correspondences kept for the estimator (the most distinctive by ratio).
    inlier_voxels
        Correspondence inlier distance, voxels.
    hypotheses
        Distinct hypotheses verified on the clouds.
    gate_spacings
        Fine gate of the overlap share, multiples of the target point spacing.
    min_overlap
        Smallest overlap share (of the smaller cloud's points within the gate)
        accepted.
    min_inliers
        Smallest consensus set accepted.
    min_significance
        The consensus must be at least this multiple of the clique size expected
        by chance (:func:`~pyheracles.registration.consensus.null_clique_size`).
    min_conditioning
        Smallest ratio of the weakest to the strongest motion constraint of the
        overlap (:func:`motion_conditioning`): below it a plane, a cylinder or a
        sphere leaves the pose undetermined.
    min_margin
        The best pose's overlap must exceed that of the best *different* pose by
        this share of itself (``1 - second / best``), else ``"ambiguous"`` when that
        pose's own consensus is beyond chance (or the chosen one's does not stand
        out against it).
    finer_retries
        Multiples of ``target_points`` tried in turn until one is accepted (with
        ``voxel_m`` given: that voxel only).  Large scenes (a building rather than an
        object) need finer voxels than 5 000 per cloud to keep their details.
    rival_significance
        Every hypothesis of a different pose whose consensus is at least this multiple
        of the clique size expected by chance is refined and compared with the chosen
        one (symmetric or repeated structure gives several such poses; the chosen pose
        must beat every one of them by ``min_margin``).
    same_pose_voxels
        Two poses are one when they move the source's points by at most this many
        voxels (RMS): closer hypotheses are variants of one pose, not rivals.
    rival_share
        ``"ambiguous"`` when a different pose (sharing less than half of its matches
        with the chosen one) has at least this share of the chosen pose's consistent
        matches and is itself beyond chance: symmetric or repeated structure.
    rival_misfit
        A different pose is no rival (whatever its overlap) when the share of source
        points it leaves outside the fine gate is at least this multiple of the share
        the chosen pose leaves (``1 - overlap`` of the quick refinements): the chosen
        pose explains nearly all of the source and the other a clearly smaller part.
    symmetries
        At most this many self-similarities of the target (a turn or a shift mapping
        one part of it onto another: symmetric or repeated structure, found by matching
        its descriptors with those of its other parts and a consensus beyond
        ``rival_significance`` x chance) are composed, each with its inverse too, with the
        first-ranked pose; each such different pose whose coarse overlap is within
        ``min_margin`` of the first-ranked one is refined and compared like a rival,
        even when few feature matches support it.  0: off.
    seed
        Seed of every random choice.
    """

    voxel_m: float | None = None
    target_points: int = 5_000
    normal_neighbours: int = 16
    feature_radius_voxels: float = 5.0
    feature_max_neighbours: int = 100
    ratio: float | None = None
    min_mutual: int = 200
    max_correspondences: int = 5_000
    inlier_voxels: float = 1.5
    hypotheses: int = 6
    gate_spacings: float = 3.0
    min_overlap: float = 0.10
    min_inliers: int = 8
    min_significance: float = 4.0
    min_conditioning: float = 0.01
    min_margin: float = 0.5
    rival_share: float = 0.5
    rival_significance: float = 2.0
    same_pose_voxels: float = 2.0
    finer_retries: tuple[float, ...] = (1.0, 4.0)
    rival_misfit: float = 3.0
    symmetries: int = 2
    seed: int = 0

    def __post_init__(self) -> None:
        if self.voxel_m is not None and not (self.voxel_m > 0 and np.isfinite(self.voxel_m)):
            raise InputError(f"voxel_m must be a positive number, got {self.voxel_m}")
        if self.target_points < 100:
            raise InputError(f"target_points must be at least 100, got {self.target_points}")
        if self.ratio is not None and not 0 < self.ratio <= 1:
            raise InputError(f"ratio must be in (0, 1], got {self.ratio}")
        if not 0 < self.min_overlap < 1:
            raise InputError(f"min_overlap must be in (0, 1), got {self.min_overlap}")
        if not self.finer_retries or min(self.finer_retries) <= 0:
            raise InputError("finer_retries must be a non-empty list of positive multiples")
        if not (self.rival_significance > 0 and self.same_pose_voxels > 0):
            raise InputError("rival_significance and same_pose_voxels must be positive")
        if self.symmetries < 0 or not self.rival_misfit > 1:
            raise InputError(
                f"symmetries must be >= 0 and rival_misfit > 1, got {self.symmetries} and "
                f"{self.rival_misfit}"
            )
        if self.hypotheses < 1 or self.max_correspondences < 3:
            raise InputError("hypotheses must be >= 1 and max_correspondences >= 3")


@dataclass(frozen=True, eq=False)
class GlobalRegistrationResult:
    """Result of :func:`global_registration`.

    ``T_target_source`` (4x4, world source -> world target) is only meaningful
    when :attr:`ok`; otherwise ``status`` and ``reason`` say why it was rejected.
    """

    T_target_source: NDArray[np.float64]
    status: str
    reason: str
    overlap: float  # max of the two shares: the smaller cloud's covered part
    overlap_source: float
    overlap_target: float
    inliers: int
    correspondences: int
    mutual_matches: int
    significance: float  # inliers / clique size expected by chance
    conditioning: float
    margin: float  # 1 - (overlap of the best different pose) / overlap
    confidence: float
    voxel_m: float
    points_downsampled: tuple[int, int]
    icp: ICPResult | None
    timings: dict[str, float] = field(default_factory=dict)
    hypotheses: list[dict[str, Any]] = field(default_factory=list)
    attempts: list[dict[str, Any]] = field(default_factory=list)  # one per voxel size tried

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": "global (FPFH + consistency-graph RANSAC + point-to-plane ICP)",
            "status": self.status,
            "reason": self.reason,
            "T_target_source": self.T_target_source.tolist(),
            "overlap": self.overlap,
            "overlap_source": self.overlap_source,
            "overlap_target": self.overlap_target,
            "inliers": self.inliers,
            "correspondences": self.correspondences,
            "mutual_matches": self.mutual_matches,
            "significance": self.significance,
            "conditioning": self.conditioning,
            "margin": self.margin,
            "confidence": self.confidence,
            "voxel_m": self.voxel_m,
            "points_downsampled": list(self.points_downsampled),
            "icp": None if self.icp is None else self.icp.to_dict(),
            "timings_s": self.timings,
            "hypotheses": self.hypotheses,
            "attempts": self.attempts,
        }


def _as_cloud(c: PointCloud | ArrayLike, what: str) -> PointCloud:
    if isinstance(c, PointCloud):
        return c.validate(what=what)
    return PointCloud(xyz=np.asarray(c, dtype=np.float64)).validate(what=what)


def motion_conditioning(points: NDArray[np.float64], normals: NDArray[np.float64]) -> float:
    """How well a set of surface points constrains the six motions (0 to 1).

    The point-to-plane normal matrix ``J^T J`` with ``J = [(p - c) / r x n, n]``
    (rotations scaled by the RMS radius ``r`` about the centroid ``c``, so both
    blocks are dimensionless): the ratio of its smallest to its largest
    eigenvalue.  About 0 for a plane (three free motions), a cylinder (two) or a
    sphere (three), up to about 0.3 for a closed box.
    """
    if len(points) < 6:
        return 0.0
    c = points.mean(axis=0)
    r = float(np.sqrt(np.mean(np.sum((points - c) ** 2, axis=1)))) or 1.0
    J = np.hstack([np.cross((points - c) / r, normals), normals])
    ev = np.linalg.eigvalsh(J.T @ J)
    return float(max(ev[0], 0.0) / max(ev[-1], 1e-300))


def _world(
    R: NDArray[np.float64], t: NDArray[np.float64], off_s: NDArray[np.float64], off_t
) -> NDArray[np.float64]:
    """World T_target_source of a local motion ``x_t = R x_s + t``."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = off_t + t - R @ off_s
    return T


def _same_pose(
    Ta: NDArray[np.float64], Tb: NDArray[np.float64], pts: NDArray[np.float64], max_m: float
) -> bool:
    """Whether two world transforms are one pose: the RMS displacement between them of
    ``pts`` (where the data are, world) is at most ``max_m`` metres."""
    move = pts @ (Ta[:3, :3] - Tb[:3, :3]).T + (Ta[:3, 3] - Tb[:3, 3])
    return bool(np.sqrt(np.mean(np.sum(move**2, axis=1))) <= max_m)


def _nearest_within(
    tree: cKDTree, pts: NDArray[np.float64], gate: float, rows: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """``tree.query(pts, k=1, distance_upper_bound=gate)``, asked in the order of ``rows``
    (the points' rows in their cloud: neighbouring queries walk the same branches of the
    tree, faster than a random order) and returned in the order of ``pts``."""
    order = np.argsort(rows, kind="stable")
    d = np.empty(len(pts))
    nn = np.empty(len(pts), dtype=np.intp)
    d[order], nn[order] = tree.query(pts[order], k=1, distance_upper_bound=gate, workers=-1)
    return d, nn


def _shares(
    src: PointCloud,
    tgt: PointCloud,
    T: NDArray[np.float64],
    gate: float,
    tree_t: cKDTree,
    tree_s: cKDTree,
    normals_t: NDArray[np.float64],
    k_normals: int,
    rng: np.random.Generator,
    sample: int = 30_000,
    n_normals: int = 5_000,
) -> tuple[float, float, NDArray[np.float64], NDArray[np.float64]]:
    """Shares of source (target) points within ``gate`` of the other cloud after ``T``,
    and the overlapping source points (target local frame) with their target normals
    (``k_normals`` neighbours; taken from, and added to, the cache ``normals_t``)."""
    R, t = T[:3, :3], T[:3, 3]
    shift = R @ src.offset + t - tgt.offset  # source local -> target local
    i_s = rng.choice(len(src), size=min(sample, len(src)), replace=False)
    ps = src.xyz[i_s] @ R.T + shift
    d, nn = _nearest_within(tree_t, ps, gate, i_s)
    ok = np.isfinite(d)
    i_t = rng.choice(len(tgt), size=min(sample, len(tgt)), replace=False)
    pt = (tgt.xyz[i_t] - shift) @ R  # target local -> source local
    d2, _ = _nearest_within(tree_s, pt, gate, i_t)
    pts = ps[ok][:n_normals]
    rows = nn[ok][:n_normals]
    todo = np.unique(rows[np.isnan(normals_t[rows, 0])])
    if len(todo):
        normals_t[todo] = estimate_normals(tgt.xyz, tree_t, todo, k_normals)
    return float(ok.mean()), float(np.isfinite(d2).mean()), pts, normals_t[rows]


def _coarse_overlap(
    tree: cKDTree,
    pts: NDArray[np.float64],
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    gate: float,
) -> float:
    """Share of ``pts`` moved by ``(R, t)`` within ``gate`` of the points of ``tree``."""
    d, _ = tree.query(pts @ R.T + t, k=1, distance_upper_bound=gate, workers=-1)
    return float(np.isfinite(d).mean())


def _self_similarities(
    pts: NDArray[np.float64],
    desc: NDArray[np.float64],
    min_m: float,
    cp: ConsensusParams,
    p: GlobalRegistrationParams,
) -> list[NDArray[np.float64]]:
    """Rigid motions ``S`` (4x4, ``pts``' frame) that map one part of a cloud onto another.

    Points (at most ``_SELF_MATCH_ROWS``, evenly spread over the rows) are matched with
    the nearest descriptor (rows of ``desc``) among those of points at least ``min_m``
    metres away, and the graph-guided RANSAC of
    :func:`~pyheracles.registration.consensus.robust_rigid` finds the consistent
    motions: a 2-fold turn of a symmetric building, the shift from one bay to the
    next.  Only motions whose consensus is at least ``p.rival_significance`` times the
    clique size expected by chance (and ``p.min_inliers``) are returned, at most
    ``p.symmetries``, strongest first.
    """
    rows = np.arange(0, len(pts), max(1, -(-len(pts) // _SELF_MATCH_ROWS)))
    if len(rows) < 3:
        return []
    partner = nearest_far_descriptors(desc, pts, rows, min_m)
    hyps, stats = robust_rigid(
        pts[rows],
        pts[partner],
        replace(cp, max_hypotheses=p.symmetries, min_samples=256, max_samples=1024),
    )
    need = max(p.rival_significance * float(stats.get("null_clique", 1.0)), p.min_inliers)
    return [h.matrix for h in hyps if h.n_inliers >= need]


def global_registration(
    source: PointCloud | ArrayLike,
    target: PointCloud | ArrayLike,
    params: GlobalRegistrationParams | None = None,
) -> GlobalRegistrationResult:
    """Register ``source`` onto ``target`` without tie points or an initial pose.

    Parameters
    ----------
    source, target
        Clouds (or ``(N, 3)`` arrays) in their own frames, any relative pose.
    params
        :class:`GlobalRegistrationParams`.

    Returns
    -------
    GlobalRegistrationResult
        Always returned; use the transform only when ``result.ok`` (status
        ``"ok"``).  ``"no overlap"``: the clouds share too little surface (or no
        consistent set of matches exists); ``"ambiguous"``: the overlap does not
        fix the pose (a plane, a symmetric shape, two poses fitting as well).

    Raises
    ------
    InputError
        Empty clouds, NaN coordinates, fewer than 3 points, invalid parameters.
    """
    p = params or GlobalRegistrationParams()
    src = _as_cloud(source, "source cloud")
    tgt = _as_cloud(target, "target cloud")
    if len(src) < 10 or len(tgt) < 10:
        raise InputError(
            f"global registration needs at least 10 points per cloud "
            f"(source {len(src)}, target {len(tgt)})"
        )
    # every matrix product here is thin (N x 3, 6 x N, blocks of 256 descriptors): a
    # second BLAS thread only busy-waits, and on a shared machine it stalls the
    # product whenever the other core is taken
    with one_blas_thread():
        return _register(src, tgt, p)


def _register(
    src: PointCloud, tgt: PointCloud, p: GlobalRegistrationParams
) -> GlobalRegistrationResult:
    """:func:`global_registration` on validated clouds: the voxel sizes in turn."""
    # one KD-tree per full cloud, shared by the spacing, the verification and every
    # attempt; the target's normals estimated where first needed, then shared alike.
    # Balanced (median splits): slower to build than the sliding-midpoint trees of
    # pyheracles.geometry, but the hundreds of thousands of ICP queries that follow
    # are answered 10-15 % faster
    tree_s, tree_t = cKDTree(src.xyz), cKDTree(tgt.xyz)
    normals_t = np.full((len(tgt), 3), np.nan)
    sp_s = point_spacing(src.xyz, tree_s, rng=p.seed)
    sp_t = point_spacing(tgt.xyz, tree_t, rng=p.seed)
    scales = (1.0,) if p.voxel_m is not None else p.finer_retries
    res: GlobalRegistrationResult | None = None
    attempts: list[dict[str, Any]] = []
    for m in scales:
        pm = replace(p, target_points=round(p.target_points * m))
        res = _attempt(src, tgt, pm, (sp_s, sp_t), (tree_s, tree_t), normals_t)
        attempts.append({"voxel_m": res.voxel_m, "status": res.status, "reason": res.reason})
        if res.status != "no overlap":
            break  # accepted, or ambiguous (symmetric, degenerate: finer will not help)
    assert res is not None
    return replace(res, attempts=attempts)


def _attempt(
    src: PointCloud,
    tgt: PointCloud,
    p: GlobalRegistrationParams,
    spacings: tuple[float, float],
    trees: tuple[cKDTree, cKDTree],
    normals_t: NDArray[np.float64],
) -> GlobalRegistrationResult:
    """One pass of :func:`global_registration` at the voxel size of ``p`` (``spacings``
    and ``trees``: of the full source and target clouds; ``normals_t``: cache of the
    target's normals, NaN where not estimated yet)."""
    sp_s, sp_t = spacings
    tree_s, tree_t = trees
    rng = np.random.default_rng(p.seed)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    with progress.stage("global registration: voxels, normals, FPFH"):
        voxel = p.voxel_m or max(
            choose_voxel(src.xyz, sp_s, p.target_points, rng=rng),
            choose_voxel(tgt.xyz, sp_t, p.target_points, rng=rng),
        )
        ds, _ = voxel_downsample(src.xyz, voxel)
        dt, _ = voxel_downsample(tgt.xyz, voxel)
        if len(ds) < 10 or len(dt) < 10:  # one cloud is tiny at the other's scale
            return GlobalRegistrationResult(
                T_target_source=np.eye(4), status="no overlap",
                reason=f"at a voxel of {voxel:.3g} m the clouds keep {len(ds)} and {len(dt)} "
                "points: their sizes differ too much to share a surface",
                overlap=0.0, overlap_source=0.0, overlap_target=0.0, inliers=0,
                correspondences=0, mutual_matches=0, significance=0.0, conditioning=0.0,
                margin=0.0, confidence=0.0, voxel_m=voxel,
                points_downsampled=(len(ds), len(dt)), icp=None, timings=timings,
            )  # fmt: skip
        ns = unoriented_normals(ds, p.normal_neighbours)
        nt = unoriented_normals(dt, p.normal_neighbours)
        radius = p.feature_radius_voxels * voxel
        fs = fpfh_descriptors(ds, ns, radius, max_neighbours=p.feature_max_neighbours)
        ft = fpfh_descriptors(dt, nt, radius, max_neighbours=p.feature_max_neighbours)
    timings["features"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    with progress.stage("global registration: matching and consensus"):
        i_s, i_t, n_mutual = match_descriptors(
            np.sqrt(fs), np.sqrt(ft), ratio=p.ratio, min_mutual=p.min_mutual,
            max_matches=p.max_correspondences,
        )  # fmt: skip
        cp = ConsensusParams(
            inlier_m=p.inlier_voxels * voxel, max_hypotheses=p.hypotheses, seed=p.seed
        )
        hyps, stats = robust_rigid(ds[i_s], dt[i_t], cp)
    timings["consensus"] = time.perf_counter() - t0
    null = float(stats.get("null_clique", 1.0))
    n_corr = len(i_s)
    base: dict[str, Any] = {
        "voxel_m": voxel,
        "points_downsampled": (len(ds), len(dt)),
        "correspondences": n_corr,
        "mutual_matches": n_mutual,
        "timings": timings,
    }
    inliers = hyps[0].n_inliers if hyps else 0
    significance = inliers / max(null, 1.0)
    if inliers < p.min_inliers or significance < p.min_significance:
        reason = (
            f"no consistent set of feature matches stands out: at best {inliers} of {n_corr} "
            f"correspondences agree ({significance:.1f} x the {null:.0f} expected by chance; "
            f"need {p.min_inliers} and {p.min_significance:.1f} x)"
        )
        return GlobalRegistrationResult(
            T_target_source=np.eye(4), status="no overlap", reason=reason,
            overlap=0.0, overlap_source=0.0, overlap_target=0.0, inliers=inliers,
            significance=significance, conditioning=0.0, margin=0.0, confidence=0.0, icp=None,
            **base,
        )  # fmt: skip
    t0 = time.perf_counter()
    with progress.stage("global registration: verifying hypotheses (ICP)"):
        # coarse score of every hypothesis on the downsampled clouds (1 voxel gate)
        tree_dt = cKDTree(dt)
        coarse = []
        for h in hyps:
            coarse.append(_coarse_overlap(tree_dt, ds, h.R, h.t, voxel))
        order = [int(q) for q in np.argsort(coarse, kind="stable")[::-1]]
        # poses compared where the data are: RMS displacement of the source's voxels
        where = ds[:: max(1, len(ds) // 2000)] + src.offset
        distinct_m = p.same_pose_voxels * voxel
        T_hyp = [_world(h.R, h.t, src.offset, tgt.offset) for h in hyps]
        # every different pose whose own consensus is beyond chance is a rival
        chance = p.rival_significance * max(null, 1.0)
        rival_q = [
            q
            for q in order[1:]
            if hyps[q].n_inliers >= chance
            and not _same_pose(T_hyp[q], T_hyp[order[0]], where, distinct_m)
        ]
        # the target's own symmetries composed with the first-ranked pose: where the
        # target repeats itself the source fits there too, yet such a pose may have few
        # matches (each source point has one nearest descriptor, and the better-fitting
        # pose takes most of them): it would never be beyond chance as a hypothesis
        n_hyps = len(hyps)
        if p.symmetries:
            h0 = hyps[order[0]]
            for S in _self_similarities(dt, np.sqrt(ft), radius, cp, p):
                for M in (S, np.linalg.inv(S)):
                    R, t = M[:3, :3] @ h0.R, M[:3, :3] @ h0.t + M[:3, 3]
                    Tw = _world(R, t, src.offset, tgt.offset)
                    if any(
                        _same_pose(Tw, T_hyp[q], where, distinct_m)
                        for q in [order[0], *rival_q, *range(n_hyps, len(hyps))]
                    ):
                        continue
                    inl = np.linalg.norm(ds[i_s] @ R.T + t - dt[i_t], axis=1) < cp.inlier_m
                    hyps.append(RigidHypothesis(R=R, t=t, inliers=inl, n_samples_supporting=0))
                    T_hyp.append(Tw)
                    coarse.append(_coarse_overlap(tree_dt, ds, R, t, voxel))
                    # refined (and compared) only when it could come within the margin
                    if coarse[-1] >= (1.0 - p.min_margin) * coarse[order[0]]:
                        rival_q.append(len(hyps) - 1)
        mirrored = set(range(n_hyps, len(hyps)))  # rivals from the target's symmetries
        gate = p.gate_spacings * max(sp_t, sp_s)
        fine = ICPParams(
            max_correspondence_m=max(gate, voxel), overlap_distance_m=gate,
            samples=(5_000, 20_000, 60_000), tolerance=1e-5, min_overlap=0.01, seed=p.seed,
        )  # fmt: skip
        quick = replace(fine, samples=(2_000, 8_000), iterations_per_level=10,
                        evaluation_samples=20_000)  # fmt: skip
        if len(tgt) <= _ALL_NORMALS_UP_TO and np.isnan(normals_t[:, 0]).all():
            # the ICP runs and the overlap shares will touch much of a small target:
            # all its normals at once by the compiled octree search, about 3x cheaper
            # per point than the lazy k-d tree estimate (the same k nearest neighbours,
            # the point itself counted; a tie at the k-th distance may pick another)
            k = int(min(fine.normal_neighbours, len(tgt)))
            normals_t[:] = octree_pca(tgt.xyz, k, directions=False)[1]

        def refine(T0: NDArray[np.float64], prm: ICPParams) -> tuple[float, Any]:
            try:
                r = icp(src, tgt, T0, prm, target_tree=tree_t, target_normals=normals_t)
            except (InputError, EstimationError):
                return 0.0, None
            return r.overlap_fraction, r

        win, second, second_inliers, top_from_symmetry = order[0], 0.0, 0, False
        best_q = order[0]  # the hypothesis whose quick score stands for the chosen pose
        quick_score: dict[int, float] = {}
        pose: dict[int, NDArray[np.float64]] = {}
        rival_of: list[int] = []
        # hypotheses of the chosen pose (variants of it, not rivals)
        chosen = {
            q for q in range(len(hyps)) if _same_pose(T_hyp[q], T_hyp[order[0]], where, distinct_m)
        }
        if rival_q:
            # the best and every rival refined alike, so that their overlaps compare fairly
            refined = {q: refine(T_hyp[q], quick) for q in [order[0], *rival_q]}
            quick_score = {q: s for q, (s, _) in refined.items()}
            pose = {
                q: T_hyp[q] if r is None else r.T_target_source for q, (_, r) in refined.items()
            }
            # a better-fitting rival of its own consensus wins; one from a symmetry of the
            # target only rivals (its few matches would not make it significant)
            best_q = max((q for q in refined if q not in mirrored), key=lambda q: refined[q][0])
            # the refined hypotheses that converged onto the best-fitting pose are that pose
            same = {q for q in refined if _same_pose(pose[q], pose[best_q], where, distinct_m)}
            chosen = same | chosen if order[0] in same else same
            # the pose is represented by its hypothesis of the largest consensus
            win = max(same, key=lambda q: (hyps[q].n_inliers, refined[q][0]))
            # a different pose is a rival unless it leaves clearly more of the source
            # unexplained than the chosen one, which explains nearly all of it (a crop
            # inside a building of repeated bays fits the next bay only in part)
            misfit = p.rival_misfit * (1.0 - refined[best_q][0])
            rival_of = [q for q in refined if q not in same and 1.0 - refined[q][0] < misfit]
            if rival_of:
                top = max(rival_of, key=lambda q: refined[q][0])
                second, second_inliers = refined[top][0], hyps[top].n_inliers
                top_from_symmetry = top in mirrored
        h_best = hyps[win]
        # the full refinement starts from the best-fitting quick refinement of the pose
        # (ICP from another hypothesis of it may stop in a neighbouring local minimum)
        start = pose[best_q] if rival_q else T_hyp[win]
        best_score, final_icp = refine(start, fine)
        if rival_q:
            best_score = quick_score[best_q]  # the margin compares the quick refinements
        T = final_icp.T_target_source if final_icp is not None else start
        ov_s, ov_t, pts, nrm = _shares(
            src, tgt, T, gate, tree_t, tree_s, normals_t, fine.normal_neighbours, rng
        )
    timings["verification"] = time.perf_counter() - t0
    hyp_report = [
        {"inliers": h.n_inliers, "samples_supporting": h.n_samples_supporting,
         "coarse_overlap": c, "quick_overlap": quick_score.get(q), "chosen": q == win,
         "rival": q in rival_of, "from_symmetry": q in mirrored}
        for q, (h, c) in enumerate(zip(hyps, coarse, strict=True))
    ]  # fmt: skip
    # the larger of the two shares: a small cloud inside a large one overlaps fully
    overlap = max(ov_s, ov_t)
    cond = motion_conditioning(pts, nrm)
    inliers = h_best.n_inliers
    significance = inliers / max(null, 1.0)
    margin = 1.0 - second / best_score if best_score > 0 else 0.0
    repeats = (
        ": the target repeats itself (symmetric or repeated structure)" if top_from_symmetry else ""
    )
    # does the consensus stand out against the best different pose?
    stands_out = inliers >= p.min_significance * max(null, second_inliers, 1.0)
    # the strongest different pose by its own matches (a hypothesis of the chosen pose,
    # or one sharing most of its matches with it, is a variant of it, not a rival)
    rival_inliers = max(
        [h.n_inliers for q, h in enumerate(hyps)
         if q not in chosen and (h.inliers & h_best.inliers).sum() < 0.5 * h.n_inliers],
        default=0,
    )  # fmt: skip
    rival_strong = rival_inliers >= max(
        p.min_significance * null, p.rival_share * inliers, p.min_inliers
    )
    if significance < p.min_significance or inliers < p.min_inliers:
        status = "no overlap"
        reason = (
            f"the best-fitting pose has only {inliers} consistent matches "
            f"({significance:.1f} x the {null:.0f} expected by chance; need "
            f"{p.min_inliers} and {p.min_significance:.1f} x)"
        )
    elif overlap < p.min_overlap or final_icp is None:
        status = "no overlap"
        reason = (
            f"the best alignment covers only {overlap:.1%} of the points within "
            f"{gate:.3g} m (need {p.min_overlap:.0%})"
        )
    elif rival_strong:
        status = "ambiguous"
        reason = (
            f"two different poses are each supported by many consistent matches ({inliers} "
            f"and {rival_inliers}): symmetric or repeated structure"
        )
    elif margin < p.min_margin and (not stands_out or second_inliers >= p.min_significance * null):
        status = "ambiguous"
        reason = (
            f"no pose stands out: {inliers} consistent matches against {second_inliers} for a "
            f"different pose, overlap {best_score:.1%} against {second:.1%}{repeats}"
        )
    elif cond < p.min_conditioning:
        status = "ambiguous"
        reason = (
            f"the overlap does not fix all six motions (conditioning {cond:.2g} < "
            f"{p.min_conditioning:.2g}: planar, cylindrical or spherical)"
        )
    elif margin < p.min_margin:
        status = "ambiguous"
        reason = (
            f"a different pose fits almost as well (overlap {second:.1%} against "
            f"{best_score:.1%}; margin {margin:.2f} < {p.min_margin:.2f}){repeats}"
        )
    else:
        status, reason = "ok", ""
    confidence = float(
        np.clip(overlap / (2 * p.min_overlap), 0, 1)
        * np.clip((significance - 1) / (2 * p.min_significance - 1), 0, 1)
        * np.clip(cond / (2 * p.min_conditioning), 0, 1)
        * np.clip(margin / (2 * p.min_margin), 0, 1)
    )
    return GlobalRegistrationResult(
        T_target_source=T, status=status, reason=reason, overlap=overlap,
        overlap_source=ov_s, overlap_target=ov_t, inliers=inliers,
        significance=significance, conditioning=cond, margin=margin, confidence=confidence,
        icp=final_icp, hypotheses=hyp_report, **base,
    )  # fmt: skip
