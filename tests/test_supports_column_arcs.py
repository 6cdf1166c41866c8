"""A pier candidate whose points lie on a column's surface is an arc of that column
(issue 12, mode 1: "the ring must be recognised from its pieces"; the scorer's
``ring_split``: one column found twice).

Built from draw 18 of the supports family (a ruined portico of 13 columns): the main
section held an arc of its first column (r = 0.67 m) over 30 degrees, 0.62 m long and
12 cm deep, as a pier island; the low section found the column from another arc.  The
pier's 451 points lay 0.661-0.670 m from the column's axis: two supports for one.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.arcs import arc_owner
from pyheracles.supports.detect import join_arcs_to_columns

R = 0.666  # the column's radius, metres
TOL = 0.01  # surface tolerance
SEEDS = range(8)  # noise draws


def _column_row() -> dict:
    return {"class": "column", "x": 0.0, "y": 0.0, "z_min": 0.4, "z_max": 8.3,
            "radius_m": R, "radius_bottom_m": R, "radius_top_m": R, "axis_x": 0.0,
            "axis_y": 0.0, "axis_z": 1.0, "n_points": 0}  # fmt: skip


def _ring(rng: np.random.Generator, a0: float, a1: float, n: int, r: float = R) -> np.ndarray:
    """``n`` points on the cylinder of radius ``r`` between angles a0 and a1 (degrees)."""
    a = np.radians(rng.uniform(a0, a1, n))
    z = rng.uniform(0.6, 8.2, n)
    pts = np.c_[r * np.cos(a), r * np.sin(a), z]
    return pts + rng.normal(0.0, 0.003, pts.shape)


def _pier(rng: np.random.Generator, x0: float) -> np.ndarray:
    """The faces of a 0.5 x 0.3 m pier standing from x0 to x0 + 0.5 along x."""
    u = rng.uniform(0.0, 1.0, 600)
    z = rng.uniform(0.0, 3.0, 600)
    face = np.where(u < 0.5, 0, 1)
    x = np.where(face == 0, x0 + rng.uniform(0.0, 0.5, 600), x0)
    y = np.where(face == 0, -0.15, rng.uniform(-0.15, 0.15, 600))
    pts = np.c_[x, y, z]
    return pts + rng.normal(0.0, 0.003, pts.shape)


@pytest.mark.parametrize("seed", SEEDS)
def test_arc_of_a_column_found_as_a_pier_is_joined_to_it(seed: int) -> None:
    """Draw 18's split: the column's points round most of it, the 'pier' over 90-121
    degrees; the pier's points join the column, one support remains."""
    rng = np.random.default_rng(seed)
    col, arc = _ring(rng, -170.0, 85.0, 2400), _ring(rng, 90.0, 121.0, 450)
    p = np.vstack([col, arc])
    rows = [_column_row() | {"n_points": len(col)},
            {"class": "pier", "x": -0.2, "y": 0.66, "n_points": len(arc)}]  # fmt: skip
    members = [(np.arange(len(col)), True, 9.0, 0.0, True, False),
               (np.arange(len(col), len(p)), False, np.inf, 0.0, False, False)]  # fmt: skip
    assert join_arcs_to_columns(p, rows, members, TOL) == 1
    assert len(rows) == len(members) == 1
    assert rows[0]["class"] == "column" and rows[0]["n_points"] == len(p)
    assert np.array_equal(members[0][0], np.arange(len(p)))


@pytest.mark.parametrize("seed", SEEDS)
def test_pier_beside_a_column_and_a_thinner_ring_stay(seed: int) -> None:
    """A pier whose face passes 2 cm from the column's surface, and an arc of a ring 10
    cm smaller (another column's, standing inside the first's circle: a twin's), are no
    arcs of it."""
    rng = np.random.default_rng(seed)
    cols = [(_column_row(), _ring(rng, -170.0, 170.0, 2000))]
    assert arc_owner(_pier(rng, R + 0.02), cols, TOL) is None
    assert arc_owner(_ring(rng, 90.0, 121.0, 450, R - 0.1), cols, TOL) is None
    assert arc_owner(_ring(rng, 90.0, 121.0, 450), cols, TOL) == 0


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 3])
def test_draw_18_first_column_found_once(noise_draw: int) -> None:
    """Draw 18 (noise draws 0, 1 and 3): the first column's points go to one support,
    a column, and no pier is made of them."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    res = simulate("supports", 18, noise_draw=noise_draw).clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    own = (res.instance == 1) & ~res.outlier
    ids, counts = np.unique(found.instance[own], return_counts=True)
    big = ids[(ids > 0) & (counts >= 100)]
    assert len(big) == 1, dict(zip(ids.tolist(), counts.tolist(), strict=True))
    row = found.objects.set_index("instance").loc[int(big[0])]
    assert row["class"] == "column"
