"""Low clutter standing beside a building stays out of it; its platform, a canopy over the
outline and a wall's face digitised off its axis do not (issue 17, AHN3 tile 1: of the 360
points the objects took more than 0.25 m beyond their BGT outline and under 2 m over the
terrain, 35 were building in the reference; parked cars, bicycles and bins beside the
facades joined its cluster through the facade's foot)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely

from pyheracles import InputError
from pyheracles.cloud import PointCloud
from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.complex.clutter import clutter_points, terrain_under, under_terrain
from test_complex_eaves import ahn3_and_bgt, buildings_f1


def _grid(x0: float, x1: float, y0: float, y1: float, step: float) -> np.ndarray:
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1e-9, step), np.arange(y0, y1 + 1e-9, step))
    return np.column_stack([gx.ravel(), gy.ravel()])


def _face(p0: tuple[float, float], p1: tuple[float, float], z0: float, z1: float,
          step: float) -> np.ndarray:  # fmt: skip
    """Points of a vertical face from ``p0`` to ``p1`` between heights ``z0`` and ``z1``."""
    n = max(2, round(np.hypot(p1[0] - p0[0], p1[1] - p0[1]) / step) + 1)
    t = np.linspace(0.0, 1.0, n)
    z = np.arange(z0, z1 + 1e-9, step)
    tt, zz = (a.ravel() for a in np.meshgrid(t, z))
    return np.column_stack([p0[0] + tt * (p1[0] - p0[0]), p0[1] + tt * (p1[1] - p0[1]), zz])


def _scene() -> tuple[PointCloud, dict[str, gpd.GeoDataFrame], dict[str, np.ndarray]]:
    """A 10 x 8 m house (flat roof at 6 m, facades sampled every 0.4 m) on flat terrain;
    bins 1.2 m high standing 0.45-0.95 m east of its east facade; a canopy at 2.6 m over
    its south door, 0.3-0.9 m beyond the outline; a garden wall 1.8 m high, 0.5 m thick,
    west of it, whose polygon leaves its east face 0.35 m out; three low outliers 0.7 m
    under the terrain at the east facade's foot.  The ground is given (class 2)."""
    s = 0.4
    ground = _grid(-8.0, 16.0, -6.0, 14.0, s)
    ground = ground[~((ground[:, 0] > -0.1) & (ground[:, 0] < 12.5) & (ground[:, 1] > -0.1)
                      & (ground[:, 1] < 8.1))]  # fmt: skip
    parts = {
        "ground": np.column_stack([ground, np.zeros(len(ground))]),
        "roof": np.column_stack([_grid(0.0, 10.0, 0.0, 8.0, s), np.full(546, 6.0)]),
        "facade": np.vstack([
            _face((-0.05, 0.0), (-0.05, 8.0), 0.2, 5.8, s),
            _face((10.05, 0.0), (10.05, 8.0), 0.2, 5.8, s),
            _face((0.0, -0.05), (10.0, -0.05), 0.2, 5.8, s),
            _face((0.0, 8.05), (10.0, 8.05), 0.2, 5.8, s),
        ]),
        "bins": np.vstack([
            np.column_stack([_grid(10.45, 10.95, 2.0, 6.0, 0.25), np.full(51, 1.2)]),
            _face((10.45, 2.0), (10.45, 6.0), 0.3, 1.0, 0.25),
        ]),
        "canopy": np.column_stack([_grid(3.0, 6.0, -0.9, -0.3, 0.3), np.full(33, 2.6)]),
        "low": np.array([[10.15, 3.0, -0.7], [10.15, 3.8, -0.75], [10.2, 4.6, -0.7]]),
        "wall": np.vstack([
            _face((-4.6, -3.0), (-4.6, 3.0), 0.2, 1.6, s),
            _face((-4.1, -3.0), (-4.1, 3.0), 0.2, 1.6, s),
            np.column_stack([_grid(-4.6, -4.1, -3.0, 3.0, 0.25), np.full(75, 1.8)]),
        ]),
    }
    ends = np.cumsum([0] + [len(p) for p in parts.values()])
    idx = {n: np.arange(ends[i], ends[i + 1]) for i, n in enumerate(parts)}
    xyz = np.vstack(list(parts.values()))
    xyz += [0.03, 0.03, 0.01] * np.random.default_rng(0).standard_normal(xyz.shape)
    cls = np.where(np.isin(np.arange(len(xyz)), idx["ground"]), 2, 1).astype(np.uint8)
    cloud = PointCloud(xyz=xyz, offset=np.zeros(3), crs="EPSG:28992",
                       attributes={"classification": cls})  # fmt: skip
    layers = {
        "building": gpd.GeoDataFrame({"fid": ["B1"]}, geometry=[shapely.box(0, 0, 10, 8)],
                                     crs="EPSG:28992"),
        "wall": gpd.GeoDataFrame({"fid": ["W1"]}, geometry=[shapely.box(-5.05, -3.0, -4.45, 3.0)],
                                 crs="EPSG:28992"),
    }
    return cloud, prepare_layers(layers, cloud), idx


def _objects(params: ComplexParams) -> tuple[np.ndarray, dict[str, int], dict[str, np.ndarray]]:
    cloud, layers, idx = _scene()
    seg = segment_complex(cloud, layers, params).segmentation
    ids = dict(zip(seg.objects["class"], seg.objects["instance"], strict=True))
    return seg.instance, ids, idx


def test_bins_beside_the_facade_stay_out_a_canopy_and_a_wall_face_do_not() -> None:
    """Plain clustering (no scattered points: the regular grids here look rough to the
    surface variation), the mechanism AHN3 showed: the bins' points lie within the
    clustering distance of the facade's foot."""
    plain = ComplexParams(ground="class", scatter_max=None)
    inst, ids, idx = _objects(plain)
    house, wall = ids["building"], ids["wall"]
    assert (inst[idx["facade"]] == house).mean() >= 0.95
    assert (inst[idx["roof"]] == house).all()
    assert (inst[idx["canopy"]] == house).all()  # 2.6 m: one walks under it
    assert (inst[idx["wall"]] == wall).all()  # its face beyond the polygon reaches its top
    assert not (inst[idx["bins"]] > 0).any()
    # without the rule the bins join the house through the facade's foot
    inst_off, ids_off, _ = _objects(replace(plain, clutter_height_m=None))
    assert (inst_off[idx["bins"]] == ids_off["building"]).mean() >= 0.9
    with pytest.raises(InputError, match="clutter_height_m"):
        ComplexParams(clutter_height_m=0.0)


def test_clutter_points_keep_a_platform_and_need_terrain() -> None:
    """A low group beside the object is kept where it holds released ground (the
    building's platform), lies within half a buffer of the outline (the object's own
    face, digitised off it), stands beside a low object, or where the terrain under it
    is unknown."""
    roof = np.column_stack([_grid(0.0, 4.0, 0.0, 4.0, 0.4), np.full(121, 5.0)])
    low = np.column_stack([_grid(4.5, 5.5, 0.0, 4.0, 0.4), np.full(33, 0.6)])
    xyz = np.vstack([roof, low])
    inside = np.r_[np.ones(len(roof), bool), np.zeros(len(low), bool)]
    ring = ~inside
    far = xyz[:, 0] > 4.5  # beyond half the buffer
    terrain = lambda xy: np.zeros(len(xy))  # noqa: E731
    none = np.zeros(len(xyz), dtype=bool)
    found = clutter_points(xyz, ring, far, inside, terrain, none, 1.2, 2.0)
    assert found[ring].all() and not found[inside].any()
    platform = none.copy()
    platform[len(roof) + 3] = True  # one released ground point: the group is a platform
    assert not clutter_points(xyz, ring, far, inside, terrain, platform, 1.2, 2.0).any()
    # the same group within half a buffer of the outline: it may be the object's face
    assert not clutter_points(xyz, ring, np.zeros(len(xyz), bool), inside, terrain, none,
                              1.2, 2.0).any()  # fmt: skip
    unknown = lambda xy: np.full(len(xy), np.nan)  # noqa: E731
    assert not clutter_points(xyz, ring, far, inside, unknown, none, 1.2, 2.0).any()  # fmt: skip
    # beside a low shed (1.8 m) a low group may be its face digitised off its axis
    shed = xyz.copy()
    shed[inside, 2] = 1.8
    assert not clutter_points(shed, ring, far, inside, terrain, none, 1.2, 2.0).any()
    # on a slope the heights are over the terrain under each point: the same house
    # and group on a 30 % slope rising away from the group
    slope = lambda xy: 0.3 * (4.0 - xy[:, 0])  # noqa: E731
    tilted = xyz.copy()
    tilted[:, 2] += slope(xyz[:, :2])
    assert clutter_points(tilted, ring, far, inside, slope, none, 1.2, 2.0)[ring].all()
    ground = np.column_stack([_grid(-2.0, 8.0, -2.0, 6.0, 1.0), np.full(99, 0.3)])
    assert np.allclose(terrain_under(ground, xyz[:3, :2]), 0.3)
    assert np.isnan(terrain_under(np.zeros((0, 3)), xyz[:3, :2])).all()


def test_low_outliers_under_the_terrain_stay_out() -> None:
    """Multipath returns under the terrain at a facade's foot join its cluster; they are
    nobody's (complex family draws 0-29: 347 object points more than 0.5 m under the
    terrain, none of them the feature's)."""
    plain = ComplexParams(ground="class", scatter_max=None)
    inst, _, idx = _objects(plain)
    assert not (inst[idx["low"]] > 0).any()
    inst_off, ids_off, _ = _objects(replace(plain, low_outlier_m=None))
    assert (inst_off[idx["low"]] == ids_off["building"]).all()
    flat = lambda xy: np.zeros(len(xy))  # noqa: E731
    pts = np.array([[0.0, 0.0, -0.7], [1.0, 0.0, -0.3], [2.0, 0.0, 3.0]])
    assert under_terrain(pts, np.zeros(5), flat, 0.5).tolist() == [True, False, False]
    assert not under_terrain(pts, np.zeros(0), flat, 0.5).any()  # no ground near
    unknown = lambda xy: np.full(len(xy), np.nan)  # noqa: E731
    assert not under_terrain(pts, np.zeros(5), unknown, 0.5).any()
    with pytest.raises(InputError, match="low_outlier_m"):
        ComplexParams(low_outlier_m=-1.0)


@pytest.mark.slow
def test_ahn3_low_clutter_beside_the_buildings_stays_out(shared_data: Path) -> None:
    """AHN3 tile 1 (auto ground): the objects give back 198 points beyond the outlines
    (8 of them building in the reference: 190 fewer extra points; cars, bicycles, bins),
    the median per-building F1 reaches 0.98 (0.9799 without the rule, 0.9815 with it),
    the share at F1 >= 0.9 does not fall (0.935 -> 0.942)."""
    from pyheracles.evaluate import reference_from_polygons

    cloud, layers = ahn3_and_bgt(shared_data)
    cls = np.asarray(cloud.attributes["classification"])
    ref = reference_from_polygons(cloud.world_xyz()[:, :2], cls == 6, layers["building"],
                                  buffer_m=1.0)  # fmt: skip

    def run(params: ComplexParams) -> tuple[int, float, float]:
        pred, median, share = buildings_f1(cloud, layers, ref, params)
        return int(((pred > 0) & (pred != ref)).sum()), median, share

    extra_off, median_off, share_off = run(ComplexParams(ground="auto", clutter_height_m=None))
    extra, median, share = run(ComplexParams(ground="auto"))
    assert extra <= extra_off - 150
    assert median >= 0.98 > median_off
    assert share >= share_off
