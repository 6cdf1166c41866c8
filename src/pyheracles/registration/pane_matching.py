"""Matching the glazed openings of two clouds and least squares on their pane outlines.

Windows all look alike, so a match is decided by the whole arrangement, not by one
window (thesis ch. 3, Murtiyoso 2020):

1. **Candidates** - every pair of openings of compatible size (width and height).
2. **Consistency** - two candidate pairs agree when they keep the rigid invariants:
   the distance between the two pane centres, the angle between the two pane normals,
   and each normal's angle with the baseline (normals point to each cloud's viewer,
   hence opposite between an exterior and an interior view).
3. **Hypotheses** - maximal sets of mutually consistent pairs (greedy cliques, a
   simplified max-clique as in TEASER++), each giving a rigid transform from pane
   centres and normals (Kabsch; a reflection is refused, so a mirrored arrangement
   never passes).
4. **Fine fit** - point-to-line least squares of the pane mid-plane outlines with the
   pane depths, for the best hypotheses; the outlines decide between a true solution
   and a one-bay shift (neighbouring windows differ by centimetres in size or shape).
   An outline seen only in part (a reveal hidden from one viewer) is compared where it
   lies on its partner's; outlines of one size that disagree, or cannot be compared,
   contradict the solution, while a single light of a mullioned window facing the
   whole window does not.  A runner-up explaining nearly as many openings is refused
   as ambiguous.
5. **Recess ICP** - every hypothesis is also refined by point-to-plane ICP on the raw
   recess points of its matched openings (:mod:`~pyheracles.registration.pane_icp`:
   reveals and what each side sees through the glass, correspondences within one
   opening pair only, Tukey kernel).  An opening agrees or disagrees by its raw points
   where they decide, else by its outline; the refined solution replaces the outline
   one when it verifies (at least ``min_openings`` openings agreeing by their raw
   points, or by their outlines for openings of one size; not more contradicted than
   ``max_contradiction``), its minimum is unique (displaced starts converge to it) and
   the agreeing openings' reveals fix all three translations (a derived outline seen
   in part can sit decimetres off in the glass plane; the raw reveals do not), and on
   the fewest openings every turn too (``max_loose_turn_m``).
6. **Tie points** - per matched opening a local in-plane fit of its outline and its
   pane depth gives four outline points (left, right, bottom, top of the mid-plane
   outline) in both frames, for the usual robust similarity and its report.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.registration.opening_match import MatchParams, OpeningMatch
from pyheracles.registration.pane_icp import (
    loose_turn,
    minimum_spread,
    recess_trees,
    refine_on_recesses,
)
from pyheracles.registration.panes import Opening

__all__ = [
    "MatchParams",
    "OpeningMatch",
    "match_openings",
    "rigid_from_openings",
]

Array = NDArray[np.float64]

#: How a failure for two solutions fitting alike begins.
AMBIGUOUS = "ambiguous arrangement"
#: How a failure for a pose its few verified openings leave loose begins.
LOOSE = "loose pose"


def rigid_from_openings(cs: Array, ns: Array, ct: Array, nt: Array, opposite: bool = True) -> Array:
    """Rigid ``T_target_source`` (4x4) from pane centres and viewer normals (Kabsch).

    The normals enter as points one metre in front of each centre; with
    ``opposite`` the target normals are reversed (they point to the other side).
    """
    sgn = -1.0 if opposite else 1.0
    a = np.vstack([cs, cs + ns])
    b = np.vstack([ct, ct + sgn * nt])
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    H = (a - ca).T @ (b - cb)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = cb - R @ ca
    return T


def _reflection_fits_better(
    cs: Array, ns: Array, ct: Array, nt: Array, opposite: bool, up: Array
) -> bool:
    """Whether an improper orthogonal map (a mirror) fits better than a rotation.

    The vertical of both (levelled) clouds enters as one more direction, so that an
    arrangement of panes in one plane cannot be turned over instead of mirrored.
    """
    sgn = -1.0 if opposite else 1.0
    a = np.vstack([cs, cs + ns, cs.mean(axis=0) + up])
    b = np.vstack([ct, ct + sgn * nt, ct.mean(axis=0) + up])
    H = (a - a.mean(axis=0)).T @ (b - b.mean(axis=0))
    U, sv, Vt = np.linalg.svd(H)
    # the best proper and improper fits differ by 2 x the smallest singular value
    return bool(np.linalg.det(Vt.T @ U.T) < 0 and sv[2] > 1e-6 * sv[0])


def _consistency(S: list[Opening], Tg: list[Opening], cand: NDArray, p: MatchParams):
    """Boolean ``(C, C)`` matrix: candidate pairs that keep the rigid invariants."""
    cs = np.array([S[i].centre for i in cand[:, 0]])
    ct = np.array([Tg[j].centre for j in cand[:, 1]])
    ns = np.array([S[i].normal for i in cand[:, 0]])
    nt = np.array([Tg[j].normal for j in cand[:, 1]])
    sgn = -1.0 if p.opposite_sides else 1.0
    bs = cs[None, :, :] - cs[:, None, :]
    bt = ct[None, :, :] - ct[:, None, :]
    ds, dt = np.linalg.norm(bs, axis=2), np.linalg.norm(bt, axis=2)
    ok = np.abs(ds - dt) < p.distance_tolerance_m
    cos_tol = np.sin(np.deg2rad(p.angle_tolerance_deg))
    ok &= np.abs(ns @ ns.T - nt @ nt.T) < cos_tol
    with np.errstate(invalid="ignore", divide="ignore"):
        us = bs / np.maximum(ds, 1e-9)[:, :, None]
        ut = bt / np.maximum(dt, 1e-9)[:, :, None]
    ok &= np.abs(np.einsum("ik,ijk->ij", ns, us) - sgn * np.einsum("ik,ijk->ij", nt, ut)) < cos_tol
    ok &= np.abs(np.einsum("jk,ijk->ij", ns, us) - sgn * np.einsum("jk,ijk->ij", nt, ut)) < cos_tol
    same = (cand[:, 0][:, None] == cand[:, 0][None, :]) | (
        cand[:, 1][:, None] == cand[:, 1][None, :]
    )
    ok &= ~same
    ok &= ds > 0.3  # two lights of one window are too close to fix a rotation
    return ok


def _cliques(A: NDArray[np.bool_], n_seeds: int = 60) -> list[NDArray[np.int_]]:
    """Greedy maximal cliques of ``A`` grown from its best-connected nodes."""
    deg = A.sum(axis=1)
    order = np.argsort(-deg)
    out: list[NDArray[np.int_]] = []
    seen: set[tuple[int, ...]] = set()
    for s in order[:n_seeds]:  # tens of seeds
        clique = [int(s)]
        cand = A[s].copy()
        while cand.any():
            c = np.flatnonzero(cand)
            k = int(c[np.argmax(A[np.ix_(c, c)].sum(axis=1))])
            clique.append(k)
            cand &= A[k]
            cand[k] = False
        key = tuple(sorted(clique))
        if key not in seen:
            seen.add(key)
            out.append(np.array(key))
    out.sort(key=len, reverse=True)
    return out


def _sizes_fit(a: Array, b: Array, p: MatchParams) -> NDArray[np.bool_]:
    """Whether (width, height) pairs ``a`` and ``b`` (broadcast) are of one size."""
    tol = p.size_tolerance_m + p.size_tolerance_rel * np.maximum(a, b)
    return np.all(np.abs(a - b) <= tol, axis=-1)


def _size_compatible(S, Tg, pairs, p: MatchParams) -> NDArray[np.bool_]:
    """Per pair (source, target): whether the two openings are of one size."""
    if len(pairs) == 0:
        return np.zeros(0, bool)
    a = np.array([[S[i].width, S[i].height] for i in pairs[:, 0]])
    b = np.array([[Tg[j].width, Tg[j].height] for j in pairs[:, 1]])
    return _sizes_fit(a, b, p)


def _explained(S, Tg, T, p: MatchParams) -> NDArray[np.int_]:
    """Pairs (source, target) whose centres and normals agree under ``T``."""
    cs = np.array([o.centre for o in S]) @ T[:3, :3].T + T[:3, 3]
    ns = np.array([o.normal for o in S]) @ T[:3, :3].T
    ct = np.array([o.centre for o in Tg])
    nt = np.array([o.normal for o in Tg])
    sgn = -1.0 if p.opposite_sides else 1.0
    d, j = cKDTree(ct).query(cs)
    ok = (d < p.centre_gate_m) & (np.einsum("ij,ij->i", ns, sgn * nt[j]) > 0.95)
    pairs = np.column_stack([np.flatnonzero(ok), j[ok]])
    # one target opening for one source opening: keep the closest
    keep = []
    for jt in np.unique(pairs[:, 1]):  # tens of openings
        rows = np.flatnonzero(pairs[:, 1] == jt)
        keep.append(rows[np.argmin(d[pairs[rows, 0]])])
    return pairs[np.sort(np.array(keep, dtype=int))] if keep else pairs[:0]


def _glass_depths(S, Tg, pairs) -> NDArray[np.bool_]:
    """Per pair: whether its pane depths are of the most certain kind present.

    A depth from glass points on both sides is more certain than one from where a
    reveal ends (a sparse reveal may stop short of the glass); when no pair has glass
    depths on both sides (photogrammetry sees no glass) all depths are alike.
    """
    glass = np.array([S[i].n_glass > 0 and Tg[j].n_glass > 0 for i, j in pairs], dtype=bool)
    return glass if glass.any() else np.ones(len(pairs), dtype=bool)


def _subsample(o: Opening, m: int) -> tuple[Array, Array]:
    step = max(1, len(o.outline) // m)
    return o.outline[::step], o.outline_normal[::step]


def _fine(S, Tg, pairs, T0, p: MatchParams):
    """Point-to-line least squares of the matched outlines plus the pane depths."""
    T = T0.copy()
    src = [_subsample(S[i], p.max_outline_points) for i in pairs[:, 0]]
    trees = [cKDTree(Tg[j].outline) for j in pairs[:, 1]]
    sgn = -1.0 if p.opposite_sides else 1.0
    trusted = _glass_depths(S, Tg, pairs)
    depth_w = np.where(trusted, p.depth_weight, p.reveal_depth_weight)
    for gate in p.fine_gates_m:  # coarse to fine correspondence gates
        for _ in range(6):
            rows_A, rows_b, rows_w = [], [], []
            R, t = T[:3, :3], T[:3, 3]
            for k, (i, j) in enumerate(pairs):  # tens of openings
                P = src[k][0] @ R.T + t
                d, nb = trees[k].query(P, distance_upper_bound=gate)
                ok = np.isfinite(d)
                if ok.sum() >= 5:
                    q = Tg[j].outline[nb[ok]]
                    n = Tg[j].outline_normal[nb[ok]]
                    x = P[ok]
                    rows_A.append(np.hstack([np.cross(x, n), n]))
                    rows_b.append(-np.einsum("ij,ij->i", x - q, n))
                    rows_w.append(np.full(ok.sum(), 1.0))
                # pane depth: the mapped centre on the partner's mid-plane; a depth from
                # where the reveals end (no glass points) is the less certain one
                c = R @ S[i].centre + t
                n = sgn * Tg[j].normal
                rows_A.append(np.hstack([np.cross(c, n), n])[None, :])
                rows_b.append(np.array([-(c - Tg[j].centre) @ n]))
                rows_w.append(np.array([depth_w[k]]))
            if not rows_A:
                break
            A = np.vstack(rows_A)
            b = np.concatenate(rows_b)
            w = np.concatenate(rows_w)
            # Huber weights on the residuals of the current estimate (robust kernel)
            r = np.abs(b)
            s = max(1.4826 * np.median(r), 1e-4)
            w = w * np.minimum(1.0, 1.5 * s / np.maximum(r, 1e-12))
            x, *_ = np.linalg.lstsq(A * w[:, None] ** 0.5, b * w**0.5, rcond=None)
            dR = _rotvec(x[:3])
            Tn = np.eye(4)
            Tn[:3, :3] = dR
            Tn[:3, 3] = x[3:]
            T = Tn @ T
            if np.linalg.norm(x[:3]) < 1e-7 and np.linalg.norm(x[3:]) < 1e-6:
                break
    return T


def _rotvec(w: Array) -> Array:
    th = np.linalg.norm(w)
    if th < 1e-15:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def _agreement(S, Tg, pairs, T, p: MatchParams, in_plane: bool = False):
    """Per pair: median and RMS point-to-line distance of the outline, local transform.

    With ``in_plane`` the mapped source outline is first moved along the partner's
    normal onto its mid-plane: the outlines are compared in the pane plane only, for
    a pose whose depth the raw reveals fix (a pane depth from a reveal ending short
    puts a whole outline decimetres off the partner's mid-plane, which says nothing
    of its place in the plane: church draw 46).

    ``inf``: the outlines cannot be compared (less than ``min_outline_share`` of either
    within the gate);
    ``nan``: the compared part does not fix both in-plane directions (unverified).
    The fourth array says per pair whether the outlines lie within ``coarse_gate_m`` of
    each other (at least ``min_outline_share`` of either).
    """
    sgn = -1.0 if p.opposite_sides else 1.0
    med, rms, local, coarse = [], [], [], []
    R, t = T[:3, :3], T[:3, 3]
    gate = p.fine_gates_m[-1] * 2
    trusted = _glass_depths(S, Tg, pairs)
    for k, (i, j) in enumerate(pairs):  # tens of openings
        P, Pn = _subsample(S[i], p.max_outline_points)
        P = P @ R.T + t
        if in_plane:
            P = P - np.outer((P - Tg[j].centre) @ Tg[j].normal, Tg[j].normal)
        Q = Tg[j].outline
        tree_q, tree_p = cKDTree(Q), cKDTree(P)
        d, nb = tree_q.query(P, distance_upper_bound=gate)
        ok = np.isfinite(d)
        # one outline may be partial (a reveal hidden from that viewer): it must then lie
        # on the other, so the correspondences are taken from the better-covered side
        Qs = Q[:: max(1, len(Q) // p.max_outline_points)]
        d2, nb2 = tree_p.query(Qs, distance_upper_bound=gate)
        ok2 = np.isfinite(d2)
        share, share2 = ok.mean(), ok2.mean()
        if max(share, share2) < p.min_outline_share or max(ok.sum(), ok2.sum()) < 10:
            near = max(
                np.isfinite(tree_q.query(P, distance_upper_bound=p.coarse_gate_m)[0]).mean(),
                np.isfinite(tree_p.query(Qs, distance_upper_bound=p.coarse_gate_m)[0]).mean(),
            )
            med.append(np.inf)
            rms.append(np.inf)
            local.append(T)
            coarse.append(near >= p.min_outline_share)
            continue
        coarse.append(True)
        if share >= share2:
            x_pts, q, n = P[ok], Q[nb[ok]], Tg[j].outline_normal[nb[ok]]
        else:  # target points on the mapped source outline, with its (mapped) normals
            x_pts, q, n = P[nb2[ok2]], Qs[ok2], Pn[nb2[ok2]] @ R.T
        r = np.einsum("ij,ij->i", x_pts - q, n)
        nz = sgn * Tg[j].normal
        h = Tg[j].h
        v = np.cross(nz, h)
        # the compared part must fix both in-plane directions: two jambs alone let the
        # pane slide up and down along them, and agree at any height (unverified)
        nhv = np.column_stack([n @ h, n @ v])
        if np.linalg.eigvalsh(nhv.T @ nhv / len(nhv))[0] < p.min_outline_spread:
            med.append(np.nan)
            rms.append(np.nan)
            local.append(T)
            continue
        # local fit: in-plane translation and rotation about the pane normal + depth
        c = Tg[j].centre
        rel = x_pts - c
        A = np.column_stack([n @ h, n @ v, np.einsum("ij,ij->i", np.cross(nz, rel), n)])
        x, *_ = np.linalg.lstsq(A, -r, rcond=None)
        cm = R @ S[i].centre + t
        # the partner's depth corrects the global one only where it is of the most
        # certain kind present (from glass on both sides when some pair has that)
        dz = -(cm - c) @ nz if trusted[k] else 0.0
        if in_plane and abs(dz) > gate:
            # compared in the plane only: a depth farther off than the 3D comparison
            # would compare is not taken
            dz = 0.0
        r2 = r + A @ x
        med.append(float(np.median(np.abs(r2))))
        rms.append(float(np.sqrt(np.mean(r2**2))))
        L = np.eye(4)
        L[:3, :3] = _rotvec(x[2] * nz)
        L[:3, 3] = c - L[:3, :3] @ c + x[0] * h + x[1] * v + dz * nz
        local.append(L @ T)
    return (
        np.array(med),
        np.array(rms),
        np.array(local).reshape(-1, 4, 4),
        np.array(coarse, dtype=bool),
    )


def match_openings(
    source: list[Opening], target: list[Opening], params: MatchParams | None = None
) -> OpeningMatch | str:
    """Match the openings of two clouds; a failure is returned as its reason (a string).

    When no trustworthy match is found (for another reason than an ambiguous
    arrangement), the arrangement is searched once more with the centre tolerances
    (``distance_tolerance_m``, ``centre_gate_m``) multiplied by
    ``retry_tolerance_factor``; a solution of that search is taken only when the raw
    recess points verify it (``method == "recess_icp"``).

    Returns
    -------
    OpeningMatch or str
        The match, or a one-line reason why no trustworthy match exists (too few
        consistent openings, or an ambiguous arrangement such as a one-bay shift).
    """
    p = params or MatchParams()
    first = _match(source, target, p)
    if (
        not isinstance(first, str)
        or first.startswith((AMBIGUOUS, LOOSE))  # a looser search must not pick another
        or p.retry_tolerance_factor <= 1
        or p.recess_icp is None
    ):
        return first
    f = p.retry_tolerance_factor
    loose = replace(
        p, distance_tolerance_m=f * p.distance_tolerance_m, centre_gate_m=f * p.centre_gate_m
    )
    again = _match(source, target, loose)
    if isinstance(again, OpeningMatch) and again.method == "recess_icp":
        return again
    return first


def _match(source: list[Opening], target: list[Opening], p: MatchParams) -> OpeningMatch | str:
    """One search of :func:`match_openings` with the tolerances of ``p``."""
    if min(len(source), len(target)) < p.min_openings:
        return f"{len(source)} and {len(target)} openings: at least {p.min_openings} needed"
    ws = np.array([[o.width, o.height] for o in source])
    wt = np.array([[o.width, o.height] for o in target])
    ok = _sizes_fit(ws[:, None, :], wt[None, :, :], p)
    cand = np.argwhere(ok)
    if len(cand) < p.min_openings:
        return f"only {len(cand)} pairs of openings of compatible size"
    A = _consistency(source, target, cand, p)
    cliques = [c for c in _cliques(A) if len(c) >= p.min_openings]
    if not cliques:
        return f"no {p.min_openings} openings in a consistent arrangement ({len(cand)} candidates)"
    results = []
    trees = None
    tried: list[Array] = []
    n_contradicted = 0
    n_mirrored = 0
    best_good = 0
    cbar = np.mean([o.centre for o in source], axis=0)
    up = np.asarray(p.up, float) / np.linalg.norm(p.up)
    cos_tilt = np.cos(np.deg2rad(p.max_tilt_deg))
    for cl in cliques:  # best cliques first, distinct transforms only
        if len(tried) >= p.hypotheses and (results or len(tried) >= 5 * p.hypotheses):
            break  # enough solutions compared (or nothing after many tries)
        pr = cand[cl]
        cs = np.array([source[i].centre for i in pr[:, 0]])
        ns = np.array([source[i].normal for i in pr[:, 0]])
        ct = np.array([target[j].centre for j in pr[:, 1]])
        nt = np.array([target[j].normal for j in pr[:, 1]])
        if _reflection_fits_better(cs, ns, ct, nt, p.opposite_sides, up):
            n_mirrored += 1  # the arrangement is the mirror image: no rotation maps it
            continue
        T0 = rigid_from_openings(cs, ns, ct, nt, p.opposite_sides)
        if T0[:3, :3] @ up @ up < cos_tilt:  # turned over: not a levelled pair of clouds
            continue
        if any(_same_pose(T0, Tk, cbar) for Tk in tried):
            continue
        tried.append(T0)
        pairs = _explained(source, target, T0, p)
        if len(pairs) < p.min_openings:
            continue
        T = _fine(source, target, pairs, T0, p)
        pairs = _explained(source, target, T, p)
        if len(pairs) < p.min_openings:  # the fine fit left the arrangement
            continue
        T = _fine(source, target, pairs, T, p)
        if any(_same_pose(T, r[1], cbar, tol_m=0.02) for r in results):
            continue  # another clique of a solution already found
        med, rms, local, _ = _agreement(source, target, pairs, T, p)
        good = med < p.fine_tolerance_m
        # openings mapped onto a partner whose outline disagrees contradict the solution
        # (a mirrored or shifted arrangement lands windows on windows of another size);
        # outlines too different to be compared contradict it only when the two openings
        # are of one size (otherwise one cloud may hold a single light of a mullioned
        # window the other sees whole: not a contradiction, nor a tie)
        sizes_agree = _size_compatible(source, target, pairs, p)
        bad = int((np.isfinite(med) & ~good).sum() + (np.isinf(med) & sizes_agree).sum())
        # evidence: agreeing outlines of openings of one size; an agreeing outline of
        # another size (one light of a mullioned window against the whole window, an
        # outline seen in part) fixes the pose only in part and may slide along its
        # partner: it adds tie points but does not count towards ``min_openings``
        n_verified = int((good & sizes_agree).sum())
        outline_ok = bad <= p.max_contradiction * good.sum() and n_verified >= p.min_openings
        rec = None
        if p.recess_icp is not None:
            if trees is None:
                trees = recess_trees(target)
            rec = _recess_candidate(source, target, pairs, T, p, trees)
        if rec is not None and rec[0] >= p.min_openings:
            best_good = max(best_good, rec[0])
            results.append((*rec[1:], len(cl)))
            continue
        if bad > p.max_contradiction * good.sum():
            n_contradicted += 1
            continue
        best_good = max(best_good, n_verified)
        if not outline_ok:
            continue
        extras = {
            "method": "outlines",
            "n_recess_verified": 0,
            "recess_rms_m": float("nan"),
            "recess_basin_m": float("nan"),
        }
        results.append(
            (int(good.sum()), T, pairs[good], rms[good], local[good], bad, extras, len(cl))
        )
    if not results and best_good > 0:
        return (
            f"only {best_good} openings of one size whose outlines agree "
            f"(at least {p.min_openings} needed)"
        )
    if not results:
        return (
            f"no hypothesis explains enough openings ({n_mirrored} mirrored, "
            f"{n_contradicted} contradicted by outlines of another size)"
        )
    results.sort(key=lambda r: -r[0])
    best = results[0]
    runner = max((r[0] for r in results[1:] if not _same_pose(r[1], best[1], cbar)), default=0)
    if best[0] < p.min_openings:
        return f"only {best[0]} openings whose outlines agree (of {len(best[2])} matched)"
    if best[6]["method"] == "outlines" and best[0] < p.min_outline_openings:
        return (
            f"only {best[0]} openings whose outlines agree and no raw reveal points verify "
            f"them (at least {p.min_outline_openings} outlines needed without them)"
        )
    if runner >= p.min_openings and runner >= p.ambiguity_ratio * best[0]:
        return (
            f"{AMBIGUOUS}: two different solutions explain {best[0]} and "
            f"{runner} openings (repeated bays or a mirrored building)"
        )
    extras = dict(best[6])
    if extras.pop("loose", ""):  # the best solution, but its openings do not fix it
        return best[6]["loose"]
    return OpeningMatch(
        T_target_source=best[1],
        pairs=best[2],
        outline_rms=best[3],
        local=best[4],
        n_candidates=len(cand),
        n_consistent=best[7],
        runner_up=runner,
        n_contradicted=best[5],
        n_mirrored=n_mirrored,
        **extras,
    )


def _recess_candidate(S, Tg, pairs, T, p: MatchParams, trees):
    """A hypothesis refined on the raw recess points, judged opening by opening.

    Returns ``None`` when the refinement leaves the arrangement or does not verify;
    else ``(n_verified, n_good, T, pairs, rms, local, bad, extras)``, ``extras["loose"]``
    the one-line reason (beginning with :data:`LOOSE`) when its tie points come from
    ``min_openings`` openings whose reveals leave a turn loose (``max_loose_turn_m``):
    it still competes, and is refused only if it wins.  An opening's verdict comes
    from its raw points where they decide, else from its outline under the refined
    transform; the solution is refused when more openings contradict it
    than ``max_contradiction`` x those that agree, or when the openings verified by
    their raw points do not fix all three translations.
    """
    pi = p.recess_icp
    assert pi is not None
    if all(trees[j] is None or len(S[i].recess) == 0 for i, j in pairs):
        return None  # no recess points kept: outlines only

    fast = replace(pi, restart_m=0.0)  # restarts only for a solution otherwise taken

    def refine(pr, T0):
        dw = np.full(len(pr), p.recess_depth_weight)
        return refine_on_recesses(
            S, Tg, pr, T0, dw, fast, opposite_sides=p.opposite_sides, trees=trees
        )

    start = T
    r = refine(pairs, start)
    for _ in range(2):  # re-explain with the refined pose, refine again if pairs changed
        new = _explained(S, Tg, r.T_target_source, p)
        if len(new) < p.min_openings:
            return None
        if len(new) == len(pairs) and bool(np.all(new == pairs)):
            break
        pairs, start = new, r.T_target_source
        r = refine(pairs, start)
    else:
        return None  # the arrangement does not settle
    T = r.T_target_source
    med, rms, local, coarse = _agreement(S, Tg, pairs, T, p, in_plane=True)
    sizes = _size_compatible(S, Tg, pairs, p)
    o_good = med < p.fine_tolerance_m
    # with the pose fixed by raw reveal points, outlines that cannot be compared finely
    # but lie within ``coarse_gate_m`` of each other are a sparse, partial view, not a
    # contradiction (the outline-only solutions keep the strict test)
    o_bad = (np.isfinite(med) & ~o_good) | (np.isinf(med) & sizes & ~coarse)
    v = r.verdict
    good = (v == 1) | ((v == 0) & o_good)
    bad = int(((v == -1) | ((v == 0) & o_bad)).sum())
    if bad > p.max_contradiction * good.sum():
        return None
    raw = v == 1
    moment = r.normal_moment[v == 1].sum(axis=0)  # one unit of trace per opening
    ev, evec = np.linalg.eigh(moment)
    if ev[0] < p.min_translation_spread and not _held_by_reveals(
        S, Tg, pairs, T, evec[:, 0], p, trees
    ):
        return None  # the raw points leave a translation free: outlines only
    # evidence: openings whose raw points agree and fix both in-plane directions (their
    # detected sizes may differ: an outline seen in part measures short), and agreeing
    # outlines of openings of one size
    n_verified = int(((v == 1) | (good & sizes)).sum())
    if n_verified < p.min_openings:
        return None
    basin = minimum_spread(
        S,
        Tg,
        pairs,
        start,
        T,
        np.full(len(pairs), p.recess_depth_weight),
        pi,
        opposite_sides=p.opposite_sides,
        trees=trees,
    )
    if basin > p.max_basin_m:
        return None  # several minima: the raw points do not decide the pose
    loc = np.where((v == 1)[:, None, None], r.local, local)
    res = np.where(v == 1, r.residual_rms_m, rms)
    extras = {
        "method": "recess_icp",
        "n_recess_verified": int(raw.sum()),
        "recess_rms_m": float(r.rms_m),
        "recess_basin_m": basin,
    }
    # tie points from the openings verified by their raw points when there are enough:
    # an opening verified by its outline alone would carry that outline's in-plane fit
    # (a derived, partial outline: the reason for this refinement) into the similarity
    # (church draws 7 and 31, refined poses 3.6 and 5.8 mm off at the panes: the
    # similarity ended 6.8 and 8.1 mm off with them, 4.5 and 6.5 mm without)
    ties = raw if raw.sum() >= p.min_openings else good
    if ties.sum() == p.min_openings:  # resting on the fewest openings: is every turn fixed?
        loose, lever = loose_turn(S, Tg, pairs[raw], T, r.rms_m, pi, trees=trees)
        if loose > p.max_loose_turn_m:
            extras["loose"] = (
                f"{LOOSE}: the {raw.sum()} openings verified by their reveals fix it only "
                f"to {loose * 100:.1f} cm {lever:.0f} m from them "
                f"({p.max_loose_turn_m * 100:.1f} cm needed)"
            )
    return n_verified, int(good.sum()), T, pairs[ties], res[ties], loc[ties], bad, extras


def _held_by_reveals(S, Tg, pairs, T, direction: Array, p: MatchParams, trees) -> bool:
    """Whether the raw recess points alone bring the pose back along ``direction``.

    The recess ICP without pane-depth rows is started from ``T`` moved by the recess
    ICP's ``restart_m`` along ``direction`` (one way, then the other;
    :func:`~pyheracles.registration.pane_icp.minimum_spread`); the pose is held when
    both minima lie within ``max_basin_m`` of ``T`` (RMS over the matched pane
    centres).  A direction that no reveal constrains leaves a start where it is.
    """
    pi = p.recess_icp
    assert pi is not None
    if pi.restart_m <= 0:
        return False
    spread = minimum_spread(
        S, Tg, pairs, T, T, np.zeros(len(pairs)), pi, opposite_sides=p.opposite_sides,
        trees=trees, directions=direction,
    )  # fmt: skip
    return spread <= p.max_basin_m


def _same_pose(
    Ta: Array, Tb: Array, centre: Array, tol_m: float = 0.1, extent_m: float = 10.0
) -> bool:
    """Two transforms agree within ``tol_m`` over ``extent_m`` around ``centre``."""
    D = Ta[:3, :3] @ Tb[:3, :3].T
    ang = np.arccos(np.clip((np.trace(D) - 1) / 2, -1, 1))
    move = (Ta[:3, :3] - Tb[:3, :3]) @ centre + Ta[:3, 3] - Tb[:3, 3]
    return bool(np.linalg.norm(move) + ang * extent_m < tol_m)
