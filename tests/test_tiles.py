"""City scale: step 1 over tiles with buffers, on Dask (pyheracles.tiles)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import geopandas as gpd
import laspy
import numpy as np
import pyogrio
import pytest
import shapely
from pyproj import CRS

from pyheracles.cli import main
from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.errors import InputError
from pyheracles.io import read_cloud, read_layer
from pyheracles.tiles import assign_owners, read_catalog, run_tiles, split_las
from pyheracles.tiles.catalog import read_points
from pyheracles.tiles.plan import city_noise
from pyheracles.tiles.runner import boxes_meeting
from pyheracles.tiles.worker import (
    BUFFER_DIMS,
    StripJob,
    buffer_points,
    own_path,
    own_points,
    strip_tile,
)

RD = "EPSG:28992"
X0, Y0 = 85_000.0, 447_000.0


def _scene(rng: np.random.Generator) -> tuple[np.ndarray, gpd.GeoDataFrame]:
    """80 x 80 m of gently sloping ground and four box buildings, one across x = 40 m."""
    g = np.mgrid[0:80:0.5, 0:80:0.5].reshape(2, -1).T
    ground = np.column_stack([g, 0.01 * g[:, 0] + rng.normal(0, 0.02, len(g))])
    boxes = [(10, 10, 22, 20, 6.0), (34, 50, 48, 62, 8.0), (55, 15, 65, 27, 5.0),
             (12, 55, 22, 70, 7.0)]  # fmt: skip
    parts, polys = [ground], []
    for x0, y0, x1, y1, h in boxes:
        inside = (g[:, 0] > x0) & (g[:, 0] < x1) & (g[:, 1] > y0) & (g[:, 1] < y1)
        parts[0] = parts[0][~((parts[0][:, 0] > x0) & (parts[0][:, 0] < x1)
                              & (parts[0][:, 1] > y0) & (parts[0][:, 1] < y1))]  # fmt: skip
        roof = np.column_stack([g[inside], np.full(inside.sum(), h)])
        zs = np.arange(0.5, h, 0.5)
        edge = np.concatenate([
            np.column_stack([np.arange(x0, x1, 0.5), np.full(int((x1 - x0) / 0.5), y)])
            for y in (y0, y1)
        ] + [
            np.column_stack([np.full(int((y1 - y0) / 0.5), x), np.arange(y0, y1, 0.5)])
            for x in (x0, x1)
        ])  # fmt: skip
        wall = np.column_stack([np.repeat(edge, len(zs), axis=0), np.tile(zs, len(edge))])
        parts += [roof, wall]
        polys.append(shapely.box(x0 + X0, y0 + Y0, x1 + X0, y1 + Y0))
    xyz = np.concatenate(parts) + [X0, Y0, 0.0]
    xyz = xyz[rng.permutation(len(xyz))]
    layer = gpd.GeoDataFrame({"name": ["a", "b", "c", "d"]}, geometry=polys, crs=RD)
    return xyz, layer


def write_tile_las(path: Path, xyz: np.ndarray, crs: str | None = RD) -> Path:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [X0, Y0, 0.0]
    if crs is not None:
        header.add_crs(CRS.from_user_input(crs))
    header.add_extra_dim(laspy.ExtraBytesParams("reflectance", "f4"))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.intensity = np.arange(len(xyz)) % 60000
    las.reflectance = np.linspace(0, 1, len(xyz)).astype(np.float32)
    las.write(path)
    return path


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict:
    root = tmp_path_factory.mktemp("tiles")
    xyz, layer = _scene(np.random.default_rng(3))
    whole = write_tile_las(root / "whole.laz", xyz)
    tiles = split_las(whole, root / "in", 2, 2)
    return {"root": root, "whole": whole, "tiles": tiles, "layer": layer}


def labels_by_feature(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    las = laspy.read(folder / "segmented.laz")
    fid = np.full(len(las.points), -1)
    if (folder / "objects.gpkg").is_file():
        objs = pyogrio.read_dataframe(folder / "objects.gpkg", read_geometry=False)
        lut = dict(zip(objs["instance"], objs["source_fid"], strict=True))
        inst = np.asarray(las.instance)
        fid = np.array([lut.get(int(i), -1) for i in inst])
    return fid, np.asarray(las.classification) == 2


def test_owner_rule_one_tile_per_point() -> None:
    b = np.array([[0, 0, 10, 10], [10, 0, 20, 10], [0, 10, 10, 20]], dtype=float)
    pts = np.array([[5, 5], [10, 5], [15, 5], [5, 10], [25, 5], [5, 30]], dtype=float)
    assert assign_owners(pts, b).tolist() == [0, 0, 1, 0, 1, 2]


def test_owner_rule_matches_the_all_pairs_rule_on_edges_overlaps_and_outside() -> None:
    """The tree-based owners equal the rule written over every (feature, tile) pair."""
    rng = np.random.default_rng(4)
    g = np.mgrid[0:5, 0:4].reshape(2, -1).T * 100.0
    b = np.column_stack([g, g + 100.0])
    b[3] += [10, 10, 30, 30]  # a box overlapping its neighbours
    b = b[rng.permutation(len(b))]
    pts = np.concatenate(
        [
            rng.uniform(-80, 600, (3000, 2)),  # inside, outside
            np.round(rng.uniform(-1, 6, (500, 2))) * 100,  # corners
            rng.integers(-1, 6, (500, 2)) * 100 + [[50, 0]],
        ]
    )  # edges
    p, q = pts.reshape(-1, 1, 2), b.reshape(1, -1, 4)
    dx = np.maximum(np.maximum(q[..., 0] - p[..., 0], p[..., 0] - q[..., 2]), 0.0)
    dy = np.maximum(np.maximum(q[..., 1] - p[..., 1], p[..., 1] - q[..., 3]), 0.0)
    out = np.hypot(dx, dy)
    centre = np.hypot(
        p[..., 0] - (q[..., 0] + q[..., 2]) / 2, p[..., 1] - (q[..., 1] + q[..., 3]) / 2
    )
    expected = np.argmin(np.where(out == out.min(axis=1, keepdims=True), centre, np.inf), axis=1)
    assert (assign_owners(pts, b) == expected).all()
    assert assign_owners(np.zeros((0, 2)), b).shape == (0,)


def test_boxes_meeting_is_the_catalogue_neighbour_rule(scene: dict) -> None:
    catalog = read_catalog(scene["tiles"][0].parent)
    bounds = np.array([t.bounds for t in catalog.tiles])
    for k, tile in enumerate(catalog.tiles):
        for grow in (0.0, 5.0, 500.0):
            got = [catalog.tiles[j] for j in boxes_meeting(bounds, tile.box(grow)) if j != k]
            assert got == catalog.neighbours(tile, grow)


def test_buffer_from_a_strip_is_the_direct_read_else_falls_back(
    scene: dict, tmp_path: Path
) -> None:
    """Phase 0's strip gives a neighbour's buffer exactly (points, order, file indices,
    dimensions); a box it was not cut for is read from the file."""
    tile, other = read_catalog(scene["tiles"][0].parent).tiles[:2]
    boxes = (tile.box(7.5), tile.box(3.0))
    assert not strip_tile(StripJob(other, boxes, tmp_path))["skipped"]
    for box in (*boxes, tile.box(11.0)):  # the last: not cut for it
        got = buffer_points(other, box, tmp_path)
        want = read_points(other.path, box, BUFFER_DIMS)
        assert len(want[0]) > 0
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        assert got[2].keys() == want[2].keys()
        for k in want[2]:
            np.testing.assert_array_equal(got[2][k], want[2][k])
    # the tile's own points, kept for its phase 1: every point, in file order
    got, want = own_points(other, tmp_path), read_points(other.path, None, BUFFER_DIMS)
    assert own_path(tmp_path, other.name).is_file()
    for a, b in zip(got[:2], want[:2], strict=True):
        np.testing.assert_array_equal(a, b)
    assert got[2].keys() == want[2].keys()
    for k in want[2]:
        np.testing.assert_array_equal(got[2][k], want[2][k])
    assert strip_tile(StripJob(other, boxes, tmp_path))["skipped"]  # resumed


def test_city_noise_carried_forward_is_the_rerun_of_the_passes(scene: dict) -> None:
    """city_noise carries each tile's ground from pass to pass; the noise of every pass
    is, bit for bit, the one of the definition: pass k's ground by refine_ground run for
    k passes with the city's noise so far, pass k + 1's surface built from it."""
    from pyheracles.cloud import PointCloud
    from pyheracles.ground import SceneMeasures, aligned_grid, auto_params
    from pyheracles.groundfilters.refine import refine_ground
    from pyheracles.groundfilters.smrf import smrf
    from pyheracles.groundfilters.surface import RasterSampler

    catalog = read_catalog(scene["tiles"][0].parent)
    params = auto_params(SceneMeasures(0.5, float("nan"), 20.0))
    got = city_noise(catalog, params)
    clouds = [PointCloud.from_world(read_points(t.path, None, ())[0]) for t in catalog.tiles]
    sigmas: list[float] = []
    for k in range(params.refine.iterations):
        pooled = []
        for cloud in clouds:
            xy = cloud.xyz[:, :2]
            grid = aligned_grid(xy, params.seed.cell_m, cloud.offset[:2])
            sampler = RasterSampler(grid, xy, dtype=np.float32)
            seeds = smrf(cloud.xyz, params.seed, sampler=sampler)[0]
            before = seeds
            if k:
                fixed = replace(params.refine, iterations=k, sigma_m=tuple(sigmas))
                before = refine_ground(cloud.xyz, seeds, fixed, sampler=sampler)[0]
            step = replace(params.refine, iterations=k + 1, sigma_m=(*sigmas, 0.0))
            dtm = refine_ground(cloud.xyz, seeds, step, sampler=sampler)[1]
            z = cloud.xyz[before, 2]
            pooled.append((z - RasterSampler(grid, xy[before])(dtm.z_m)).astype(np.float32))
        r = np.concatenate(pooled)
        sigmas.append(float(1.4826 * np.median(np.abs(r - np.median(r)))))
    assert len(got) == params.refine.iterations >= 2
    assert got == tuple(sigmas)


def test_layer_with_repeated_source_fid_refused(scene: dict, tmp_path: Path) -> None:
    layer = scene["layer"].assign(source_fid=0)
    with pytest.raises(InputError, match="source_fid"):
        run_tiles(scene["tiles"][0].parent, {"building": layer}, tmp_path / "o")


def test_split_keeps_every_point_and_dimension(scene: dict) -> None:
    src = laspy.read(scene["whole"])
    parts = [laspy.read(p) for p in scene["tiles"]]
    assert sum(len(p.points) for p in parts) == len(src.points)
    assert all("reflectance" in p.point_format.dimension_names for p in parts)


@pytest.mark.slow
def test_tiles_on_dask_match_single_run_and_resume(scene: dict, tmp_path: Path) -> None:
    layers = {"building": scene["layer"]}
    cloud = read_cloud(scene["whole"])
    single = segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams())
    out = tmp_path / "out"
    events: list[dict] = []
    res = run_tiles(scene["root"] / "in", layers, out, workers=2, progress=events.append)
    assert set(res.status.values()) == {"done"}, res.status
    assert res.dashboard and events[-1]["done"] == events[-1]["total"] == 4
    merged = pyogrio.read_dataframe(out / "objects.gpkg", read_geometry=False)
    # every building (the one across the cut too) exactly once, whole
    assert sorted(merged["source_fid"]) == sorted(single.segmentation.objects["source_fid"])
    ref = dict(zip(single.segmentation.objects["source_fid"],
                   single.segmentation.objects["n_points"], strict=True))  # fmt: skip
    for fid, n in zip(merged["source_fid"], merged["n_points"], strict=True):
        assert abs(n - ref[fid]) <= 0.01 * ref[fid]
    # per tile: exactly its own points, in input order, every dimension kept
    world = cloud.world_xyz()
    seg = single.segmentation
    ref_fid = np.full(len(cloud), -1)
    lut = dict(zip(seg.objects["instance"], seg.objects["source_fid"], strict=True))
    ref_fid[seg.instance > 0] = [lut[i] for i in seg.instance[seg.instance > 0]]
    key = {tuple(np.round(p, 3)): k for k, p in enumerate(world)}
    agree = ground_agree = total = 0
    for tile in scene["tiles"]:
        src = laspy.read(tile)
        folder = out / "tiles" / tile.name.removesuffix(".laz")
        got = laspy.read(folder / "segmented.laz")
        assert np.array_equal(got.X, src.X) and np.array_equal(got.Y, src.Y)
        assert np.array_equal(got.reflectance, src.reflectance)
        fid, ground = labels_by_feature(folder)
        rows = np.array([key[tuple(p)] for p in np.round(np.column_stack(
            [src.x, src.y, src.z]), 3)])  # fmt: skip
        agree += int((fid == ref_fid[rows]).sum())
        ground_agree += int((ground == seg.ground[rows]).sum())
        total += len(rows)
    assert agree / total >= 0.999 and ground_agree / total >= 0.999
    index = gpd.read_file(out / "tiles.gpkg")
    assert list(index["status"]) == ["done"] * 4
    # resumed: nothing recomputed, same outputs
    before = {p: p.stat().st_mtime_ns for p in (out / "tiles").glob("*/segmented.laz")}
    again = run_tiles(scene["root"] / "in", layers, out)
    assert set(again.status.values()) == {"resumed"}
    assert {p: p.stat().st_mtime_ns for p in before} == before
    assert len(again.objects) == len(merged)


def test_tiles_in_different_crs_refused(tmp_path: Path) -> None:
    xyz, _ = _scene(np.random.default_rng(1))
    write_tile_las(tmp_path / "a.laz", xyz[xyz[:, 0] < X0 + 40])
    write_tile_las(tmp_path / "b.laz", xyz[xyz[:, 0] >= X0 + 40], crs="EPSG:32631")
    with pytest.raises(InputError, match="different CRSs") as exc:
        read_catalog(tmp_path)
    assert "a.laz" in str(exc.value) and "b.laz" in str(exc.value)


def test_duplicate_tiles_refused(scene: dict, tmp_path: Path) -> None:
    for p in scene["tiles"]:
        (tmp_path / p.name).write_bytes(p.read_bytes())
    (tmp_path / "copy.laz").write_bytes(scene["tiles"][0].read_bytes())
    with pytest.raises(InputError, match="duplicates") as exc:
        read_catalog(str(tmp_path / "*.laz"))
    assert "copy.laz" in str(exc.value)


def test_tile_index_gpkg(scene: dict, tmp_path: Path) -> None:
    index = gpd.GeoDataFrame(
        {"location": [str(p) for p in scene["tiles"]]},
        geometry=[shapely.Point(0, 0)] * len(scene["tiles"]), crs=RD,
    )  # fmt: skip
    index.to_file(tmp_path / "index.gpkg", engine="pyogrio")
    cat = read_catalog(tmp_path / "index.gpkg")
    assert len(cat.tiles) == 4 and cat.crs.equals(CRS.from_user_input(RD))


@pytest.mark.slow
def test_unreadable_tile_named_others_finish_exit_2(
    scene: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tiles = tmp_path / "in"
    tiles.mkdir()
    for p in scene["tiles"]:
        (tiles / p.name).write_bytes(p.read_bytes())
    (tiles / "broken.laz").write_bytes(b"LASF" + b"\0" * 50)
    scene["layer"].to_file(tmp_path / "b.gpkg", engine="pyogrio")
    out = tmp_path / "out"
    code = main(["complex", str(tiles), "-l", f"building={tmp_path / 'b.gpkg'}", "-o", str(out)])
    assert code == 2
    text = capsys.readouterr().out
    assert "broken.laz" in text
    assert len(list((out / "tiles").glob("*/segmented.laz"))) == 4
    index = gpd.read_file(out / "tiles.gpkg")
    assert (index["status"] == "done").sum() == 4
    assert index.loc[index["name"] == "broken", "status"].str.startswith("failed").all()


def test_missing_scheduler_clear_message(scene: dict, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot connect to the Dask scheduler"):
        run_tiles(scene["root"] / "in", {"building": scene["layer"]}, tmp_path / "o",
                  scheduler="tcp://127.0.0.1:9")  # fmt: skip


# ----------------------------------------------------------------------------- AHN3
@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("n", [2])
def test_ahn3_tiles_match_single_run(shared_data: Path, tmp_path: Path, n: int) -> None:
    d = shared_data / "delft_ahn3"
    cloud = read_cloud(d / "ahn3_tile1.laz")
    layers = {"building": read_layer(d / "bgt" / "bgt_pand.sqlite"),
              "wall": read_layer(d / "bgt" / "bgt_scheiding.sqlite")}  # fmt: skip
    cloud = replace(cloud, crs=layers["building"].crs)
    single = segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams())
    tiles = split_las(d / "ahn3_tile1.laz", tmp_path / "in", n, n)
    res = run_tiles(tmp_path / "in", layers, tmp_path / "out")
    assert set(res.status.values()) == {"done"}
    seg = single.segmentation
    merged = res.objects
    assert not merged.duplicated(["class", "source_fid"]).any()
    assert len(merged) == len(seg.objects)
    with laspy.open(d / "ahn3_tile1.laz") as reader:
        h = reader.header
    world = cloud.world_xyz()
    w = (h.maxs[0] - h.mins[0]) / n
    dd = (h.maxs[1] - h.mins[1]) / n
    col = np.clip(((world[:, 0] - h.mins[0]) // w).astype(int), 0, n - 1)
    row = np.clip(((world[:, 1] - h.mins[1]) // dd).astype(int), 0, n - 1)
    lut = {int(i): (c, int(f)) for i, c, f in
           zip(seg.objects["instance"], seg.objects["class"], seg.objects["source_fid"],
               strict=True)}  # fmt: skip
    agree = ground = 0
    for tile in tiles:
        c, r = map(int, tile.stem.split("_")[-2:])
        sel = np.flatnonzero((col == c) & (row == r))
        folder = tmp_path / "out" / "tiles" / tile.stem
        las = laspy.read(folder / "segmented.laz")
        objs = pyogrio.read_dataframe(folder / "objects.gpkg", read_geometry=False)
        mine = {int(i): (cl, int(f)) for i, cl, f in
                zip(objs["instance"], objs["class"], objs["source_fid"], strict=True)}  # fmt: skip
        got = [mine.get(int(i)) for i in las.instance]
        ref = [lut.get(int(i)) for i in seg.instance[sel]]
        agree += sum(a == b for a, b in zip(got, ref, strict=True))
        ground += int(((np.asarray(las.classification) == 2) == seg.ground[sel]).sum())
    # measured 99.96 % labels / 99.995 % ground on 4 tiles (world-aligned ground cells, the
    # city's parameters); issue target 99.9 %
    assert agree / len(cloud) >= 0.999
    assert ground / len(cloud) >= 0.999
