"""City scale: world-aligned ground cells, ground over tiles and the DTM mosaic (issue 19)."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest
from pyproj import CRS

from pyheracles.cli import main
from pyheracles.errors import InputError
from pyheracles.ground import aligned_grid, extract_ground, pass_through_of
from pyheracles.io import read_cloud
from pyheracles.tiles import read_catalog, run_ground_tiles, split_las, write_vrt

RD = "EPSG:28992"
X0, Y0 = 85_000.0, 447_000.0


def _terrain(rng: np.random.Generator) -> np.ndarray:
    """70 x 70 m of rolling ground on a 1 mm lattice, two buildings (one across x = 35 m)."""
    xy = rng.uniform(0, 70, (40_000, 2))
    z = 0.03 * xy[:, 0] + 0.4 * np.sin(xy[:, 1] / 9.0) + rng.normal(0, 0.02, len(xy))
    for x0, y0, x1, y1, h in ((28, 20, 44, 34, 7.0), (8, 48, 20, 60, 5.0)):
        roof = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
        z[roof] += h
    return np.round(np.column_stack([xy + [X0, Y0], z + 2.0]), 3)


def _write(path: Path, world: np.ndarray) -> Path:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [X0, Y0, 0.0]
    header.add_crs(CRS.from_user_input(RD))
    las = laspy.LasData(header)
    las.x, las.y, las.z = world[:, 0], world[:, 1], world[:, 2]
    las.write(path)
    return path


@pytest.fixture(scope="module")
def cut(tmp_path_factory: pytest.TempPathFactory) -> dict:
    root = tmp_path_factory.mktemp("ground_tiles")
    whole = _write(root / "whole.laz", _terrain(np.random.default_rng(7)))
    return {"root": root, "whole": whole, "tiles": split_las(whole, root / "in", 2, 2)}


def test_aligned_grid_edges_on_world_multiples_whatever_the_offset() -> None:
    rng = np.random.default_rng(0)
    world = np.round(rng.uniform(0, 30, (500, 2)), 3) + [512_700.0, 5_403_547.0]
    world[:50, 0] = np.round(world[:50, 0])  # exactly on a 1 m edge: the quantised case
    cells = []
    for origin in ([512_700.0, 5_403_547.0], [512_683.417, 5_403_529.5], [1e9 + 0.25, 1e9]):
        o = np.asarray(origin)
        local = world - o
        for cell in (1.0, 0.73):
            g = aligned_grid(local, cell, origin_m=o)
            west, north = g.x0_m + o[0], g.y0_m + o[1]
            # the edges are multiples of the cell in world coordinates (1 µm guard)
            assert abs(west / cell - round(west / cell)) * cell < 1e-5
            assert abs(north / cell - round(north / cell)) * cell < 1e-5
            rows, cols = g.index(local)
            assert (cols >= 0).all() and (cols < g.shape[1]).all()
            # the world cell of every point, independent of the origin
            cells.append(
                (cell, np.round(west / cell).astype(int) + cols,
                 np.round(north / cell).astype(int) - rows)
            )  # fmt: skip
    for cell in (1.0, 0.73):
        mine = [c for c in cells if c[0] == cell]
        for other in mine[1:]:
            np.testing.assert_array_equal(other[1], mine[0][1])
            np.testing.assert_array_equal(other[2], mine[0][2])


def test_aligned_grid_without_origin_is_the_covering_grid() -> None:
    xy = np.array([[0.3, 0.2], [5.2, 4.1]])
    g = aligned_grid(xy, 1.0)
    assert (g.x0_m, g.y0_m) == (0.3, 4.1)
    with pytest.raises(InputError, match="origin_m"):
        aligned_grid(xy, 1.0, origin_m=[np.nan, 0.0])


def test_ground_tiles_match_the_single_run_and_mosaic_is_seamless(cut: dict) -> None:
    import rasterio

    cloud = read_cloud(cut["whole"])
    single = extract_ground(cloud.xyz, "auto", max_object_size_m=20.0, origin_m=cloud.offset[:2],
                            pass_through=pass_through_of(cloud.attributes))  # fmt: skip
    out = cut["root"] / "out"
    res = run_ground_tiles(cut["root"] / "in", out, max_object_size_m=20.0)
    assert set(res.status.values()) == {"done"}
    key = {tuple(p): k for k, p in enumerate(np.round(cloud.world_xyz(), 3))}
    agree = total = 0
    for tile in cut["tiles"]:
        src = laspy.read(tile)
        got = laspy.read(out / "tiles" / tile.stem / "ground.laz")
        assert np.array_equal(got.X, src.X) and np.array_equal(got.Y, src.Y)  # own, in order
        rows = np.array([key[tuple(p)] for p in np.round(np.column_stack(
            [src.x, src.y, src.z]), 3)])  # fmt: skip
        agree += int(((np.asarray(got.classification) == 2) == single.mask[rows]).sum())
        total += len(rows)
    assert total == len(cloud)
    assert agree / total >= 0.999, agree / total
    with rasterio.open(res.paths["dtm"]) as vrt:
        assert vrt.crs.to_epsg() == 28992 and vrt.count == 2
        mosaic, t = vrt.read(1), vrt.transform
    assert (mosaic != -9999).all()  # seamless: every cell of the union covered
    g = single.dtm.grid
    c0 = round((g.x0_m + cloud.offset[0] - t.c) / t.a)
    r0 = round((t.f - (g.y0_m + cloud.offset[1])) / t.a)
    part = mosaic[r0 : r0 + g.shape[0], c0 : c0 + g.shape[1]]
    diff = np.abs(part - (single.dtm.z_m + cloud.offset[2]))[single.dtm.observed]
    assert np.percentile(diff, 99) < 0.01, np.percentile(diff, 99)
    # resumed: nothing recomputed
    before = {p: p.stat().st_mtime_ns for p in (out / "tiles").glob("*/dtm.tif")}
    again = run_ground_tiles(read_catalog(cut["root"] / "in"), out, max_object_size_m=20.0)
    assert set(again.status.values()) == {"resumed"}
    assert {p: p.stat().st_mtime_ns for p in before} == before


def test_ground_cli_on_a_folder_of_tiles(cut: dict, tmp_path: Path) -> None:
    out = tmp_path / "g"
    assert main(["ground", str(cut["root"] / "in"), "-o", str(out), "--method", "smrf"]) == 0
    assert (out / "dtm.vrt").is_file() and (out / "tiles.gpkg").is_file()
    assert len(list((out / "tiles").glob("*/ground.laz"))) == 4


def test_vrt_refuses_rasters_off_the_lattice(tmp_path: Path) -> None:
    import rasterio
    from affine import Affine

    for name, x0 in (("a.tif", 0.0), ("b.tif", 10.5)):
        with rasterio.open(
            tmp_path / name,
            "w",
            driver="GTiff",
            width=10,
            height=10,
            count=1,
            dtype="float32",
            transform=Affine(1.0, 0, x0, 0, -1.0, 10.0),
        ) as dst:
            dst.write(np.zeros((1, 10, 10), np.float32))  # fmt: skip
    with pytest.raises(InputError, match="not on the mosaic's grid"):
        write_vrt([tmp_path / "a.tif", tmp_path / "b.tif"], tmp_path / "m.vrt")
    assert write_vrt([], tmp_path / "none.vrt") is None
