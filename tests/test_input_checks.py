"""Issue 15: every command survives a careless user (memory, degenerate clouds, units, seeds).

Each case is a one-line error with exit code 2 that names the file and says what to
do, instead of a traceback, an allocation of hundreds of GiB or "z = nan".
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pyheracles.cli import main
from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.io import write_cloud
from pyheracles.resources import (
    available_memory_bytes,
    check_grid_memory,
    check_spread,
    format_bytes,
    smallest_cell_m,
)


def _write(tmp_path: Path, name: str, xyz: np.ndarray) -> Path:
    path = tmp_path / name
    write_cloud(PointCloud.from_world(np.asarray(xyz, dtype=np.float64)), path)
    return path


# ----------------------------------------------------------------------------- resources
@pytest.mark.parametrize("function", ["ground", "attic", "supports"])
def test_step_functions_refuse_degenerate_clouds(function: str) -> None:
    """The library steps themselves (not only the CLI's reader) name the file."""
    from pyheracles.building import segment_attic, segment_building
    from pyheracles.ground import extract_ground

    call = {
        "ground": lambda xyz: extract_ground(xyz, source="f.laz"),
        "attic": lambda xyz: segment_attic(xyz, source="f.laz"),
        "supports": lambda xyz: segment_building(xyz, source="f.laz"),
    }[function]
    with pytest.raises(InputError, match=r"^f\.laz: all 5000 points are at the same location"):
        call(np.full((5000, 3), 7.0))
    with pytest.raises(InputError, match=r"^f\.laz: only 1 point; .* need at least"):
        call(np.array([[1.0, 2.0, 3.0]]))


def test_check_grid_memory_refuses_with_the_numbers() -> None:
    assert check_grid_memory((1000, 1000), 8, "a raster", available_bytes=2**30) == 8_000_000
    with pytest.raises(InputError) as err:
        check_grid_memory(
            (800_000, 1_200_000), 96, "a DTM at 0.001 m cells over 1200 x 800 m",
            "--dtm-cell 0.5 or larger", path="site.laz", available_bytes=22 * 2**30,
        )  # fmt: skip
    text = str(err.value)
    assert text.startswith("site.laz: a DTM at 0.001 m cells over 1200 x 800 m needs ")
    assert "TiB; this machine has 22 GiB free. Fix: --dtm-cell 0.5 or larger" in text
    assert format_bytes(326 * 2**30) == "326 GiB" and format_bytes(1.5 * 2**20) == "1.5 MiB"
    assert available_memory_bytes() is None or available_memory_bytes() > 0
    # the suggested cell gives a grid within a quarter of the free memory
    cell = smallest_cell_m([1200.0, 800.0], 96, available_bytes=22 * 2**30)
    assert cell in (0.05, 0.1, 0.2, 0.5, 1.0)
    assert (1200 / cell) * (800 / cell) * 96 <= 0.25 * 22 * 2**30


@pytest.mark.parametrize(
    ("xyz", "message"),
    [
        (np.zeros((1, 3)), "only 1 point; supports need at least 10"),
        (np.ones((5000, 3)), "all 5000 points are at the same location"),
        (np.c_[np.zeros(50), np.zeros(50), np.arange(50.0)], "one vertical line"),
        (np.c_[np.arange(50.0), np.arange(50.0) % 7, np.zeros(50)], "same height"),
    ],
)
def test_check_spread(xyz: np.ndarray, message: str) -> None:
    with pytest.raises(DegenerateGeometryError, match=message):
        check_spread(xyz, step="supports", min_points=10, path="b.laz", need_z=True)


# ----------------------------------------------------------------------------- ground
def test_ground_refuses_a_dtm_larger_than_the_memory(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(0)
    xyz = np.c_[rng.uniform(0, 1200, 5000), rng.uniform(0, 800, 5000), rng.normal(0, 0.1, 5000)]
    xyz[:2, :2] = [[0, 0], [1200, 800]]
    src = _write(tmp_path, "site.laz", xyz + [500_000, 5_400_000, 0])
    out = tmp_path / "g"
    assert main(["ground", str(src), "--dtm-cell", "0.001", "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "a DTM at 0.001 m cells over 1200 x 800 m" in err and "needs" in err
    assert "free. Fix: --dtm-cell" in err and "or larger" in err
    assert str(src) in err
    assert not out.exists()


@pytest.mark.parametrize("command", ["ground", "attic", "supports"])
@pytest.mark.parametrize(
    ("xyz", "message"),
    [
        ([[1.0, 2.0, 3.0]], "only 1 point"),
        (np.full((5000, 3), 7.0), r"all 5000 points .*at the same location"),
    ],
)
def test_degenerate_clouds_are_refused_naming_the_file(
    command: str, xyz, message: str, tmp_path: Path, capsys
) -> None:
    src = _write(tmp_path, "tiny.laz", xyz)
    out = tmp_path / "out"
    assert main([command, str(src), "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert re.search(message, err) and "tiny.laz" in err, err
    assert "nan" not in err
    assert not out.exists()


def test_supports_in_millimetres_on_a_metre_cloud(tmp_path: Path, capsys) -> None:
    from pyheracles.synthetic.buildings import building_scene

    scene = building_scene("pavilion", spacing_m=0.12, rng=0)
    src = _write(tmp_path, "pavilion.laz", scene.xyz)
    assert main(["supports", str(src), "--units", "mm", "-o", str(tmp_path / "s")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "looks to be in metres already" in err and "pavilion.laz" in err


def test_section_clustering_refuses_a_pair_list_larger_than_the_memory(monkeypatch) -> None:
    """A millimetre cloud read as metres puts thousands of points within the clustering
    distance: the pair list is estimated and refused, not allocated (std::bad_alloc)."""
    import pyheracles.resources as res
    from pyheracles.supports import SupportParams, section_islands

    monkeypatch.setattr(res, "available_memory_bytes", lambda: 1_000_000)
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 0.05, (20_000, 2))
    with pytest.raises(InputError, match=r"clustering the section .* needs .* free"):
        section_islands(xy, SupportParams(), 0.03)


# ----------------------------------------------------------------------------- demo
def test_demo_with_a_negative_seed(tmp_path: Path, capsys) -> None:
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene

    with pytest.raises(InputError, match="seed must be a whole number >= 0, got -1"):
        kasepuhan_scene(ComplexSceneParams(seed=-1))
    assert main(["demo", "--seed", "-1", "-o", str(tmp_path / "d")]) == 2
    assert "seed must be a whole number >= 0" in capsys.readouterr().err
