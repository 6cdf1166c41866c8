"""Step 1 on sparse airborne surveys and under crowns (issue 17, complex-family draws).

Built from the draws where trees were the largest source of error: at 0.1-0.4 points/m^2
a 3-spacing buffer (5-7 m) took the crowns and clutter around small buildings and walls
(draw 5, walls' median F1 0.79); small buildings of 10-15 points got no object (draw 9);
crowns over roofs joined the roofs through their scattered points (draw 18, 805 of 4737
tree points in objects), up to 3 spacings above small roofs (draw 26); on AHN3 tile 1 the
eave returns of roofs must stay with them.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pyheracles import InputError, PointCloud
from pyheracles.complex import ComplexParams, prepare_layers, resolve_params, segment_complex
from pyheracles.complex.clusters import porous_points, vote_scattered
from pyheracles.evaluate import evaluate_by_feature
from test_complex_eaves import ahn3_and_bgt, building_labels


@cache
def _draw(seed: int):
    """A draw of the complex family and its cloud as step 1 reads it (with the echoes)."""
    from pyheracles.synthetic.families import simulate

    sim = simulate("complex", seed)
    res = sim.clouds["cloud"]
    attrs = {"return_number": res.return_number, "number_of_returns": res.number_of_returns}
    cloud = PointCloud(xyz=res.xyz, offset=np.asarray(sim.offset), crs=sim.crs, attributes=attrs)
    return sim, cloud, prepare_layers(sim.extras["layers"], cloud)


def run_complex_draw(seed: int, params: ComplexParams | None = None):
    """Step 1 on a draw: (tree points put into objects, F1 per feature of 10 points or more)."""
    sim, cloud, layers = _draw(seed)
    seg = segment_complex(cloud, layers, params).segmentation
    res = sim.clouds["cloud"]
    tree = res.class_id == sim.scene.class_code("tree")
    ref = sim.extras["reference_objects"]
    table = evaluate_by_feature(seg.instance, seg.objects, res.instance, ref).objects
    table = table[table["n_reference"] >= 10]  # as the benchmark scores them
    f1 = dict(zip(table["key"], table["f1"].fillna(0.0), strict=True))
    return int((tree & (seg.instance > 0)).sum()), f1


def test_buffer_does_not_grow_with_the_spacing() -> None:
    """Draw 5 (0.11 points/m^2, spacing 2.5 m): a 7.6 m buffer put 87 of 508 tree points
    into objects and its walls scored F1 0.51-0.88 (median 0.68); 1 m leaves crowns out."""
    assert resolve_params(ComplexParams(), 2.53).buffer_m == 1.0
    assert resolve_params(ComplexParams(), 0.05).buffer_m == 1.0
    taken, f1 = run_complex_draw(5)
    assert taken <= 40
    walls = [v for k, v in f1.items() if k.startswith("wall/")]
    assert np.median(walls) >= 0.85 and np.median(list(f1.values())) >= 0.95


def test_small_buildings_of_a_sparse_survey_get_objects() -> None:
    """Draw 9 (0.16 points/m^2): B19 (10 points, 2 of them on the ground) got no object
    with 10 points required for one; a few points on 1 m^2 are enough."""
    assert resolve_params(ComplexParams(), 1.78).min_cluster_points == 5
    _, f1 = run_complex_draw(9)
    assert f1["building/B19"] >= 0.8 and f1["building/B17"] >= 0.8


def test_echoes_decide_where_the_surface_variation_flags_a_whole_building(monkeypatch) -> None:
    """Draw 9 (0.16 points/m^2): the 12 neighbours of the surface variation span a whole
    pavilion (B06: 13 points, all single returns, platform 1.1 m and roof 4-5.5 m) and
    every point looked scattered: no object.  B32 (15 points under a crown) likewise.
    The points where a pulse ended and that are not amid pass-through returns now make
    the core (F1 0.96 and 0.93; one single return of the crown 5 m over B06's roof joins
    it)."""
    _, f1 = run_complex_draw(9)
    assert f1["building/B06"] >= 0.95 and f1["building/B32"] >= 0.9
    # without the solid points as a core both are lost, as before
    from pyheracles.complex import clusters, segment

    def geometry_only(*args, solid=None, **kwargs):
        return clusters.object_points(*args, **kwargs)

    monkeypatch.setattr(segment, "object_points", geometry_only)
    _, f1 = run_complex_draw(9)
    assert f1["building/B06"] == 0.0 and f1["building/B32"] == 0.0


def test_crowns_over_roofs_stay_out() -> None:
    """Draw 18 (1.8 points/m^2, crowns over a third of the roofs): without the echoes,
    805 tree points joined objects; the porous points held to the roof surface: < 660."""
    taken, f1 = run_complex_draw(18)
    assert taken < 660
    assert np.median(list(f1.values())) >= 0.965


def test_scattered_points_rise_little_above_a_sparse_roof() -> None:
    """Draw 26 (0.39 points/m^2, spacing 1.2 m): scattered points allowed 3 spacings (3.5 m)
    above an object's top put 61 tree points into objects (median F1 0.923); 1 m: 51."""
    taken, f1 = run_complex_draw(26)
    assert taken <= 56
    assert np.median(list(f1.values())) >= 0.94
    with pytest.raises(InputError, match="scatter_above_top_m"):
        ComplexParams(scatter_above_top_m=-0.5)


def test_porous_points_vote() -> None:
    """A crown's last returns lie amid pass-through returns; a lone pass-through point on
    a roof of last returns (an edge) does not make its neighbours porous."""
    rng = np.random.default_rng(0)
    roof = np.column_stack([rng.uniform(0, 10, 800), rng.uniform(0, 10, 800), np.full(800, 5.0)])
    crown = rng.normal([20.0, 5.0, 8.0], 1.5, (400, 3))
    xyz = np.vstack([roof, crown])
    through = np.r_[np.zeros(800, bool), rng.random(400) < 0.7]
    through[::97] = True  # a few edge returns on the roof
    porous = porous_points(xyz, through, 0.5)
    assert porous[800:].mean() > 0.9 and porous[:800].sum() == 0
    assert (porous_points(xyz, through, None) == through).all()
    with pytest.raises(InputError, match="porous_share"):
        ComplexParams(porous_share=0.0)
    with pytest.raises(InputError, match="scatter_rise_m"):
        ComplexParams(scatter_rise_m=-1.0)


def test_ahn3_eave_returns_stay_with_their_roofs(shared_data: Path) -> None:
    """AHN3 tile 1: pass-through returns of eaves (0.3-0.7 m beyond the BGT walls) lie
    amid the roof's last returns.  A vote over 8 points lost 1175 of the reference's
    pass-through points, over 17 points 977."""
    from pyheracles.evaluate import reference_from_polygons

    cloud, layers = ahn3_and_bgt(shared_data)
    seg = segment_complex(cloud, layers, ComplexParams(ground="class")).segmentation
    cls = np.asarray(cloud.attributes["classification"])
    ref = reference_from_polygons(
        cloud.world_xyz()[:, :2], cls == 6, layers["building"], buffer_m=1.0
    )
    rn = np.asarray(cloud.attributes["return_number"])
    through = (rn >= 1) & (rn < np.asarray(cloud.attributes["number_of_returns"]))
    lost = (ref > 0) & (building_labels(seg) != ref) & through
    assert lost.sum() < 1080


def test_smooth_patches_of_a_crown_do_not_chain_it_to_a_roof() -> None:
    """Draw 18 (1.8 points/m^2): a crown 2-9 m over B23's 3 m roof joined it through a
    few of its points that looked flat (F1 0.64, 533-626 tree points in objects); voted
    scattered (most of their 8 nearest are, and they stand over the roof beside them),
    they no longer do.  The crown rule (``crown_rise_m``) is off here, to show the vote
    alone (the floating-cluster test, part of ``outside_above_top_m``, leaves 491 tree
    points out without the vote, 533 before it)."""
    alone = ComplexParams(crown_rise_m=None)
    off, f1_off = run_complex_draw(18, replace(alone, scatter_vote_neighbours=None))
    taken, f1 = run_complex_draw(18, alone)
    assert off > 450 and f1_off["building/B23"] < 0.7
    assert taken < 400 and f1["building/B23"] >= 0.95
    assert np.median(list(f1.values())) >= 0.975


def test_vote_spares_smooth_points_beside_a_roof() -> None:
    """Smooth points amid scattered ones but at or under the roof beside them (a facade
    under its eave) stay smooth; a flat patch over the roof amid scattered points does
    not; a vote that would take most of the smooth points inside is dropped."""
    rng = np.random.default_rng(1)
    roof = np.column_stack([rng.uniform(0, 10, 400), rng.uniform(0, 10, 400), np.full(400, 5.0)])
    crown = rng.normal([5.0, 5.0, 9.0], 1.0, (200, 3))
    patch = np.column_stack([rng.uniform(4.5, 5.5, 6), rng.uniform(4.5, 5.5, 6), np.full(6, 9.0)])
    facade = np.column_stack([np.full(6, 10.2), rng.uniform(4.5, 5.5, 6), rng.uniform(3, 4, 6)])
    eave = rng.normal([10.5, 5.0, 3.5], 0.5, (60, 3))  # scattered points round the facade
    xyz = np.vstack([roof, crown, patch, facade, eave])
    scattered = np.repeat([False, True, False, True], [400, 200, 12, 60])
    inside = np.ones(len(xyz), bool)
    p = resolve_params(ComplexParams(), 0.5)
    flipped = vote_scattered(xyz, scattered, inside, p)
    assert flipped[600:606].all() and not flipped[606:612].any() and not flipped[:400].any()
    lone = np.r_[np.zeros(3, bool), np.ones(9, bool)]  # 3 smooth points amid 9 scattered
    pts = rng.normal(0.0, 1.0, (12, 3))
    assert not vote_scattered(pts, lone, np.ones(12, bool), p).any()
    off = replace(p, scatter_vote_neighbours=None)
    assert not vote_scattered(xyz, scattered, inside, off).any()
    with pytest.raises(InputError, match="scatter_vote_share"):
        ComplexParams(scatter_vote_share=0.0)


def test_nothing_outside_a_polygon_rises_over_its_top() -> None:
    """Draw 5 (0.11 points/m^2, clustering distance 7.6 m): crown points beside wall W03,
    above its top, chained to it from the buffer ring (F1 0.74); outside its polygon no
    point of a feature stands more than 1 m above its top inside.  Since the porosity
    vote counts only neighbours within a crown's radius, most of that crown is porous
    and stays out either way; draw 14 (0.12 points/m^2) still shows the rule: without
    it 13 tree points join objects and B09 scores 0.93, with it 9 and 1.0.  The crown
    rule (``crown_rise_m``, see test_complex_crowns.py) takes most of them out too: it
    is off here, to show this rule alone."""
    alone = ComplexParams(crown_rise_m=None)
    off, _ = run_complex_draw(5, replace(alone, outside_above_top_m=None))
    taken, _ = run_complex_draw(5, alone)
    assert taken < off
    off, f1_off = run_complex_draw(14, replace(alone, outside_above_top_m=None))
    taken, f1 = run_complex_draw(14, alone)
    assert taken < off
    assert f1_off["building/B09"] < 0.95 and f1["building/B09"] >= 0.98
    with pytest.raises(InputError, match="outside_above_top_m"):
        ComplexParams(outside_above_top_m=-1.0)


def test_porosity_is_voted_within_a_crown_on_a_sparse_survey() -> None:
    """At 0.3 points/m^2 the 16 nearest points of a crown's return reach over the whole
    roof under it (4-5 m), and its few pass-through returns were outvoted by the roof's
    last returns: no crown point was porous.  Only neighbours within a crown's radius
    vote; a lone point is judged by its own echo."""
    rng = np.random.default_rng(3)
    roof = np.column_stack([rng.uniform(0, 12, 45), rng.uniform(0, 10, 45), np.full(45, 5.0)])
    crown = rng.normal([3.0, 3.0, 8.5], [0.8, 0.8, 0.5], (6, 3))
    xyz = np.vstack([roof, crown])
    through = np.r_[np.zeros(45, bool), True, True, True, True, False, False]
    porous = porous_points(xyz, through, 0.5)
    assert porous[45:].sum() >= 5  # the crown, its last returns amid its own echoes
    assert porous[:45].sum() == 0  # the roof's last returns, under the crown too
    apart = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    lone = porous_points(apart, np.array([True, False]), 0.5)
    assert lone.tolist() == [True, False]


def test_crown_returns_of_a_sparse_survey_stay_out_of_small_objects() -> None:
    """Draw 2 (0.17 points/m^2): crowns over small buildings and a wall were not porous
    (the vote's 16 neighbours spanned the building), 23 tree points joined objects and
    W08 scored F1 0.74, B07 0.85.  Voting within a crown's radius: 11, F1 0.96 each."""
    taken, f1 = run_complex_draw(2)
    assert taken <= 15
    assert f1["wall/W08"] >= 0.9 and f1["building/B07"] >= 0.9
