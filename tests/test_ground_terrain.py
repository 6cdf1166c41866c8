"""Ground filter on terrain nobody tuned for (issue 17): each test rebuilds, small, the
terrain-family draw (``benchmarks/bench_ground.py --sweep``) that showed the mechanism."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.ground import extract_ground
from pyheracles.groundfilters import surface
from pyheracles.groundfilters.smrf import (
    SMRFParams,
    joined_patches,
    low_clusters,
    plane_misfit,
    progressive_filter,
    smrf,
)
from pyheracles.groundfilters.surface import inpaint


def _sparse_raster(shape=(220, 220), keep=0.12, seed=0):
    rng = np.random.default_rng(seed)
    rr, cc = np.indices(shape)
    values = 0.02 * rr + 0.01 * cc + np.sin(rr / 15.0) + np.cos(cc / 11.0)
    holed = np.where(rng.random(shape) < keep, values, np.nan)
    return values, holed


def test_inpaint_coarse_to_fine_matches_the_exact_membrane(monkeypatch) -> None:
    # terrain seed 3 (0.16 points/m^2 on 1 m cells: 81 % of the cells empty) took 4 s per
    # sparse LU; the coarse-to-fine path gives the same membrane to a fraction of a mm
    _, holed = _sparse_raster()
    assert np.isnan(holed).sum() > surface.EXACT_MAX_UNKNOWN
    fast = inpaint(holed)
    monkeypatch.setattr(surface, "EXACT_MAX_UNKNOWN", 10**9)
    exact = inpaint(holed)
    assert np.isfinite(fast).all()
    np.testing.assert_allclose(fast, exact, atol=2e-3)


def test_inpaint_cost_follows_the_data_not_the_bounding_box(monkeypatch) -> None:
    # tiles on a diagonal: the bounding box is mostly empty; only a band near the data is
    # solved at full resolution
    tile = np.add.outer(np.arange(40.0), np.arange(40.0)) * 0.05
    raster = np.full((320, 320), np.nan)
    for k in range(8):
        raster[40 * k : 40 * k + 40, 40 * k : 40 * k + 40] = tile + k
    solved: list[int] = []
    original = surface._solve_band_cells

    def spy(values, at):
        solved.append(int(at.size))
        return original(values, at)

    monkeypatch.setattr(surface, "_solve_band_cells", spy)
    out = inpaint(raster)
    assert np.isfinite(out).all()
    assert solved and solved[0] < 0.25 * int(np.isnan(raster).sum())
    # known cells untouched, the fill stays within the data's range
    known = np.isfinite(raster)
    np.testing.assert_array_equal(out[known], raster[known])
    assert out.min() >= np.nanmin(raster) - 1e-6 and out.max() <= np.nanmax(raster) + 1e-6


def test_inpaint_coarse_to_fine_reproduces_a_plane_near_the_data() -> None:
    rr, cc = np.indices((200, 200))
    plane = 0.3 * rr - 0.1 * cc + 5.0
    holed = plane.copy()
    holed[20:180, 20:180] = np.nan  # 25 600 unknown cells: the coarse-to-fine path
    out = inpaint(holed)
    near = np.isnan(holed) & (
        (np.abs(rr - 100) >= 70 - surface.INPAINT_BAND_CELLS + 2)
        | (np.abs(cc - 100) >= 70 - surface.INPAINT_BAND_CELLS + 2)
    )
    np.testing.assert_allclose(out[near], plane[near], atol=0.02)
    np.testing.assert_allclose(out, plane, atol=0.1)


def test_progressive_filter_blockwise_matches_the_whole_raster() -> None:
    rng = np.random.default_rng(1)
    surface_m = np.zeros((700, 700))
    active = np.zeros(surface_m.shape, dtype=bool)
    active[:180, :180] = True
    active[500:, 500:] = True
    surface_m[active] = rng.normal(0, 0.05, int(active.sum()))
    surface_m[40:52, 60:75] += 6.0  # a building
    whole = progressive_filter(surface_m, slope=0.15, max_radius=9, cell_m=1.0)
    blocks = progressive_filter(surface_m, slope=0.15, max_radius=9, cell_m=1.0, active=active)
    assert blocks[40:52, 60:75].all()
    assert np.mean(whole[active] == blocks[active]) > 0.999
    # the boxes partition the active cells and cover far less than the bounding box
    from pyheracles.groundfilters.smrf import _active_blocks

    cover = np.zeros(active.shape, dtype=int)
    windows = 0
    for core, window in _active_blocks(active, 20):
        cover[core] += 1
        windows += (window[0].stop - window[0].start) * (window[1].stop - window[1].start)
    assert (cover[active] == 1).all()
    assert windows < 0.4 * active.size


def test_slope_aware_openings_keep_convex_slopes_and_reject_buildings() -> None:
    # terrain seeds 2 / 15 (slopes to 40 deg): convex ground on steep slopes is lowered by
    # every opening by about its slope per cell and flagged with PDAL's slope 0.15
    rr, cc = np.indices((120, 120), dtype=float)
    ridge = np.maximum(0.0, 30.0 - 0.8 * np.abs(cc - 60.0))  # crest, flanks at 0.8
    house = (np.abs(rr - 20) < 7) & (np.abs(cc - 10) < 7)  # 14 m wide, 6 m, on the flat
    terrain = ridge + np.where(house, 6.0, 0.0)
    local = np.full(terrain.shape, 0.8)
    local[:, :20] = 0.0  # the flat part (what terrain_slope_raster measures there)
    flank = (np.abs(cc - 60) < 30) & (np.abs(cc - 60) > 1)
    plain = progressive_filter(terrain, slope=0.15, max_radius=12, cell_m=1.0)
    aware = progressive_filter(
        terrain, slope=0.15, max_radius=12, cell_m=1.0, extra_slope=local, extra_max_radius=12
    )
    assert plain[flank].mean() > aware[flank].mean()
    assert aware[house].all() and plain[house].all()
    # measured local slope: the flanks' slope, not the roof's (near the crest itself the
    # opened, smoothed trend is flatter: a known limit, see the README)
    from pyheracles.groundfilters.smrf import terrain_slope_raster

    measured = terrain_slope_raster(terrain, max_radius=12, cell_m=1.0)
    assert abs(float(np.median(measured[:, 30:37])) - 0.8) < 0.05
    assert float(np.median(measured[10:30, 2:18])) < 0.1


def test_slope_allowance_keeps_only_patches_that_join_the_ground() -> None:
    # ISPRS sample 11 (houses on a steep slope): the slope-aware seed stage with openings
    # to 6 m kept roofs on the slope (total error 8.7 -> 9.2 %); a roof stands on a step
    # along most of its outline, so its patch does not continue the slope's plane
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 100, (12000, 2))
    x, y = xy[:, 0], xy[:, 1]
    z = 40.0 - 0.6 * np.abs(x - 50.0)  # a crest along y, flanks at 0.6
    house = (np.abs(x - 25) < 4) & (np.abs(y - 50) < 4)  # 8 x 8 m on the west flank
    z[house] = 40.0 - 0.6 * 21.0 + 1.0  # flat roof 1 m above its uphill edge
    xyz = np.c_[xy, z]
    crest = np.abs(x - 50) < 6

    def run(**kw):
        return smrf(xyz, SMRFParams(terrain_slope_weight=1.0, terrain_slope_radius_m=6.0, **kw))[0]

    ungated, gated = run(join_share=0.0), run(join_share=0.75)
    published = smrf(xyz, SMRFParams())[0]
    assert ungated[house].mean() > 0.9
    assert gated[house].mean() < 0.1
    assert gated[crest].sum() >= published[crest].sum()
    assert gated[~house].mean() >= published[~house].mean()
    # the object test itself: a patch a step above the ground around it is not kept
    zmin = np.zeros((30, 30))
    zmin[10:20, 10:20] = 3.0
    kept = zmin == 0.0
    fit = plane_misfit(zmin, kept)
    assert not joined_patches(fit, ~kept, 0.5, 0.75).any()
    sloped = np.add.outer(np.zeros(30), 0.5 * np.arange(30.0))
    assert joined_patches(plane_misfit(sloped, kept), ~kept, 0.5, 0.75)[~kept].all()


def test_terrain_rising_to_the_raster_edge_is_not_an_object() -> None:
    # ISPRS sample 23: ground rising at 0.8 to the east edge was rejected over 12 m (19 %
    # of the ground there): beyond the edge the surface is replicated, so an opening of
    # radius r lowers the rising terrain at d cells from the edge by slope * (r - d)
    rng = np.random.default_rng(6)
    xy = rng.uniform(0, 80, (8000, 2))
    x, y = xy[:, 0], xy[:, 1]
    z = 0.6 * np.maximum(0.0, x - 30.0)  # flat, then rising at 0.6 to the east edge
    house = (np.abs(x - 15) < 5) & (np.abs(y - 40) < 5)
    z[house] += 5.0
    xyz = np.c_[xy, z]
    east = x > 60
    published = smrf(xyz, SMRFParams())[0]
    edge = smrf(xyz, SMRFParams(edge_slope_allowance=True, join_share=0.75))[0]
    assert published[east].mean() < 0.9
    assert edge[east].mean() > 0.95
    assert not edge[house].any()
    # the slope measured with the surface continued beyond the edge, not flattened
    from pyheracles.groundfilters.smrf import terrain_slope_raster

    ramp = np.add.outer(np.zeros(60), 0.6 * np.arange(60.0))
    flat_edge = terrain_slope_raster(ramp, max_radius=10, cell_m=1.0)
    continued = terrain_slope_raster(ramp, max_radius=10, cell_m=1.0, extrapolate=True)
    assert float(flat_edge[30, -2]) < 0.3
    assert abs(float(continued[30, -2]) - 0.6) < 0.05


def test_low_outlier_cluster_of_any_size_is_not_ground() -> None:
    # ISPRS: a 6 x 7 m cluster 6 m under the terrain; terrain family: 2-8 m deep clusters
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 80, (12000, 2))
    z = 0.05 * xy[:, 0] + rng.normal(0, 0.03, len(xy))
    cluster = (np.abs(xy[:, 0] - 40) < 3) & (np.abs(xy[:, 1] - 40) < 3.5)
    z[cluster] -= 6.0
    xyz = np.c_[xy, z]
    res = extract_ground(xyz, "auto")
    assert not res.mask[cluster].any()
    assert res.mask[~cluster].mean() > 0.98
    # a real depression with sloping sides is not a cluster
    bowl = np.maximum(0.0, 8.0 - np.hypot(xy[:, 0] - 40, xy[:, 1] - 40)) * 0.5
    cells = np.full((80, 80), 0.0)
    r, c = np.indices(cells.shape)
    cells -= np.maximum(0.0, 8.0 - np.hypot(r - 40, c - 40)) * 0.5
    assert not low_clusters(cells, max_radius=10, drop_m=2.0).any()
    assert bowl.max() > 3.0


def test_sparse_cloud_under_vegetation_keeps_its_ground() -> None:
    # terrain seed 3 of the baseline sweep (0.16 points/m^2, half under trees) returned no
    # ground at all; here 0.1 points/m^2, 60 % in trees: before the fix the note was "the
    # lowest points form lines" and no point was ground
    rng = np.random.default_rng(4)
    n = 4000
    xy = rng.uniform(0, 200, (n, 2))
    ground_z = 0.1 * xy[:, 0] + 2.0 * np.sin(xy[:, 1] / 30.0)
    tree = rng.random(n) < 0.6
    z = ground_z + np.where(tree, rng.uniform(3, 15, n), 0.0)
    res = extract_ground(np.c_[xy, z], "auto")
    assert res.note == ""
    assert res.mask[~tree].mean() > 0.9
    assert res.mask[tree].mean() < 0.05


@pytest.mark.parametrize("scene", ["flat_roof", "water", "cliff"])
@pytest.mark.parametrize("method", ["auto", "smrf", "csf"])
def test_bad_input_gets_an_explicit_result(scene: str, method: str) -> None:
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 30, (4000, 2))
    if scene == "flat_roof":  # a cloud of one flat roof: a plane at 12 m, nothing else
        z = np.full(len(xy), 12.0) + rng.normal(0, 0.01, len(xy))
    elif scene == "water":  # water only: a plane with waves, a few drop-outs
        z = 0.05 * np.sin(xy[:, 0]) + rng.normal(0, 0.02, len(xy))
    else:  # a cliff: two levels 25 m apart and its face
        z = np.where(xy[:, 0] < 15, 0.0, 25.0)
        face = rng.random(len(xy)) < 0.1
        xy[face, 0] = 15.0
        z[face] = rng.uniform(0, 25, int(face.sum()))
    res = extract_ground(np.c_[xy, z], method)
    assert res.mask.shape == (len(xy),)
    assert res.note or res.n_ground > 0
    if res.n_ground:
        assert res.dtm is not None and np.isfinite(res.dtm.z_m).all()
    if scene == "cliff" and method != "csf":
        top, bottom = xy[:, 0] > 16, xy[:, 0] < 14
        # a 15 m wide plateau 25 m up is, to a morphological filter, a building: the foot
        # of the cliff is the ground, the result is explicit
        assert res.mask[bottom].mean() > 0.9
        assert res.mask[top].mean() in (0.0, 1.0) or res.mask[top].mean() < 0.1
