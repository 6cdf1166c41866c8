"""Recess ICP after the pane solution (issue 14): raw reveals decide where outlines cannot.

Church seed 4 (exterior TLS from the ground, windows 7-14 m up) gave exterior outlines
seen in part and shifted 7-16 cm in the glass plane, so every outline hypothesis was
contradicted and the draw refused although the raw reveal points of both clouds agree
to millimetres.  The synthetic arrangement below reproduces that: straight reveals
seen densely from their own side and sparsely through the glass from the other side,
and target outlines shifted by 10 cm in the glass plane.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pyheracles.registration.pane_icp import PaneICPParams, recess_trees, refine_on_recesses
from pyheracles.registration.pane_matching import MatchParams, OpeningMatch, match_openings
from pyheracles.registration.panes import Opening

T_TRUE = np.eye(4)
T_TRUE[:3, :3] = Rotation.from_euler("zyx", [-23.0, 0.4, 0.7], degrees=True).as_matrix()
T_TRUE[:3, 3] = [55.0, 12.0, -1.5]


def _reveal(w: float, hgt: float, z0: float, z1: float, n: int, rng) -> tuple:
    """Points (u, v, z) and in-plane normals of a straight rectangular reveal."""
    per = 2 * (w + hgt)
    s = rng.uniform(0, per, n)
    z = rng.uniform(z0, z1, n)
    u, v = np.zeros(n), np.zeros(n)
    nu, nv = np.zeros(n), np.zeros(n)
    a = s < w  # sill
    u[a], v[a], nv[a] = s[a] - w / 2, -hgt / 2, 1.0
    b = (s >= w) & (s < w + hgt)  # right jamb
    u[b], v[b], nu[b] = w / 2, s[b] - w - hgt / 2, 1.0
    c = (s >= w + hgt) & (s < 2 * w + hgt)  # head
    u[c], v[c], nv[c] = w / 2 - (s[c] - w - hgt), hgt / 2, 1.0
    d = s >= 2 * w + hgt  # left jamb
    u[d], v[d], nu[d] = -w / 2, hgt / 2 - (s[d] - 2 * w - hgt), 1.0
    return u, v, z, nu, nv


def opening_pair(centre, normal, w, hgt, rng, shift_target_m=0.0) -> tuple[Opening, Opening]:
    """One opening seen from inside (source frame) and outside (target frame).

    The source sees its own reveal (depth 0-0.3 m in front of the mid-plane) densely
    and the outer one sparsely through the glass; the target the other way round.  The
    target's outline and centre are shifted by ``shift_target_m`` along ``h`` (a
    partial outline), its raw reveal points are not.
    """
    c = np.asarray(centre, float)
    nz = np.asarray(normal, float)
    h = np.cross([0.0, 0.0, 1.0], nz)
    h /= np.linalg.norm(h)
    v = np.cross(nz, h)

    def cloud(dense: tuple, sparse: tuple):
        parts = [_reveal(w, hgt, *dense, 800, rng), _reveal(w, hgt, *sparse, 200, rng)]
        u, vv, z, nu, nv = (np.concatenate(x) for x in zip(*parts, strict=True))
        xyz = c + np.outer(u, h) + np.outer(vv, v) + np.outer(z, nz)
        return xyz + rng.normal(0, 0.002, xyz.shape), np.outer(nu, h) + np.outer(nv, v)

    rec_s, nrm_s = cloud((0.01, 0.3), (-0.3, -0.01))
    rec_t, nrm_t = cloud((-0.3, -0.01), (0.01, 0.3))
    u, vv, _, nu, nv = _reveal(w, hgt, 0.0, 0.0, 400, rng)
    outline = c + np.outer(u, h) + np.outer(vv, v)
    onrm = np.outer(nu, h) + np.outer(nv, v)
    src = Opening(c, nz, h, v, w, hgt, outline, onrm, 0.2, 100, 0, rec_s, nrm_s)
    R, t = T_TRUE[:3, :3], T_TRUE[:3, 3]
    sh = shift_target_m * h
    tgt = Opening(
        R @ (c + sh) + t, -(R @ nz), R @ h, R @ v, w, hgt, (outline + sh) @ R.T + t,
        onrm @ R.T, 0.2, 100, 0, rec_t @ R.T + t, nrm_t @ R.T,
    )  # fmt: skip
    return src, tgt


def _church(rng, shifts, gable: bool = True) -> tuple[list[Opening], list[Opening]]:
    """Windows on two long walls (and a gable) with their target outline shifts."""
    places = [([k * 3.0, 0.0, 3.0], [0, 1, 0]) for k in range(3)]
    places += [([k * 3.0 + 1.0, 10.0, 3.0], [0, -1, 0]) for k in range(3)]
    if gable:
        places += [([-2.0, 5.0, 3.5], [1, 0, 0])]
    sizes = [(0.9, 2.0), (1.0, 2.2), (0.8, 1.9), (1.1, 2.4), (0.95, 2.1), (0.85, 2.3), (1.2, 2.6)]
    S, Tg = [], []
    for (c, n), (w, hgt), sh in zip(places, sizes, shifts, strict=False):
        a, b = opening_pair(c, n, w, hgt, rng, sh)
        S.append(a)
        Tg.append(b)
    return S, Tg


def _pose_error(T: np.ndarray, S: list[Opening]) -> float:
    c = np.array([o.centre for o in S])
    d = c @ T[:3, :3].T + T[:3, 3] - (c @ T_TRUE[:3, :3].T + T_TRUE[:3, 3])
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def test_recess_icp_converges_from_a_decimetre_off() -> None:
    rng = np.random.default_rng(4)
    S, Tg = _church(rng, [0.0] * 7)
    T0 = T_TRUE.copy()
    T0[:3, 3] += [0.06, -0.05, 0.04]
    T0[:3, :3] = Rotation.from_rotvec([0.0, 0.0, 0.004]).as_matrix() @ T0[:3, :3]
    pairs = np.array([[k, k] for k in range(len(S))])
    r = refine_on_recesses(S, Tg, pairs, T0, np.ones(len(pairs)), trees=recess_trees(Tg))
    assert _pose_error(r.T_target_source, S) < 0.003
    assert np.all(r.verdict == 1)
    assert r.basin_m < 0.002


def test_shifted_outlines_are_rescued_by_the_raw_reveals() -> None:
    """Four of seven target outlines 10 cm off in the glass plane (seed 4's failure)."""
    rng = np.random.default_rng(14)
    shifts = [0.1, 0.0, -0.1, 0.1, 0.0, -0.1, 0.0]
    S, Tg = _church(rng, shifts)
    outlines_only = match_openings(S, Tg, MatchParams(recess_icp=None))
    assert isinstance(outlines_only, str)  # refused: the outlines contradict each other
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, OpeningMatch)
    assert m.method == "recess_icp"
    assert m.n_recess_verified >= 5
    assert _pose_error(m.T_target_source, S) < 0.003
    # the per-opening transforms (tie points) stay on the true pose at their own opening
    for (i, _j), L in zip(m.pairs, m.local, strict=True):
        P = S[i].outline
        d = P @ L[:3, :3].T + L[:3, 3] - (P @ T_TRUE[:3, :3].T + T_TRUE[:3, 3])
        assert np.sqrt(np.mean(np.sum(d**2, axis=1))) < 0.005


@pytest.mark.parametrize("gable", [False])
def test_reveals_of_one_wall_direction_do_not_decide(gable: bool) -> None:
    """Straight reveals on two parallel walls leave the depth along their normal to the
    pane depths, which never decide alone (even when, as here, they agree): the recess
    solution is not taken, and with shifted outlines nothing is returned."""
    rng = np.random.default_rng(7)
    S, Tg = _church(rng, [0.1, 0.0, -0.1, 0.1, 0.0, -0.1], gable=gable)
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, str)
    # the recess ICP itself says why: no reveal normal along the walls' normal
    pairs = np.array([[k, k] for k in range(len(S))])
    r = refine_on_recesses(S, Tg, pairs, T_TRUE, np.zeros(len(pairs)), PaneICPParams())
    moment = r.normal_moment[r.verdict == 1].sum(axis=0)
    assert np.linalg.eigvalsh(moment)[0] < 0.01


def _sparse(o: Opening, n: int, rng, depth_m: float = 0.0) -> Opening:
    """``o`` with ``n`` raw recess points (too few for a verdict of their own) and its
    pane depth taken where a reveal ends ``depth_m`` short of the glass (centre and
    outline moved towards its viewer)."""
    r = rng.choice(len(o.recess), n, replace=False)
    off = depth_m * o.normal
    return replace(
        o,
        centre=o.centre + off,
        outline=o.outline + off,
        recess=o.recess[r],
        recess_normal=o.recess_normal[r],
    )


def test_sparse_reveals_of_another_wall_hold_what_parallel_reveals_leave_free() -> None:
    """Church draw 46 (exterior TLS, 8 stations): the openings verified by their raw
    points lie on the two long walls and leave the depth along their normal free; a
    gable window too sparse for a verdict of its own (30 points a side) still holds it
    through its jambs, which the test of the moment alone ignored: refused.  Three long-wall
    openings, as sparse, took their pane depth where a reveal ends 12-20 cm short; their
    outlines, compared in 3D, counted as contradictions: they are compared in the pane
    plane, the depth being the raw reveals' to fix."""
    rng = np.random.default_rng(7)
    S, Tg = _church(rng, [0.1, 0.0, -0.1, 0.1, 0.0, -0.1, 0.0])
    S[6], Tg[6] = _sparse(S[6], 30, rng), _sparse(Tg[6], 30, rng)
    for k, d in ((1, 0.12), (3, 0.15), (4, 0.2)):
        Tg[k] = _sparse(Tg[k], 20, rng, depth_m=d)
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, OpeningMatch)
    assert m.method == "recess_icp"
    assert _pose_error(m.T_target_source, S) < 0.003
    # the moment of the verified openings alone leaves the depth free: refused
    alone = MatchParams(recess_icp=PaneICPParams(restart_m=0.0))
    assert isinstance(match_openings(S, Tg, alone), str)


def test_depth_rows_are_robust() -> None:
    """One pane depth off by 17 cm (seed 4, opening 1) does not pull the solution."""
    rng = np.random.default_rng(5)
    S, Tg = _church(rng, [0.0] * 7)
    Tg[1] = replace(Tg[1], centre=Tg[1].centre + 0.17 * Tg[1].normal)
    pairs = np.array([[k, k] for k in range(len(S))])
    r = refine_on_recesses(S, Tg, pairs, T_TRUE, np.full(len(pairs), 30.0))
    assert _pose_error(r.T_target_source, S) < 0.002


def _seen_from_far_below(o: Opening, rng, shift_m: float) -> Opening:
    """``o`` seen sparsely from far below: 60 outline points, partial and derived from
    grazing reveals, sitting ``shift_m`` off diagonally in the glass plane, and too few
    raw recess points (20) for a verdict of their own."""
    k = rng.choice(len(o.outline), 60, replace=False)
    off = shift_m * (o.h + o.v) / np.sqrt(2)
    r = rng.choice(len(o.recess), 20, replace=False)
    return replace(
        o,
        outline=o.outline[k] + off + rng.normal(0, 0.004, (60, 3)),
        outline_normal=o.outline_normal[k],
        recess=o.recess[r],
        recess_normal=o.recess_normal[r],
    )


def test_sparse_outlines_do_not_contradict_a_pose_fixed_by_reveals() -> None:
    """Church draw 4: exterior openings 7-14 m up seen by a few points, their outlines
    centimetres off, counted as contradictions of the true pose, which the other
    openings' reveals fix: the draw was refused."""
    rng = np.random.default_rng(4)
    S, Tg = _church(rng, [0.0] * 7)
    for k in (0, 2, 4):
        Tg[k] = _seen_from_far_below(Tg[k], rng, shift_m=0.06)
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, OpeningMatch)
    assert m.method == "recess_icp"
    assert _pose_error(m.T_target_source, S) < 0.003
    # the strict test alone (no coarse comparison) loses the true pose: here it even
    # returns a one-bay turn 3 m off, verified by three outlines
    strict = match_openings(S, Tg, MatchParams(coarse_gate_m=0.0))
    assert isinstance(strict, str) or _pose_error(strict.T_target_source, S) > 0.1


@pytest.mark.parametrize("seed", [1, 2])
def test_centres_decimetres_off_are_searched_again(seed: int) -> None:
    """Church draws 9, 42 and 43: an exterior TLS sees deep reveals from below (sills
    hidden, no glass return): opening centres 0.2-0.5 m off fail the 0.25 m rigid
    invariants and no arrangement is found; searched again with twice the tolerances,
    the raw reveals verify the true pose."""
    rng = np.random.default_rng(seed)
    S, Tg = _church(rng, [0.3, 0.0, -0.3, 0.3, 0.0, -0.3, 0.3])
    assert isinstance(match_openings(S, Tg, MatchParams(retry_tolerance_factor=1.0)), str)
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, OpeningMatch)
    assert m.method == "recess_icp"
    assert _pose_error(m.T_target_source, S) < 0.003


def test_tie_points_of_a_recess_solution_come_from_its_raw_verified_openings() -> None:
    """Church draws 7 and 31: openings verified by their outline alone (too sparse for a
    verdict of their raw points) carried their outline's in-plane fit into the tie points,
    8 mm off here as a partial outline can be; the similarity ended 6.8 and 8.1 mm off
    instead of 4.5 and 6.5 mm.  With enough openings verified by raw points, only those
    give tie points, each on the true pose at its own opening."""
    rng = np.random.default_rng(21)
    S, Tg = _church(rng, [0.0] * 7)
    for k in (1, 4):  # sparse, outline 8 mm off along the wall: agrees (< 1.2 cm)
        Tg[k] = replace(_sparse(Tg[k], 20, rng), outline=Tg[k].outline + 0.008 * Tg[k].h)
    m = match_openings(S, Tg, MatchParams())
    assert isinstance(m, OpeningMatch) and m.method == "recess_icp"
    assert m.n_recess_verified >= 3 and len(m.pairs) == m.n_recess_verified
    assert not set(m.pairs[:, 1]) & {1, 4}
    for (i, _j), L in zip(m.pairs, m.local, strict=True):
        P = S[i].outline
        d = P @ L[:3, :3].T + L[:3, 3] - (P @ T_TRUE[:3, :3].T + T_TRUE[:3, 3])
        assert np.sqrt(np.mean(np.sum(d**2, axis=1))) < 0.003
