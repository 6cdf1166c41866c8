"""Walls: a narrow light cut across by a sparse face's stray returns is one opening
(:func:`pyheracles.walls.bands.join_stray_bands`).

A face's occupancy is closed to bridge its scan lines' gaps; a few mixed pixels on the
outer face's plane inside a light 0.3-0.4 m wide were bridged to both jambs, and the
light was two or three windows one above the other (church draws 6, 23 and 26: nine
lights split, the walls' opening counts wrong).  The band holds no point of the dense
inner face; a transom of stone does.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls import segment_walls
from pyheracles.walls.bands import StrayBandParams, join_stray_bands

LIGHTS = ((2.0, 2.34), (2.56, 2.90))  # u ranges (m) of two narrow lights
SILL, HEAD, THICK = 1.5, 4.0, 0.5


def _face(rng: np.random.Generator, y: float, step: float, jitter: float,
          holes: list[tuple[float, float, float, float]]) -> np.ndarray:  # fmt: skip
    """A face 6 m long and 5 m high on the plane ``y`` (m), points ``step`` apart
    jittered by up to ``jitter``, without the ``holes`` (u0, u1, z0, z1)."""
    u, z = np.meshgrid(np.arange(0, 6.0, step), np.arange(0, 5.0, step), indexing="ij")
    u = u.ravel() + rng.uniform(-jitter, jitter, u.size)
    z = z.ravel() + rng.uniform(-jitter, jitter, z.size)
    keep = np.ones(u.size, dtype=bool)
    for u0, u1, z0, z1 in holes:
        keep &= ~((u > u0) & (u < u1) & (z > z0) & (z < z1))
    return np.c_[u[keep], y + rng.normal(0, 0.002, np.count_nonzero(keep)), z[keep]]


def _wall(seed: int, strays: bool = True, transom: bool = False) -> np.ndarray:
    """A wall 0.5 m thick with two lights 0.34 m wide (glass mid-wall, straight
    reveals): the inner face scanned from near (2 cm), the outer from afar (10 cm);
    ``strays``: three mixed pixels on the outer plane across each light at two heights;
    ``transom``: each light two, one above the other, either side of 0.15 m of stone."""
    rng = np.random.default_rng(seed)
    if transom:
        holes = [(a, b, z0, z1) for a, b in LIGHTS for z0, z1 in ((SILL, 2.7), (2.85, HEAD))]
    else:
        holes = [(a, b, SILL, HEAD) for a, b in LIGHTS]
    parts = [_face(rng, 0.0, 0.02, 0.005, holes), _face(rng, THICK, 0.1, 0.01, holes)]
    for u0, u1, z0, z1 in holes:
        u, z = np.meshgrid(np.arange(u0, u1, 0.03), np.arange(z0, z1, 0.03), indexing="ij")
        parts.append(np.c_[u.ravel(), np.full(u.size, 0.3), z.ravel()])
        for e in (u0, u1):
            y, z = np.meshgrid(np.arange(0.0, THICK, 0.03), np.arange(z0, z1, 0.03),
                               indexing="ij")  # fmt: skip
            parts.append(np.c_[np.full(y.size, e), y.ravel(), z.ravel()])
    if strays:
        for a, b in LIGHTS:
            for zr in (2.3, 3.2):
                u = rng.uniform(a + 0.08, b - 0.08, 3)
                y = THICK + rng.normal(0, 0.003, 3)
                parts.append(np.c_[u, y, zr + rng.normal(0, 0.01, 3)])
    return np.vstack(parts)


def _openings(xyz: np.ndarray) -> list[tuple[float, float, float, float]]:
    r = segment_walls(xyz)
    w = max(r.walls, key=lambda w: w.n_points)
    return sorted((-o.u_max, -o.u_min, o.z_min, o.z_max) for o in w.openings)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_narrow_light_cut_by_stray_returns_is_one_opening(seed: int) -> None:
    """Each light one window over its full height (within 5 cm), three noise draws;
    without the stray returns the same."""
    for strays in (True, False):
        ops = _openings(_wall(seed, strays))
        assert len(ops) == 2, ops
        for (u0, u1, z0, z1), (a, b) in zip(ops, LIGHTS, strict=True):
            assert abs(u0 - a) <= 0.05 and abs(u1 - b) <= 0.05
            assert abs(z0 - SILL) <= 0.05 and abs(z1 - HEAD) <= 0.05


def test_a_stone_transom_keeps_two_lights() -> None:
    """Lights one above the other either side of 0.15 m of stone, seen on both faces,
    stay two windows each (the stray returns too)."""
    ops = _openings(_wall(0, strays=True, transom=True))
    assert len(ops) == 4, ops
    for (_, _, z0, z1), (lo, hi) in zip(ops, [(SILL, 2.7), (2.85, HEAD)] * 2, strict=True):
        assert abs(z0 - lo) <= 0.05 and abs(z1 - hi) <= 0.05


def test_join_stray_bands_on_a_grid() -> None:
    """A band between two holes: filled when a face dense around holds no point in it,
    kept when it does (a transom), and when the holes do not overlap enough."""
    holes = np.zeros((12, 30), dtype=bool)
    holes[4:9, 3:12] = holes[4:9, 14:25] = True
    inner = ~holes
    inner[4:9, 12:14] = False
    sparse = np.zeros_like(holes)
    sparse[4:9:2, 12] = True  # a row of strays of the other face
    out = join_stray_bands(holes, [inner, sparse])
    assert np.array_equal(out[4:9, 12:14], np.ones((5, 2), dtype=bool))
    assert np.count_nonzero(out != holes) == 10
    assert np.array_equal(join_stray_bands(holes, [~holes, sparse]), holes)
    shifted = np.zeros_like(holes)
    shifted[4:9, 3:12] = shifted[7:11, 14:25] = True  # 2 of the narrower's 4 columns
    empty_band = ~shifted
    empty_band[4:11, 12:14] = False
    assert np.array_equal(join_stray_bands(shifted, [empty_band]), shifted)
    with pytest.raises(ValueError):
        StrayBandParams(empty=0.0)


@pytest.mark.slow  # simulates a church draw: about 20 s each
@pytest.mark.parametrize("noise_draw", [0, 1])
def test_church26_narrow_lights_are_one_opening_each(noise_draw: int) -> None:
    """Church draw 26 (two- and three-light windows of 0.3-0.37 m lights): two lights
    of the north wall and two of the south wall were each two or three windows one
    above the other on the draw's own scan (one or two more on noise draw 1); each
    light is one opening, and each wall has as many openings as the truth."""
    from church_walls import openings_over, wall_crop

    for name in ("north", "south"):
        xyz, tw, ops = wall_crop(26, name, noise_draw)
        n = np.asarray(tw["outer_plane"]["normal"])
        r = segment_walls(xyz)
        w = max(r.walls, key=lambda w: w.n_points if abs(w.normal @ n) > 0.99 else 0)
        assert openings_over(w, ops) == [1] * len(ops)
        assert len(w.openings) == sum(tw["openings"].values())
