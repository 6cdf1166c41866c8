"""Cost of the automatic seed stage (issue 7: auto no slower than CSF on AHN3 tile 1).

The slope-aware seed stage with its object test (issue 17) ran the whole progressive
filter twice (with the allowances and as published) and inpainted the provisional DTM
again when the low-cluster test had found no pit; the refinement sampled the DTM slope at
every point of every pass. These tests pin the shared work."""

from __future__ import annotations

from collections import Counter

import numpy as np

from pyheracles.groundfilters import smrf as smrf_module
from pyheracles.groundfilters.refine import (
    RefineParams,
    sampled_threshold_test,
    within_threshold,
)
from pyheracles.groundfilters.smrf import (
    SMRFParams,
    progressive_filter,
    progressive_filters,
    smrf,
    terrain_slope_raster,
)
from pyheracles.groundfilters.surface import Grid, RasterSampler


def _terrain(shape=(90, 110), seed=3):
    rng = np.random.default_rng(seed)
    rr, cc = np.indices(shape, dtype=float)
    z = 0.4 * np.maximum(0.0, cc - 60.0) + 0.05 * rr + rng.normal(0, 0.05, shape)
    z[20:32, 10:24] += 6.0  # a building on the flat
    z[60:66, 70:76] += 4.0  # one on the slope
    return z


def test_progressive_filters_is_both_passes_bit_for_bit() -> None:
    z = _terrain()
    extra = terrain_slope_raster(z, max_radius=12, cell_m=1.0)
    edge = terrain_slope_raster(z, max_radius=12, cell_m=1.0, extrapolate=True)
    args = dict(slope=0.15, max_radius=12, cell_m=1.0)
    allow = dict(extra_slope=extra, extra_max_radius=4, edge_slope=edge)
    for active in (None, np.pad(np.ones((20, 30), dtype=bool), ((0, 70), (0, 80)))):
        # the second active mask covers a small share: the box-by-box path
        with_allowances, published = progressive_filters(z, **args, **allow, active=active)
        assert np.array_equal(
            with_allowances, progressive_filter(z, **args, **allow, active=active)
        )
        assert np.array_equal(published, progressive_filter(z, **args, active=active))
        assert (published & ~with_allowances).any()  # the allowances do keep cells


def test_auto_seed_stage_opens_and_inpaints_once(monkeypatch) -> None:
    # AHN3 tile 1: the published test of the object test repeated every opening of the
    # allowance pass (+0.04 s CPU), and the provisional DTM repeated the low-cluster
    # test's membrane although no pit had been found (+0.02 s)
    z = _terrain()
    rows, cols = z.shape
    rr, cc = np.indices(z.shape, dtype=float)
    xyz = np.c_[cc.ravel() + 0.5, rr.ravel() + 0.5, z.ravel()]
    params = SMRFParams(
        window_m=12.0,
        terrain_slope_weight=1.0,
        terrain_slope_radius_m=4.0,
        join_share=0.75,
        edge_slope_allowance=True,
        low_cluster_window_m=3.0,
    )
    expected, _ = smrf(xyz, params)
    radii: Counter[int] = Counter()
    n_inpaint = 0
    opening, inpaint = smrf_module.opening, smrf_module.inpaint

    def counted_opening(surface, radius):
        radii[radius] += 1
        return opening(surface, radius)

    def counted_inpaint(values):
        nonlocal n_inpaint
        n_inpaint += 1
        return inpaint(values)

    monkeypatch.setattr(smrf_module, "opening", counted_opening)
    monkeypatch.setattr(smrf_module, "inpaint", counted_inpaint)
    mask, dtm = smrf(xyz, params)
    assert np.array_equal(mask, expected)
    assert mask.reshape(rows, cols)[40:50, 30:50].all()  # flat ground kept
    assert not mask.reshape(rows, cols)[22:30, 12:22].any()  # the building is not
    # radii above the low-cluster test's (3) and below the slope rasters' (12): the
    # progressive openings only, once each
    assert all(radii[r] == 1 for r in range(4, 12)), radii
    # the minimum surface and the low-cluster surface, reused as provisional DTM
    assert n_inpaint == 2
    assert dtm.observed.any()


def test_refinement_samples_the_slope_only_where_it_decides() -> None:
    # AHN3 tile 1: the refinement sampled the DTM slope at all 0.64 M points three times,
    # while its thresholds decide only ~3 % of them (the others pass at any slope, or fail
    # at the steepest); the test must stay that of within_threshold, bit for bit
    rng = np.random.default_rng(5)
    grid = Grid(0.0, 60.0, 1.0, (60, 80))
    xy = np.c_[rng.uniform(-0.5, 80.5, 50_000), rng.uniform(-0.5, 60.5, 50_000)]
    sampler = RasterSampler(grid, xy, dtype=np.float32)
    rr, cc = np.indices(grid.shape, dtype=float)
    slope = 0.4 + 0.3 * np.sin(rr / 7.0) * np.cos(cc / 5.0)  # 0.1 .. 0.7
    # ground within a few cm of the surface, objects metres above, some in between
    residual = rng.normal(0.0, 0.02, xy.shape[0])
    residual[::3] = rng.uniform(-1.0, 10.0, residual[::3].size)
    residual = residual.astype(np.float32)
    residual[::50] = np.nan
    params = RefineParams(cell_m=1.0)
    sampled: list[int] = []

    class Counting(RasterSampler):
        def __call__(self, values, at=None):
            sampled.append(xy.shape[0] if at is None else at.size)
            return super().__call__(values, at)

    counting = Counting(grid, xy, dtype=np.float32)
    for sigma in (0.01, 0.02, 0.05):
        expected = within_threshold(residual, sampler(slope), sigma, params)
        got = sampled_threshold_test(residual, slope, counting, sigma, params)
        assert np.array_equal(got, expected)
        assert expected.any() and not expected.all()
    assert max(sampled) < 0.35 * xy.shape[0]
    at = np.flatnonzero(rng.random(xy.shape[0]) < 0.1)
    assert np.array_equal(sampler(slope, at=at), sampler(slope)[at])


def test_window_lookups_are_the_binary_dilation_at_those_cells() -> None:
    """Issue 17 (8 tiles on a diagonal: a raster 8x its data): the ground growth's fronts
    come from window look-ups at the candidate and new cells, not from dilations of the
    raster; they must be the dilation exactly, edges included."""
    from scipy import ndimage

    from pyheracles.groundfilters.grow import window_any, window_cells

    rng = np.random.default_rng(8)
    for shape, radius in (((37, 23), 1), ((5, 60), 2), ((1, 9), 3), ((40, 40), 4)):
        mask = rng.uniform(size=shape) < 0.05
        window = np.ones((2 * radius + 1, 2 * radius + 1), dtype=bool)
        dilated = ndimage.binary_dilation(mask, window)
        cells = np.flatnonzero(rng.uniform(size=shape) < 0.3)
        assert np.array_equal(window_any(mask, cells, radius), dilated.ravel()[cells])
        assert np.array_equal(window_cells(np.flatnonzero(mask), shape, radius),
                              np.flatnonzero(dilated))  # fmt: skip


def test_mean_surface_at_occupied_cells_is_the_raster_formula() -> None:
    """The centroid correction computed at occupied cells only is the whole-raster one
    with :func:`numpy.gradient` bit for bit (one- and two-cell wide rasters included)."""
    from pyheracles.groundfilters.surface import gradient, mean_surface_cells

    rng = np.random.default_rng(2)
    for w, h, n in ((60.0, 75.0, 3000), (0.5, 40.0, 200), (40.0, 0.5, 200), (2.9, 2.9, 30)):
        xy = rng.uniform(0, 1, (n, 2)) * [w, h]
        z = rng.normal(size=n) + 0.3 * xy[:, 0]
        grid = Grid.covering(xy, 1.5)
        flat = grid.flat_index(xy)
        size = grid.shape[0] * grid.shape[1]
        count = np.bincount(flat, minlength=size).astype(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            mz, mx, my = (
                (np.bincount(flat, weights=v, minlength=size) / count).reshape(grid.shape)
                for v in (z, xy[:, 0], xy[:, 1])
            )
        rr, cc = np.indices(grid.shape)
        gy, gx = gradient(mz, grid.cell_m)
        dx = grid.x0_m + (cc + 0.5) * grid.cell_m - mx
        dy = grid.y0_m - (rr + 0.5) * grid.cell_m - my
        expected = mz + np.nan_to_num(gx * dx + gy * dy, nan=0.0, posinf=0.0, neginf=0.0)
        got = mean_surface_cells(grid, flat, xy[:, 0], xy[:, 1], z)
        assert np.array_equal(got, expected, equal_nan=True)


def test_halving_and_far_cells_are_the_whole_raster_formulas(monkeypatch) -> None:
    """The inpainting pyramid's block means (strided quarters) and its far cells (a
    square dilation of the known cells) are the block reduction and the chessboard
    distance map they replace, to the bit (cost per level: issue 17's diagonal tiles)."""
    from scipy import ndimage

    from pyheracles.groundfilters import surface
    from pyheracles.groundfilters.pyramid import halve

    rng = np.random.default_rng(5)
    for shape in ((301, 403), (1, 7), (6, 1), (9, 9)):
        v = rng.normal(size=shape) * 100.0
        v[rng.uniform(size=shape) < 0.4] = np.nan
        rows, cols = shape
        padded = np.full((rows + rows % 2, cols + cols % 2), np.nan)
        padded[:rows, :cols] = v
        blocks = padded.reshape(padded.shape[0] // 2, 2, padded.shape[1] // 2, 2)
        known = np.isfinite(blocks)
        with np.errstate(invalid="ignore", divide="ignore"):
            expected = np.where(known.any(axis=(1, 3)),
                                np.where(known, blocks, 0.0).sum(axis=(1, 3))
                                / known.sum(axis=(1, 3)), np.nan)  # fmt: skip
        assert np.array_equal(halve(v), expected, equal_nan=True)
    unknown = rng.uniform(size=(200, 150)) < 0.97  # more than EXACT_MAX_UNKNOWN
    values = np.where(unknown, np.nan, 1.0)
    d = ndimage.distance_transform_cdt(unknown, metric="chessboard")
    far_expected = unknown & (d > surface.INPAINT_BAND_CELLS)
    seen = {}
    original = surface._solve_band_cells

    def spy(vals, at):
        seen["band"] = np.zeros(vals.size, dtype=bool)
        seen["band"][at] = True
        return original(vals, at)

    monkeypatch.setattr(surface, "_solve_band_cells", spy)
    surface.inpaint(values)
    assert np.array_equal(seen["band"].reshape(values.shape), unknown & ~far_expected)


def test_band_solve_and_float32_padding_are_the_whole_raster_formulas() -> None:
    """The band's system is gathered at the band cells only, and the sampler casts the
    padded raster once: the same numbers as the raster-wide versions (issue 17, tiles on
    a diagonal)."""
    from scipy import sparse

    from pyheracles.groundfilters import surface

    rng = np.random.default_rng(5)
    values = _terrain((40, 55))
    band = np.zeros(values.shape, dtype=bool)
    band[3:12, 0:9] = True  # touching the raster's edge
    band[20:26, 30:50] = True
    band[39, 54] = True  # a corner cell
    # the raster-wide assembly: padded rasters, ids per cell
    rows, cols = band.shape
    ur, uc = np.nonzero(band)
    deg = np.zeros(ur.size)
    rhs = np.zeros(ur.size)
    ids = -np.ones(band.shape, dtype=int)
    ids[ur, uc] = np.arange(ur.size)
    entries = {(i, i): 0.0 for i in range(ur.size)}
    for i, (r, c) in enumerate(zip(ur, uc, strict=True)):
        for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            nr, nc = r + dr, c + dc
            if 0 <= nr < rows and 0 <= nc < cols:
                deg[i] += 1
                if band[nr, nc]:
                    entries[(i, ids[nr, nc])] = -1.0
                else:
                    rhs[i] += values[nr, nc]
    for i in range(ur.size):
        entries[(i, i)] = deg[i]
    keys = list(entries)
    matrix = sparse.csr_matrix(
        ([entries[k] for k in keys], ([k[0] for k in keys], [k[1] for k in keys])),
        shape=(ur.size, ur.size),
    )
    start = values[ur, uc] + rng.normal(0, 0.5, ur.size)
    expected = surface._jacobi_cg(matrix, rhs, start, 1.0 / deg)
    trial = values.copy()
    trial[ur, uc] = start
    assert np.allclose(surface._solve_band_cells(trial, np.flatnonzero(band)), expected, atol=1e-9)
    for shape in [(1, 1), (2, 5), (7, 2), (3, 3), (40, 55)]:
        v = rng.normal(size=shape) * 100.0
        assert np.array_equal(
            surface._pad_linear_as(v, np.float32), surface._pad_linear(v).astype(np.float32)
        )


def test_coarse_fill_is_the_interleaved_bilinear_formula() -> None:
    """The compiled fill of the pyramid is the two interleaved bilinear passes (rows, then
    columns; edges replicated) it replaces, to the bit, in the unknown cells only, and
    its band is the unknown cells a square dilation of the known ones reaches."""
    from scipy import ndimage

    from pyheracles.groundfilters.pyramid import band_and_fill

    def axis0(a):
        prev = np.concatenate([a[:1], a[:-1]])
        nxt = np.concatenate([a[1:], a[-1:]])
        out = np.empty((2 * a.shape[0],) + a.shape[1:])
        out[0::2] = 0.75 * a + 0.25 * prev
        out[1::2] = 0.75 * a + 0.25 * nxt
        return out

    rng = np.random.default_rng(9)
    for shape in ((301, 403), (1, 7), (6, 1), (9, 9), (1, 1)):
        coarse = rng.normal(size=((shape[0] + 1) // 2, (shape[1] + 1) // 2)) * 10.0
        unknown = rng.uniform(size=shape) < 0.9
        values = np.where(unknown, np.nan, -1.0)
        expected = values.copy()
        expected[unknown] = axis0(axis0(coarse).T).T[: shape[0], : shape[1]][unknown]
        for reach in (1, 3, 6):
            got = values.copy()
            band = band_and_fill(got, coarse, reach)
            assert np.array_equal(got, expected)
            near = ndimage.maximum_filter((~unknown).view(np.uint8), size=2 * reach + 1,
                                          mode="constant")  # fmt: skip
            assert np.array_equal(band, np.flatnonzero(unknown & (near > 0)))


def test_slivers_of_a_tile_run_in_one_window_with_the_same_result() -> None:
    """Tiles corner to corner are cut into slivers by the box split, each with its own
    halo; windows that overlap run together when that costs fewer cells, and every core
    is still written from a window holding it with its halo (issue 17, 8 AHN3 tiles on a
    diagonal: 18 windows of 1.18 M cells, now 8 of 0.91 M)."""
    rng = np.random.default_rng(4)
    shape = (7 * 60, 7 * 50)
    active = np.zeros(shape, dtype=bool)
    for k in range(7):  # seven 60 x 50 tiles corner to corner, a few empty cells
        active[60 * k : 60 * (k + 1), 50 * k : 50 * (k + 1)] = True
    active &= rng.uniform(size=shape) > 0.03
    z = np.where(active, rng.normal(0, 0.05, shape), 0.0)
    z[200:210, 170:184] += 5.0  # a building in the fourth tile, cut by the box split
    halo = 2 * 9 + 2
    boxes = list(smrf_module._active_blocks(active, halo))
    merged = smrf_module._merged_windows(boxes, halo, shape)

    def cells(windows):
        return sum((w[0].stop - w[0].start) * (w[1].stop - w[1].start) for w in windows)

    assert len(merged) < len(boxes)
    assert cells(w for w, _ in merged) < cells(w for _, w in boxes)
    assert sum(len(c) for _, c in merged) == len(boxes)
    for window, cores in merged:  # every core lies in its window with the halo around it
        for core in cores:
            for c, w, n in zip(core, window, shape, strict=True):
                assert w.start == max(0, c.start - halo) or w.start <= c.start - halo
                assert w.stop == min(n, c.stop + halo) or w.stop >= c.stop + halo
    args = dict(slope=0.15, max_radius=9, cell_m=1.0)
    whole = progressive_filter(z, **args)
    boxwise = progressive_filter(z, **args, active=active)
    assert boxwise[200:210, 170:184][active[200:210, 170:184]].all()
    assert np.array_equal(whole[active], boxwise[active])


def test_smooth_components_gathered_at_the_cells_are_the_raster_shifts() -> None:
    """The growth's components are linked at the cells themselves (binary search of a
    neighbour's id), not by shifting raster-sized masks: the same components, numbered
    alike, on rasters of any shape and reach (issue 17, tiles on a diagonal)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from pyheracles.groundfilters.grow import smooth_components

    def shifted(zmin, cells, step_m, reach, rise_m):
        rows, cols = cells.shape
        index = np.full(cells.shape, -1, dtype=np.intp)
        at = np.flatnonzero(cells)
        index.ravel()[at] = np.arange(at.size)
        heads, tails = [], []
        offsets = [(0, dc) for dc in range(1, reach + 1)]
        offsets += [(dr, dc) for dr in range(1, reach + 1) for dc in range(-reach, reach + 1)]
        for dr, dc in offsets:
            if dr >= rows or abs(dc) >= cols:
                continue
            a = (slice(0, rows - dr), slice(max(0, -dc), cols - max(0, dc)))
            b = (slice(dr, rows), slice(max(0, dc), cols - max(0, -dc)))
            limit = step_m + rise_m * float(np.hypot(dr, dc))
            link = cells[a] & cells[b] & (np.abs(zmin[a] - zmin[b]) < limit)
            heads.append(index[a][link])
            tails.append(index[b][link])
        head, tail = np.concatenate(heads), np.concatenate(tails)
        graph = coo_matrix((np.ones(head.size, np.int8), (head, tail)), (at.size, at.size))
        _, comp = connected_components(graph, directed=False)
        labels = np.full(cells.shape, -1, dtype=np.intp)
        labels.ravel()[at] = comp
        return labels, np.bincount(comp, minlength=1)

    rng = np.random.default_rng(2)
    for shape in ((50, 60), (1, 30), (30, 1), (3, 3)):
        for reach in (1, 2, 3):
            z = rng.normal(size=shape).cumsum(axis=1) * 0.3
            cells = rng.uniform(size=shape) < 0.7
            z[~cells] = np.nan
            got = smooth_components(z, cells, 0.4, reach=reach, rise_m=0.1)
            want = shifted(z, cells, 0.4, reach, 0.1)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    labels, sizes = smooth_components(np.zeros((4, 4)), np.zeros((4, 4), bool), 0.4)
    assert (labels == -1).all() and sizes.tolist() == [0]


def test_inpaint_update_solves_only_the_regions_that_changed() -> None:
    """After SMRF takes pits out of its terrain, only the unknown regions holding a pit
    are solved again (each exactly, in its own box): the same raster as inpainting the
    whole anew, where the whole costs a mosaic's raster a quarter of a second."""
    from pyheracles.groundfilters.surface import inpaint, inpaint_update

    rng = np.random.default_rng(7)
    rr, cc = np.indices((80, 90), dtype=float)
    z = 0.1 * rr + 0.05 * cc + rng.normal(0, 0.02, (80, 90))
    holed = z.copy()
    holed[10:20, 10:30] = np.nan
    holed[50:52, 60:62] = np.nan
    before = inpaint(holed)
    changed = np.zeros(z.shape, dtype=bool)
    changed[30, 40] = True  # a pit cell amid known cells
    changed[15, 30] = True  # one at the edge of a hole: the hole is solved again
    unknown = np.isnan(holed) | changed
    got = inpaint_update(before, unknown, changed)
    np.testing.assert_allclose(got, inpaint(np.where(unknown, np.nan, holed)), atol=1e-12)
    assert np.array_equal(got[50:52, 60:62], before[50:52, 60:62])  # untouched region
