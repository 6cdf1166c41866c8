"""ICP restricted to the recesses of matched openings (after the pane solution).

The outlines of :mod:`~pyheracles.registration.panes` are derived surfaces: each reveal
point slid onto the pane mid-plane.  Where a viewer sees a reveal in part or at a
grazing angle (a high window seen from the ground by an exterior TLS), the derived
outline can sit centimetres to decimetres off in the glass plane although the raw
points are right.  This module refines a pane solution on the raw points instead:

- **Surfaces** - per opening, the recess points that are not glass
  (:attr:`Opening.recess`): the reveals from the wall face to the glass and, through
  the glass, the other side's reveals.  Between an interior and an exterior cloud the
  shared surfaces are a straight reveal on both sides of the glass and each side's
  reveal seen through it; a splayed inner reveal against a straight outer one is not
  shared, so a correspondence must join points of parallel tangent planes.
- **Correspondences** - each source point of a matched opening with its nearest point
  of the *partner* opening only (one KD-tree per opening: a jamb never pairs with the
  neighbouring window), within a gate shrinking coarse to fine, normals within
  ``normal_agreement_deg``.
- **Step** - linearised point-to-plane least squares with a Tukey biweight (scale from
  the MAD, floored at ``min_scale_m``, its cut-off never inside the gate), plus one
  robust row per opening putting its mapped pane centre on the partner's mid-plane
  (the glass thickness is compensated in the mid-planes; the glass itself is a pair
  of parallel planes a thickness apart and does not enter as points).
- **Check** - per opening, the share of source points that lie on the partner's
  surfaces (within ``agree_distance_m``) among those near them, and whether those
  points fix both in-plane directions (two jambs alone leave the pane free to slide
  along them).  The caller decides what a solution needs (see
  :func:`~pyheracles.registration.pane_matching.match_openings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.registration.panes import Opening

__all__ = [
    "PaneICPParams",
    "PaneICPResult",
    "loose_turn",
    "minimum_spread",
    "motion_moment",
    "recess_trees",
    "refine_on_recesses",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PaneICPParams:
    """Parameters of :func:`refine_on_recesses` (metres and degrees).

    Attributes
    ----------
    gates_m
        Correspondence distances, coarse to fine.
    iterations
        Largest number of steps per gate.
    normal_agreement_deg
        Largest angle between the tangent planes of two corresponding points.
    min_scale_m
        Floor of the robust scale (the range noise of a good scanner).
    tukey_c
        Tukey biweight constant in robust scales.
    agree_distance_m
        A source point lies on its partner's surface when its point-to-plane distance
        is below this.
    check_gate_m
        Points with a partner point within this distance take part in the check.
    min_check_points
        Fewest points in the check of one opening for a verdict.
    min_spread
        Smallest eigenvalue of the 2 x 2 second-moment matrix of the in-plane components
        of the partner normals (agreeing points) for an opening to be verified (two
        jambs alone give 0, a full rectangle about 0.5).
    agree_share
        An opening agrees when at least this share of its checked points lies on the
        partner's surfaces; it disagrees below ``disagree_share``.
    disagree_share
        See ``agree_share``.
    max_points
        Source points per opening used at most (regular subsample).
    depth_scale_m
        Robust scale of the pane-depth rows (Tukey kernel at ``tukey_c`` x it).
    restart_m
        Displacement of the six extra starts (along each axis, both ways) whose minima
        must coincide with the solution's (0: no restarts).
    """

    gates_m: tuple[float, ...] = (0.12, 0.06, 0.03, 0.015)
    iterations: int = 8
    normal_agreement_deg: float = 35.0
    min_scale_m: float = 0.003
    tukey_c: float = 4.685
    agree_distance_m: float = 0.01
    check_gate_m: float = 0.05
    min_check_points: int = 40
    min_spread: float = 0.05
    agree_share: float = 0.6
    disagree_share: float = 0.35
    max_points: int = 1500
    restart_m: float = 0.05
    depth_scale_m: float = 0.01


@dataclass(frozen=True, eq=False)
class PaneICPResult:
    """Result of :func:`refine_on_recesses`.

    Attributes
    ----------
    T_target_source
        Refined rigid transform (cloud local frames).
    n_correspondences
        Correspondences of the last step.
    rms_m
        Weighted point-to-plane RMS of the last step.
    n_checked
        ``(K,)`` points per matched opening that took part in the check.
    share_on_surface
        ``(K,)`` share of them on the partner's surfaces (``nan``: too few checked).
    spread
        ``(K,)`` in-plane spread of the agreeing points' normals.
    verdict
        ``(K,)`` +1 agrees, -1 disagrees, 0 undecided (too few points, or they fix
        only one in-plane direction).
    local
        ``(K, 4, 4)`` per opening: the refined transform corrected in the pane plane
        (translation and rotation about the normal) by that opening's own agreeing
        points (the refined transform itself where it does not agree): its tie points
        then carry its own scatter into the adjustment's report.
    residual_rms_m
        ``(K,)`` RMS point-to-plane distance of each opening's agreeing points after
        its local fit (``nan`` where it does not agree).
    normal_moment
        ``(K, 3, 3)`` mean ``n n^T`` of each opening's agreeing points' normals (zero
        where it does not agree): summed over the agreeing openings, its smallest
        eigenvalue says whether they fix all three translations (reveals of one wall
        direction leave the depth along its normal free).
    basin_m
        Largest RMS distance, over the matched pane centres, between the solution and
        the minima reached from the six displaced starts (0 without restarts).
    """

    T_target_source: Array
    n_correspondences: int
    rms_m: float
    n_checked: NDArray[np.int_]
    share_on_surface: Array
    spread: Array
    verdict: NDArray[np.int_]
    local: Array
    residual_rms_m: Array
    normal_moment: Array
    basin_m: float = 0.0


def recess_trees(openings: list[Opening]) -> list[cKDTree | None]:
    """One KD-tree per opening on its recess points (``None`` when it has too few)."""
    return [cKDTree(o.recess) if len(o.recess) >= 10 else None for o in openings]


def _rotation(w: Array) -> Array:
    th = float(np.linalg.norm(w))
    if th < 1e-15:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def _subsample(o: Opening, m: int) -> tuple[Array, Array]:
    step = max(1, len(o.recess) // m)
    return o.recess[::step], o.recess_normal[::step]


def _correspond(
    src: tuple[Array, Array],
    tgt: Opening,
    tree: cKDTree,
    R: Array,
    t: Array,
    gate: float,
    cos_tol: float,
) -> tuple[Array, Array, Array]:
    """Mapped source points, partner points and partner normals of the valid pairs."""
    P = src[0] @ R.T + t
    Ns = src[1] @ R.T
    d, nb = tree.query(P, distance_upper_bound=gate)
    ok = np.isfinite(d)
    nb_ok = nb[ok]
    Nt = tgt.recess_normal[nb_ok]
    ok_idx = np.flatnonzero(ok)
    par = np.abs(np.einsum("ij,ij->i", Ns[ok_idx], Nt)) > cos_tol
    sel = ok_idx[par]
    return P[sel], tgt.recess[nb_ok[par]], Nt[par]


def refine_on_recesses(
    source: list[Opening],
    target: list[Opening],
    pairs: NDArray[np.int_],
    T0: Array,
    depth_weight: Array,
    params: PaneICPParams | None = None,
    *,
    opposite_sides: bool = True,
    trees: list[cKDTree | None] | None = None,
) -> PaneICPResult:
    """Point-to-plane ICP of the matched openings' recesses, then a per-opening check.

    Parameters
    ----------
    source, target
        Openings of the two clouds (with their recess points).
    pairs
        ``(K, 2)`` matched openings (source index, target index).
    T0
        Initial ``T_target_source`` (4x4, local frames), e.g. from the outline fit.
    depth_weight
        ``(K,)`` weight (in points) of each opening's pane-depth row (0: none).
    params
        :class:`PaneICPParams`.
    opposite_sides
        The clouds see the panes from opposite sides (normals reversed).
    trees
        :func:`recess_trees` of ``target`` (built when omitted).

    Returns
    -------
    PaneICPResult
        The refined transform and the check of every matched opening.
    """
    p = params or PaneICPParams()
    trees = trees if trees is not None else recess_trees(target)
    cos_tol = float(np.cos(np.deg2rad(p.normal_agreement_deg)))
    sgn = -1.0 if opposite_sides else 1.0
    src = [_subsample(source[i], p.max_points) for i in pairs[:, 0]]
    T, n_corr, rms = _iterate(source, target, pairs, T0, depth_weight, src, trees, p, sgn)
    basin = _basin(source, target, pairs, T0, T, depth_weight, src, trees, p, sgn)
    n_checked, share, spread, verdict, local, res, mom = _check(
        source, target, pairs, T, src, trees, p, cos_tol
    )
    return PaneICPResult(
        T_target_source=T,
        n_correspondences=n_corr,
        rms_m=rms,
        n_checked=n_checked,
        share_on_surface=share,
        spread=spread,
        verdict=verdict,
        local=local,
        residual_rms_m=res,
        normal_moment=mom,
        basin_m=basin,
    )


def minimum_spread(
    source: list[Opening],
    target: list[Opening],
    pairs: NDArray[np.int_],
    T0: Array,
    T: Array,
    depth_weight: Array,
    params: PaneICPParams | None = None,
    *,
    opposite_sides: bool = True,
    trees: list[cKDTree | None] | None = None,
    directions: Array | None = None,
) -> float:
    """Spread of the minima from starts displaced from ``T0`` about the solution ``T``.

    The same steps as :func:`refine_on_recesses` from starts ``T0`` moved by
    ``restart_m`` both ways along each of ``directions`` (unit vectors, rows; default
    the three axes: six starts); returns the largest RMS distance over the matched
    pane centres between their minima and ``T`` (the caller may compute it only for a
    solution it would otherwise take: two refinements per direction).
    """
    p = params or PaneICPParams()
    trees = trees if trees is not None else recess_trees(target)
    src = [_subsample(source[i], p.max_points) for i in pairs[:, 0]]
    sgn = -1.0 if opposite_sides else 1.0
    return _basin(source, target, pairs, T0, T, depth_weight, src, trees, p, sgn, directions)


def motion_moment(
    source: list[Opening],
    target: list[Opening],
    pairs: NDArray[np.int_],
    T: Array,
    centre: Array,
    lever_m: float,
    params: PaneICPParams | None = None,
    *,
    trees: list[cKDTree | None] | None = None,
) -> Array:
    """Moment of the rigid motions that the matched openings' reveal points fix.

    Per opening, the mean of ``a a^T`` over its source points lying on the partner's
    surfaces under ``T`` (the points of the check of :func:`refine_on_recesses`), with
    ``a = ((x - centre) x n / lever_m, n)``: ``x`` a mapped source point, ``n`` its
    partner point's normal.  A motion ``(w, t)`` (turn ``w`` about ``centre``, then
    ``t``) moves ``x`` by ``w x (x - centre) + t``, so in the coordinates
    ``(lever_m w, t)`` (metres at the lever) ``u^T M u`` is the mean squared
    point-to-plane motion that ``u`` gives, summed over the openings: one unit of
    trace of the translation block per opening, as in
    :attr:`PaneICPResult.normal_moment`.

    Parameters
    ----------
    source, target
        Openings of the two clouds (with their recess points).
    pairs
        ``(K, 2)`` openings whose points count (e.g. those verified by their raw points).
    T
        ``T_target_source`` (4x4, local frames).
    centre
        ``(3,)`` centre of the turns, target frame.
    lever_m
        Distance at which a turn is measured, m.
    params
        :class:`PaneICPParams` (``check_gate_m``, ``agree_distance_m``,
        ``normal_agreement_deg``, ``max_points``).
    trees
        :func:`recess_trees` of ``target`` (built when omitted).

    Returns
    -------
    numpy.ndarray
        ``(6, 6)`` symmetric moment; its eigenvector of the smallest eigenvalue is the
        motion the reveal points fix least.
    """
    p = params or PaneICPParams()
    trees = trees if trees is not None else recess_trees(target)
    cos_tol = float(np.cos(np.deg2rad(p.normal_agreement_deg)))
    R, t = T[:3, :3], T[:3, 3]
    M = np.zeros((6, 6))
    for i, j in pairs:  # a few openings
        tree = trees[j]
        src = _subsample(source[i], p.max_points)
        if tree is None or not len(src[0]):
            continue
        x, q, n = _correspond(src, target[j], tree, R, t, p.check_gate_m, cos_tol)
        on = np.abs(np.einsum("ij,ij->i", x - q, n)) < p.agree_distance_m
        if not on.any():
            continue
        a = np.hstack([np.cross(x[on] - centre, n[on]) / lever_m, n[on]])
        M += a.T @ a / len(a)
    return M


def loose_turn(
    source: list[Opening],
    target: list[Opening],
    pairs: NDArray[np.int_],
    T: Array,
    scatter_m: float,
    params: PaneICPParams | None = None,
    *,
    trees: list[cKDTree | None] | None = None,
) -> tuple[float, float]:
    """How far a turn may move the source cloud's openings unseen by the reveals of ``pairs``.

    The turns about the mean of the ``pairs``' mapped source pane centres (their
    translation held: the translations have their own test, see
    :attr:`~pyheracles.registration.pane_matching.MatchParams.min_translation_spread`)
    are measured at the lever, the RMS distance of every source opening's mapped centre
    from that centre (at least 1 m).  The turn block of their :func:`motion_moment`
    counts each opening once (one unit of trace), as one observation whose error is
    ``scatter_m``: a turn moving the lever by ``s`` metres along the eigenvector of the
    smallest eigenvalue ``lam`` moves the reveal points by ``sqrt(lam) s``, so the
    reveals cannot tell apart poses ``scatter_m / sqrt(lam)`` apart there.  A turn
    moving an opening along its own pane normal (its reveals run along it) or turning
    openings about the line through them is seen only by reveal points near its axis.

    Parameters
    ----------
    source, target
        Openings of the two clouds (with their recess points).
    pairs
        ``(K, 2)`` openings whose reveal points count (those verified by them).
    T
        ``T_target_source`` (4x4, local frames).
    scatter_m
        Error of one opening's reveal points, m (e.g. the recess ICP's RMS).
    params
        :class:`PaneICPParams`.
    trees
        :func:`recess_trees` of ``target`` (built when omitted).

    Returns
    -------
    tuple of float
        The loosest turn's motion at the lever (``inf`` when ``pairs`` fix none) and
        the lever, m.
    """
    if not len(pairs):
        return float("inf"), 1.0
    R, t = T[:3, :3], T[:3, 3]
    probes = np.array([o.centre for o in source]) @ R.T + t
    centre = (np.array([source[i].centre for i in pairs[:, 0]]) @ R.T + t).mean(axis=0)
    lever = max(float(np.sqrt(np.mean(np.sum((probes - centre) ** 2, axis=1)))), 1.0)
    M = motion_moment(source, target, pairs, T, centre, lever, params, trees=trees)
    lam = float(np.linalg.eigvalsh(M[:3, :3])[0])
    return (scatter_m / np.sqrt(lam) if lam > 0 else float("inf")), lever


def _basin(
    source, target, pairs, T0, T, depth_weight, src, trees, p: PaneICPParams, sgn,
    directions: Array | None = None,
):  # fmt: skip
    # the same minimum from starts displaced by ``restart_m`` along each direction: a
    # pose that reveals leave free, or a splayed reveal pulling a start aside, converges
    # elsewhere and shows as a spread of the minima
    centres = np.array([source[i].centre for i in pairs[:, 0]])
    ref = centres @ T[:3, :3].T + T[:3, 3]
    basin = 0.0
    axes = np.eye(3) if directions is None else np.atleast_2d(directions)
    for axis in axes if p.restart_m > 0 else ():  # two restarts per direction
        for sign in (-1.0, 1.0):
            Ts = np.asarray(T0, float).copy()
            Ts[:3, 3] += sign * p.restart_m * axis
            Tr, _, _ = _iterate(source, target, pairs, Ts, depth_weight, src, trees, p, sgn)
            d = centres @ Tr[:3, :3].T + Tr[:3, 3] - ref
            basin = max(basin, float(np.sqrt(np.mean(np.sum(d**2, axis=1)))))
    return basin


def _iterate(source, target, pairs, T0, depth_weight, src, trees, p: PaneICPParams, sgn: float):
    """Coarse-to-fine point-to-plane steps from ``T0``: (transform, correspondences, RMS)."""
    cos_tol = float(np.cos(np.deg2rad(p.normal_agreement_deg)))
    T = np.asarray(T0, float).copy()
    n_corr, rms = 0, float("nan")
    for gate in p.gates_m:  # coarse to fine gates
        for _ in range(p.iterations):
            R, t = T[:3, :3], T[:3, 3]
            rows_A, rows_b, rows_w, rows_p = [], [], [], []
            for k, (i, j) in enumerate(pairs):  # tens of openings
                tree = trees[j]
                if tree is not None and len(src[k][0]):
                    x, q, n = _correspond(src[k], target[j], tree, R, t, gate, cos_tol)
                    if len(x):
                        rows_A.append(np.hstack([np.cross(x, n), n]))
                        rows_b.append(-np.einsum("ij,ij->i", x - q, n))
                        rows_w.append(np.ones(len(x)))
                        rows_p.append(np.ones(len(x), bool))
                if depth_weight[k] > 0:  # mapped pane centre on the partner's mid-plane
                    c = R @ source[i].centre + t
                    n = sgn * target[j].normal
                    rows_A.append(np.hstack([np.cross(c, n), n])[None, :])
                    rows_b.append(np.array([-(c - target[j].centre) @ n]))
                    rows_w.append(np.array([float(depth_weight[k])]))
                    rows_p.append(np.zeros(1, bool))
            if not rows_A:
                break
            A, b = np.vstack(rows_A), np.concatenate(rows_b)
            w0 = np.concatenate(rows_w)
            pts = np.concatenate(rows_p)  # point rows (the others: pane depths)
            s = max(1.4826 * float(np.median(np.abs(b[pts]))) if pts.any() else 0.0, p.min_scale_m)
            # the kernel never rejects within the gate: reveals sliding along themselves
            # (jambs under a vertical offset) hold most residuals near 0, and a scale from
            # them alone would reject the sills and heads that fix the offset
            c = max(p.tukey_c * s, gate)
            w = w0 * np.where(np.abs(b) < c, (1 - (b / c) ** 2) ** 2, 0.0)
            # the depth rows: their own Tukey kernel (a pane depth from a sparse glass or
            # a reveal ending short can be off by decimetres)
            cd = p.tukey_c * p.depth_scale_m
            bd = b[~pts]
            w[~pts] = w0[~pts] * np.where(np.abs(bd) < cd, (1 - (bd / cd) ** 2) ** 2, 0.0)
            if np.count_nonzero(w) < 6:
                break
            sw = np.sqrt(w)
            dx, *_ = np.linalg.lstsq(A * sw[:, None], b * sw, rcond=None)
            step = np.eye(4)
            step[:3, :3] = _rotation(dx[:3])
            step[:3, 3] = dx[3:]
            T = step @ T
            n_corr = int(pts.sum())
            rms = float(np.sqrt(np.sum(w[pts] * b[pts] ** 2) / max(w[pts].sum(), 1.0)))
            if np.linalg.norm(dx[:3]) < 1e-7 and np.linalg.norm(dx[3:]) < 1e-5:
                break
    return T, n_corr, rms


def _check(source, target, pairs, T, src, trees, p: PaneICPParams, cos_tol: float):
    """Per matched opening: checked points, share on the partner's surfaces, verdict."""
    R, t = T[:3, :3], T[:3, 3]
    K = len(pairs)
    n_checked = np.zeros(K, int)
    share = np.full(K, np.nan)
    spread = np.zeros(K)
    verdict = np.zeros(K, int)
    local = np.repeat(T[None], K, axis=0)
    res = np.full(K, np.nan)
    mom = np.zeros((K, 3, 3))
    for k, (_i, j) in enumerate(pairs):  # tens of openings
        tree = trees[j]
        if tree is None or not len(src[k][0]):
            continue
        x, q, n = _correspond(src[k], target[j], tree, R, t, p.check_gate_m, cos_tol)
        n_checked[k] = len(x)
        if len(x) < p.min_check_points:
            continue
        r = np.abs(np.einsum("ij,ij->i", x - q, n))
        on = r < p.agree_distance_m
        share[k] = float(on.mean())
        h = target[j].h
        v = np.cross(target[j].normal, h)  # the sign of v does not change the spread
        nn = n[on]
        if len(nn) >= 10:
            nhv = np.column_stack([nn @ h, nn @ v])
            spread[k] = float(np.linalg.eigvalsh(nhv.T @ nhv / len(nhv))[0])
        if share[k] < p.disagree_share:
            verdict[k] = -1
        elif share[k] >= p.agree_share and spread[k] >= p.min_spread:
            verdict[k] = 1
            local[k], res[k] = _local_fit(x[on], q[on], n[on], target[j], T)
            mom[k] = nn.T @ nn / len(nn)
    return n_checked, share, spread, verdict, local, res, mom


def _local_fit(x: Array, q: Array, n: Array, o: Opening, T: Array) -> tuple[Array, float]:
    """In-plane translation and rotation about the pane normal fitted to one opening."""
    nz, h = o.normal, o.h
    v = np.cross(nz, h)
    rel = x - o.centre
    r = np.einsum("ij,ij->i", x - q, n)
    A = np.column_stack([n @ h, n @ v, np.einsum("ij,ij->i", np.cross(nz, rel), n)])
    sol, *_ = np.linalg.lstsq(A, -r, rcond=None)
    L = np.eye(4)
    L[:3, :3] = _rotation(sol[2] * nz)
    L[:3, 3] = o.centre - L[:3, :3] @ o.centre + sol[0] * h + sol[1] * v
    return L @ T, float(np.sqrt(np.mean((r + A @ sol) ** 2)))
