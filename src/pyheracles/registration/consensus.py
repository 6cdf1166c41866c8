"""Rigid transforms from putative correspondences with 95-99 % outliers.

Feature matches between two scans are mostly wrong.  Two ideas make the
estimate survive that:

1. **Pairwise consistency** (TEASER++, Yang, Shi & Carlone 2020; KISS-Matcher,
   Lim et al. 2025): a rigid motion preserves distances, so two correct
   correspondences ``(a_i, b_i)``, ``(a_j, b_j)`` satisfy
   ``| |a_i - a_j| - |b_i - b_j| | <= 2 eps``.  The boolean consistency graph is
   built once; correct correspondences form a large clique in it, wrong ones
   are rarely consistent with anything.
2. **Graph-guided sampling** (RANSAC, Fischler & Bolles 1981, with the
   edge-length check of Open3D's ``CorrespondenceCheckerBasedOnEdgeLength``
   built in): a minimal sample is a *triangle* of the graph — a seed drawn in
   proportion to its degree, a consistent second correspondence, and a third
   consistent with both.  With 97 % outliers a uniform triplet is all-inlier
   once in 37 000 draws; a graph triangle around an inlier seed nearly always
   is.  Samples are drawn and scored in vectorised batches (batched Kabsch by
   SVD, inlier counts on all correspondences by a compiled kernel), with early
   stop once the best consensus has been found again several times.

Every distinct hypothesis is then re-estimated on its consensus set (least
squares, a few local-optimisation rounds as in LO-RANSAC) and returned, best
first, for verification on the clouds.  :func:`null_clique_size` gives the
size of the largest clique expected by chance in a random graph of the same
density, against which the consensus is judged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.distance import cdist

from pyheracles.errors import InputError

__all__ = [
    "ConsensusParams",
    "RigidHypothesis",
    "consistency_graph",
    "kabsch",
    "null_clique_size",
    "robust_rigid",
    "rotation_angle_deg",
]


@dataclass(frozen=True)
class ConsensusParams:
    """Parameters of :func:`robust_rigid`.

    Attributes
    ----------
    inlier_m
        A correspondence is an inlier when ``|R a + t - b|`` is below this, metres.
    edge_tolerance_m
        Pairwise consistency tolerance on distance differences, metres; ``None``:
        ``2 * inlier_m`` (the bound for two points each within ``inlier_m``).
    min_edge_m
        The three correspondences of a sample must be at least this far apart
        (both clouds), metres; ``None``: ``3 * inlier_m``.  Short triangles give
        badly determined rotations.
    batch
        Samples drawn and scored at once.
    max_samples
        Upper bound of samples.
    min_samples
        Samples drawn before the early stop may apply.
    confirmations
        Early stop: the best consensus (within 90 % of its size) was reached by
        this many samples.
    max_hypotheses
        Distinct hypotheses returned (best first).
    distinct_deg, distinct_m
        Two hypotheses are the same when their rotations differ by less than
        ``distinct_deg`` degrees and their translations by less than
        ``distinct_m`` metres (``None``: ``5 * inlier_m``).
    refine_rounds
        Least-squares re-estimations on the consensus set.
    seed
        Seed of the random sampling.
    """

    inlier_m: float
    edge_tolerance_m: float | None = None
    min_edge_m: float | None = None
    batch: int = 256
    max_samples: int = 20_000
    min_samples: int = 1_024
    confirmations: int = 6
    max_hypotheses: int = 6
    distinct_deg: float = 5.0
    distinct_m: float | None = None
    refine_rounds: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        if not (self.inlier_m > 0 and np.isfinite(self.inlier_m)):
            raise InputError(f"inlier_m must be a positive number, got {self.inlier_m}")
        if self.batch < 1 or self.max_samples < 1 or self.max_hypotheses < 1:
            raise InputError("batch, max_samples and max_hypotheses must be at least 1")


@dataclass(frozen=True, eq=False)
class RigidHypothesis:
    """A rigid motion ``b = R a + t`` with its consensus set."""

    R: NDArray[np.float64]
    t: NDArray[np.float64]
    inliers: NDArray[np.bool_]  # over the correspondences given
    n_samples_supporting: int  # samples whose consensus reached 90 % of this one's

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())

    @property
    def matrix(self) -> NDArray[np.float64]:
        T = np.eye(4)
        T[:3, :3] = self.R
        T[:3, 3] = self.t
        return T


def kabsch(
    a: NDArray[np.float64], b: NDArray[np.float64], w: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares rotation and translation with ``b ~ R a + t``.

    ``a``, ``b`` are ``(..., n, 3)``: a leading batch dimension is solved at once
    (Arun, Huang & Blostein 1987; reflections excluded, Umeyama 1991).
    """
    if w is None:
        ca, cb = a.mean(axis=-2, keepdims=True), b.mean(axis=-2, keepdims=True)
        H = np.swapaxes(a - ca, -1, -2) @ (b - cb)
    else:
        ws = w / w.sum(axis=-1, keepdims=True)
        ca = (ws[..., None] * a).sum(axis=-2, keepdims=True)
        cb = (ws[..., None] * b).sum(axis=-2, keepdims=True)
        H = np.swapaxes((a - ca) * ws[..., None], -1, -2) @ (b - cb)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)))
    d = np.where(d == 0, 1.0, d)
    D = np.zeros(H.shape)
    D[..., 0, 0] = 1.0
    D[..., 1, 1] = 1.0
    D[..., 2, 2] = d
    R = np.swapaxes(Vt, -1, -2) @ D @ np.swapaxes(U, -1, -2)
    t = cb[..., 0, :] - (R @ ca[..., 0, :, None])[..., 0]
    return R, t


def rotation_angle_deg(R1: NDArray[np.float64], R2: NDArray[np.float64]) -> float:
    """Angle of the rotation ``R1 R2^T``, degrees."""
    c = (np.trace(R1 @ R2.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def consistency_graph(
    a: NDArray[np.float64], b: NDArray[np.float64], tolerance: float
) -> tuple[NDArray[np.bool_], NDArray[np.float32]]:
    """Pairwise length-consistency matrix (diagonal False) and the source distances."""
    n = len(a)
    C = np.empty((n, n), dtype=bool)
    dmin = np.empty((n, n), dtype=np.float32)
    for s in range(0, n, 1024):  # row blocks bound the float64 temporaries
        da = cdist(a[s : s + 1024], a)
        db = cdist(b[s : s + 1024], b)
        C[s : s + 1024] = np.abs(da - db) <= tolerance
        dmin[s : s + 1024] = np.minimum(da, db)
    np.fill_diagonal(C, False)
    return C, dmin


def null_clique_size(n: int, density: float) -> float:
    """Largest clique expected by chance in a random graph G(n, p) (Matula 1976).

    ``2 log n / log(1 / p) + 1``; a consensus much larger than this is not luck.
    """
    if n < 2:
        return 1.0
    p = float(np.clip(density, 1e-12, 1 - 1e-9))
    return 2.0 * np.log(n) / np.log(1.0 / p) + 1.0


def _random_member(mask: NDArray[np.bool_], rng: np.random.Generator) -> NDArray[np.intp]:
    """One random True column per row (rows without any: -1)."""
    score = rng.random(mask.shape, dtype=np.float32) * mask
    j = score.argmax(axis=1)
    return np.where(mask.any(axis=1), j, -1)


def _refine(
    a: NDArray[np.float64], b: NDArray[np.float64], R, t, eps: float, rounds: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    inl = np.linalg.norm(a @ R.T + t - b, axis=1) < eps
    for _ in range(rounds):
        if inl.sum() < 3:
            break
        R2, t2 = kabsch(a[inl], b[inl])
        inl2 = np.linalg.norm(a @ R2.T + t2 - b, axis=1) < eps
        if inl2.sum() < inl.sum():
            break
        R, t, inl = R2, t2, inl2
    return R, t, inl


def robust_rigid(
    a: ArrayLike, b: ArrayLike, params: ConsensusParams
) -> tuple[list[RigidHypothesis], dict[str, float]]:
    """Distinct rigid hypotheses from outlier-ridden correspondences, best first.

    Parameters
    ----------
    a, b
        ``(n, 3)`` corresponding points (source, target), metres, local frames.
    params
        :class:`ConsensusParams`.

    Returns
    -------
    hypotheses
        Up to ``max_hypotheses`` distinct :class:`RigidHypothesis`, most inliers
        first (empty when no consistent triangle exists).
    stats
        ``samples`` drawn, graph ``density``, ``null_clique`` (the clique size
        expected by chance, from the density among the correspondences outside
        the best consensus, ``density_outliers``), ``max_degree``.
    """
    A = np.asarray(a, dtype=np.float64)
    B = np.asarray(b, dtype=np.float64)
    if A.shape != B.shape or A.ndim != 2 or A.shape[1] != 3:
        raise InputError(f"correspondences must be two (n, 3) arrays, got {A.shape}, {B.shape}")
    n = len(A)
    p = params
    # centred: translations of two hypotheses then compare at the data, not at a far origin
    ca = A.mean(axis=0) if n else np.zeros(3)
    cb = B.mean(axis=0) if n else np.zeros(3)
    A = A - ca
    B = B - cb
    eps = p.inlier_m
    tol = p.edge_tolerance_m if p.edge_tolerance_m is not None else 2.0 * eps
    min_edge = p.min_edge_m if p.min_edge_m is not None else 3.0 * eps
    distinct_m = p.distinct_m if p.distinct_m is not None else 5.0 * eps
    stats: dict[str, float] = {"correspondences": n, "samples": 0, "density": 0.0}
    if n < 3:
        stats["null_clique"] = 1.0
        return [], stats
    from pyheracles.registration.fpfh_kernels import consistency_kernel, inlier_counts_kernel

    # the graph of consistency_graph (and its edges long enough to sample) in one pass
    C = np.empty((n, n), dtype=bool)
    usable = np.empty((n, n), dtype=bool)
    consistency_kernel(A, B, float(tol), float(min_edge), C, usable)
    density = float(C.sum()) / (n * (n - 1))
    stats["density"] = density
    stats["null_clique"] = null_clique_size(n, density)
    deg = usable.sum(axis=1).astype(np.float64)
    stats["max_degree"] = float(deg.max())
    if deg.max() < 2:
        return [], stats
    rng = np.random.default_rng(p.seed)
    prob = deg**2 / np.sum(deg**2)
    best = 0
    confirmations = 0
    keep_R = np.zeros((0, 3, 3))
    keep_t = np.zeros((0, 3))
    keep_n = np.zeros(0, dtype=np.int64)
    drawn = 0
    while drawn < p.max_samples:
        m = min(p.batch, p.max_samples - drawn)
        drawn += m
        i = rng.choice(n, size=m, p=prob)
        j = _random_member(usable[i], rng)
        ok = j >= 0
        i, j = i[ok], j[ok]
        k = _random_member(usable[i] & usable[j], rng)
        ok = k >= 0
        i, j, k = i[ok], j[ok], k[ok]
        if len(i) == 0:
            continue
        tri = np.stack([i, j, k], axis=1)
        R, t = kabsch(A[tri], B[tri])
        counts = inlier_counts_kernel(A, B, R, t, eps * eps)  # |R a + t - b| < eps
        top = int(counts.max())
        if top > best:
            best = top
            # samples that already reached 90 % of the new best still count
            confirmations = int((keep_n >= 0.9 * best).sum())
        confirmations += int((counts >= 0.9 * best).sum())
        good = counts >= max(3, 0.5 * best)
        keep_R = np.concatenate([keep_R, R[good]])
        keep_t = np.concatenate([keep_t, t[good]])
        keep_n = np.concatenate([keep_n, counts[good]])
        if len(keep_n) > 4096:  # keep the strongest only
            order = np.argsort(keep_n, kind="stable")[::-1][:1024]
            keep_R, keep_t, keep_n = keep_R[order], keep_t[order], keep_n[order]
        if drawn >= p.min_samples and confirmations >= p.confirmations:
            break
    stats["samples"] = drawn
    order = np.argsort(keep_n, kind="stable")[::-1]
    keep_R, keep_t, keep_n = keep_R[order], keep_t[order], keep_n[order]
    cos_max = np.cos(np.radians(p.distinct_deg))

    def same(R: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which kept raw samples are the same motion as (R, t)."""
        c = (np.einsum("bij,ij->b", keep_R, R) - 1.0) / 2.0  # cos of the relative angle
        return (c >= cos_max) & (np.linalg.norm(keep_t - t, axis=1) < distinct_m)

    hyps: list[RigidHypothesis] = []
    free = np.ones(len(keep_n), dtype=bool)
    attempts = 0
    while free.any() and len(hyps) < p.max_hypotheses and attempts < 4 * p.max_hypotheses:
        attempts += 1
        q = int(np.argmax(free))  # the strongest raw sample not yet explained
        R2, t2, inl = _refine(A, B, keep_R[q], keep_t[q], eps, p.refine_rounds)
        free &= ~same(keep_R[q], keep_t[q])
        if inl.sum() < 3:
            continue
        free &= ~same(R2, t2)
        if any(
            rotation_angle_deg(R2, h.R) < p.distinct_deg and np.linalg.norm(t2 - h.t) < distinct_m
            for h in hyps
        ):
            continue
        support = int((keep_n >= 0.9 * inl.sum()).sum())
        hyps.append(RigidHypothesis(R=R2, t=t2, inliers=inl, n_samples_supporting=support))
    hyps.sort(key=lambda h: -h.n_inliers)
    hyps = [  # back to the given frames: b = R (a - ca) + t + cb
        RigidHypothesis(R=h.R, t=h.t + cb - h.R @ ca, inliers=h.inliers,
                        n_samples_supporting=h.n_samples_supporting)
        for h in hyps
    ]  # fmt: skip
    if hyps:
        # chance level from the correspondences the best consensus leaves out
        rest = ~hyps[0].inliers
        m = int(rest.sum())
        if m >= 2:
            p_rest = float(C[np.ix_(rest, rest)].sum()) / (m * (m - 1))
            stats["density_outliers"] = p_rest
            stats["null_clique"] = null_clique_size(m, p_rest)
    return hyps, stats
