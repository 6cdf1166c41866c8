"""A support's own extent at its ends, on draws of the supports scene family (issue 12,
step 2a, failure modes 5 and 6): what stands on a column over its own plan (a vault
springing from its top, a girder across it) is not the column; a plinth or an abacus
whose horizontal face was not scanned is.  Each mechanism rebuilt on a small synthetic
room with the dimensions of the draw that showed it."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, detect_supports
from pyheracles.supports.profile import head_cut
from test_supports_clutter import grid, tube


def square_sides(centre, half: float, z0: float, z1: float, step: float) -> np.ndarray:
    """Points on the four vertical faces of a square block (no top, no bottom face)."""
    cx, cy = centre
    out = []
    for s in (-1.0, 1.0):
        uz = grid(-half, half, z0, z1, step)
        out.append(np.c_[np.full(len(uz), cx + s * half), cy + uz[:, 0], uz[:, 1]])
        out.append(np.c_[cx + uz[:, 0], np.full(len(uz), cy + s * half), uz[:, 1]])
    return np.vstack(out)


@pytest.mark.slow
def test_vault_springing_from_column_tops_is_not_the_columns() -> None:
    """Draw 15 of the supports family (a portico of 0.19 m columns 3.14 m tall with abaci,
    under groin vaults springing from their tops, rise 1.2 m): the vault rises 0.9 m over
    a column's own plan before it reaches the ring around its cookie, where the carried
    surface was found, so 30 % of each column's points were vault (median F1 0.81, the
    draw's only failure).  Points well inside the outline of the layers below, over the
    section, in layer after layer, mark the top."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 15)
    res = sim.clouds["cloud"]
    seg, found, _, _ = segment_building(res.xyz)
    m = score_supports(
        sim, found.instance, found.objects, section_height=found.section_height,
        attic_mask=seg.class_id == 2,
    )  # fmt: skip
    assert m["count_exact"] and m["class_all_right"]
    assert m["median_f1"] >= 0.95
    vault = np.isin(res.part, [k for k, v in sim.scene.part_names.items() if v == "vault"])
    # the vault's share of the supports' points: 11 % left (the vault of two columns in
    # the ring above their tops) from more than twice that
    assert np.count_nonzero(vault & (found.instance > 0)) < 0.15 * np.count_nonzero(found.instance)


def test_outliers_inside_a_shaft_do_not_end_it() -> None:
    """Draw 13: a cluster of outliers inside a 0.27 m column at 2.35-2.55 m (points well
    inside the shaft in 5 of 15 sectors) is no carried surface: the shaft's own surface
    goes on all round it: no top is found there."""
    rng = np.random.default_rng(13)
    r, step = 0.27, 0.03
    col = tube((0.0, 0.0), r, 0.0, 3.86, step)
    col += rng.normal(0, 0.003, col.shape)
    blob = rng.normal(0, 0.04, (40, 3)) + [0.12, 0.0, 2.45]
    pts = np.vstack([col, blob])
    rho = np.hypot(pts[:, 0], pts[:, 1]) - r
    ang = np.arctan2(pts[:, 1], pts[:, 0])
    assert head_cut(rho, ang, pts[:, 2], 1.0, 4.41, 0.066, 26, 0.044) == np.inf


def test_plinth_and_abacus_cut_off_by_unseen_faces_stay_with_the_column() -> None:
    """Draw 23 (a kiosk of 0.83-0.99 m columns on square plinths 2.2 m half wide and 0.4 m
    tall, abaci above, photogrammetry that saw neither the plinth's top face nor the
    abacus's underside): the plinth's sides stand 1.4 m out of the shaft, further than
    the final clustering's gap, and were left out with the abacus (12-17 % of each
    column's points).  Pieces going on from a support's foot or head, made of upright
    faces standing round it, are its own."""
    rng = np.random.default_rng(23)
    step, r, top = 0.04, 0.83, 8.0
    cols = [(4.0, 4.0), (10.0, 4.0)]
    floor = grid(-1.0, 15.0, -1.0, 9.0, step)
    under = [np.max(np.abs(floor - c), axis=1) < 1.9 for c in cols]  # hidden: no points
    ceiling = floor[~np.any([np.max(np.abs(floor - c), axis=1) < 1.3 for c in cols], axis=0)]
    floor = floor[~np.any(under, axis=0)]
    room = [np.c_[floor, np.zeros(len(floor))], np.c_[ceiling, np.full(len(ceiling), top)]]
    for c in cols:
        room += [
            square_sides(c, 1.9, 0.0, 0.4, step),  # plinth, no top face
            tube(c, r, 0.4, top - 0.3, step),
            square_sides(c, 1.3, top - 0.3, top, step),  # abacus, no underside
        ]
    xyz = np.vstack(room)
    xyz += rng.normal(0, 0.003, xyz.shape)
    found = detect_supports(xyz, SupportParams(section_height_m=4.0))
    assert list(found.objects["class"]) == ["column"] * 2, found.objects
    for c in cols:
        d = np.max(np.abs(xyz[:, :2] - c), axis=1)
        shaft = (np.hypot(*(xyz[:, :2] - c).T) < r + 0.02) & (np.abs(xyz[:, 2] - 4.0) < 1.0)
        k = np.bincount(found.instance[shaft]).argmax()
        assert k > 0
        plinth = (np.abs(d - 1.9) < 0.01) & (xyz[:, 2] > 0.06) & (xyz[:, 2] < 0.4)
        abacus = (np.abs(d - 1.3) < 0.01) & (xyz[:, 2] > top - 0.3) & (xyz[:, 2] < top - 0.06)
        assert np.mean(found.instance[plinth] == k) > 0.9
        assert np.mean(found.instance[abacus] == k) > 0.9
        assert not found.instance[(xyz[:, 2] < 0.005) & (d > 2.0)].any()  # the floor stays


@pytest.mark.xfail(
    strict=True,
    reason=(
        "on the per-ray simulator's noise draw (issue 12/13 open): three supports more "
        "than half tub points, not at most two"
    ),
)
@pytest.mark.slow
def test_pulpit_tub_cut_as_a_pier_is_not_joined_to_its_post() -> None:
    """Draw 24 of the supports family (a kiosk with pulpits): the pieces cut off at a
    column's ends are joined to it, not at a pier's (its plinth and impost stand out of
    it by less than the clustering's gap); joined to the tub of a pulpit cut by the
    section as a pier, its post and lining made two more false piers of clutter."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", 24)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    code = {v: k for k, v in sim.scene.class_names.items()}["clutter"]
    inst = found.instance[~res.outlier]
    clutter = np.bincount(inst, weights=res.class_id[~res.outlier] == code)
    share = clutter[1:] / np.maximum(np.bincount(inst)[1:], 1)
    assert np.count_nonzero(share > 0.5) <= 2  # as before the end pieces (4 with them)
