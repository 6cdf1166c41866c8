"""Section-island model of the supports on the failures of supports-family draws (issue
12): each test rebuilds, on a small synthetic scene with the dimensions of the draw that
showed it, the mechanism that failed there."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.building import segment_building
from pyheracles.geometry.sections import robust_floor
from pyheracles.supports import SupportParams, detect_supports, section_islands
from pyheracles.supports.core import Scales
from pyheracles.supports.detect import wall_pieces
from pyheracles.supports.height import dense_extent
from pyheracles.supports.sections import classify_island, sparse_gaps, sparse_group


def _rect_outline(cx: float, cy: float, w: float, d: float, step: float) -> np.ndarray:
    """Points every ``step`` along the outline of a ``w`` x ``d`` rectangle."""
    t = np.arange(0.0, 2 * (w + d), step)
    pts = []
    for s in t:
        if s < w:
            pts.append((s, 0.0))
        elif s < w + d:
            pts.append((w, s - w))
        elif s < 2 * w + d:
            pts.append((w - (s - w - d), d))
        else:
            pts.append((0.0, d - (s - 2 * w - d)))
    return np.asarray(pts) + [cx - w / 2, cy - d / 2]


def test_building_extent_from_dense_levels_not_the_roof_or_outliers() -> None:
    """Draw 23: a kiosk photographed from above (floor 0.69 m, roof 12.4-13.1 m): the roof
    is the fullest level and the floor under it holds few points, so the floor as the
    lowest level of 5 % of the fullest was the roof (section searched at 19 m, in the
    sky of outliers reaching 25 m): no support found."""
    rng = np.random.default_rng(23)
    floor = rng.uniform(0.0, 0.69, 7_000)  # ground and platform seen between supports
    shafts = rng.uniform(0.69, 12.4, 280_000)  # columns and piers
    roof = np.r_[rng.uniform(12.4, 13.1, 30_000), rng.normal(13.1, 0.004, 100_000)]
    outliers = np.r_[rng.uniform(-0.65, -0.1, 300), rng.uniform(13.7, 25.5, 2_500)]
    z = np.sort(np.r_[floor, shafts, roof, outliers])
    assert robust_floor(z) > 12.0  # the failure: the roof taken for the floor
    bottom, top = dense_extent(z)
    assert abs(bottom - 0.0) < 0.05
    assert abs(top - 13.11) < 0.05
    clean = np.sort(np.r_[floor, shafts, roof])
    assert dense_extent(clean) == (clean[0], clean[-1])
    assert np.isnan(dense_extent(np.zeros(0))[0])


def test_ruin_columns_above_its_broken_walls_are_found() -> None:
    """Draw 24: a roofless hypostyle whose walls broke off at 1.5 m while its columns
    stand 3.3 m; above the walls the hull shrinks as at an attic, and the section,
    searched only below that limit, fell among the plinths: no support found."""
    rng = np.random.default_rng(24)
    parts = []
    for x in np.arange(-6.0, 6.01, 0.02):  # perimeter walls, 12 x 12 m, 1.5 m tall
        for z in np.arange(0.0, 1.5, 0.02):
            parts += [(x, -6.0, z), (x, 6.0, z), (-6.0, x, z), (6.0, x, z)]
    walls = np.asarray(parts)
    g = np.arange(-5.0, 5.01, 0.03)
    gx, gy = np.meshgrid(g, g)
    floor = np.c_[gx.ravel(), gy.ravel(), np.zeros(gx.size)]
    cols = []
    centres = [(x, y) for x in (-3.0, -1.0, 1.0, 3.0) for y in (-3.0, -1.0, 1.0, 3.0)]
    for cx, cy in centres:  # 16 columns of radius 0.2 m, 3.3 m tall
        a = rng.uniform(0, 2 * np.pi, 9_000)
        z = rng.uniform(0.0, 3.3, 9_000)
        cols.append(np.c_[cx + 0.2 * np.cos(a), cy + 0.2 * np.sin(a), z])
    xyz = np.vstack([walls, floor, *cols]) + rng.normal(0, 0.002, (1, 3))
    seg, found, split, _ = segment_building(xyz)
    assert split.has_attic  # what the attic split says about a ruin
    assert found.section_height > split.limit_z  # the section rises above it
    got = found.objects[found.objects["class"] == "column"]
    assert len(got) == 16
    for cx, cy in centres:
        assert np.min(np.hypot(got["x"] - cx, got["y"] - cy)) < 0.05
    assert seg.check_balance()["remainder"] == 0


def test_sparse_piers_grouped_at_their_own_scan_line_gap() -> None:
    """Draw 12: a hypostyle of 35 piers 0.72 x 0.64 m, scanned from five stations: at the
    section most piers are crossed by scan lines 5-20 cm apart (bunches of points along
    each line), while walls near a station set a clustering distance of 3 cm: 26 of 35
    piers missed."""
    rng = np.random.default_rng(12)
    wall = np.c_[np.arange(0.0, 12.0, 0.003), np.full(4000, -3.0)]  # dense: 3 cm distance
    piers, centres = [], []
    for k, gap in enumerate((0.06, 0.1, 0.14, 0.18)):
        c = (2.0 * k, 2.0)
        centres.append(c)
        lines = _rect_outline(*c, 0.72, 0.64, gap)
        bunch = np.repeat(lines, 6, axis=0) + rng.normal(0, 0.003, (6 * len(lines), 2))
        piers.append(bunch)
    xy = np.vstack([wall, *piers])
    got = section_islands(xy, SupportParams(), 0.03)
    found = [i for i in got if i.kind == "pier"]
    for c in centres:
        near = [i for i in found if np.hypot(*(i.center - c)) < 0.1]
        assert len(near) == 1, c
        assert np.allclose(sorted(near[0].size), [0.64, 0.72], atol=0.04)
    assert sparse_gaps(0.03)[0] == 0.2 and sparse_gaps(0.3) == []


def test_pieces_of_a_thick_wall_between_openings_are_walls() -> None:
    """Draw 28: a portico's back wall 1.33 m thick with doors 1-3 m wide; the pieces
    between the doors, with their reveals, are closed rectangles like piers (three
    spurious piers); they lie on the lines of the wall's faces, a free pier does not."""
    rng = np.random.default_rng(28)
    step = 0.01
    face_out = np.c_[np.arange(-1.0, 7.9, step), np.full(890, -1.33)]
    face_in = np.c_[np.arange(-1.0, 7.9, step), np.zeros(890)]
    # pieces between openings: x 8.7-10.0, 11.1-12.3, 13.9-15.9 (the last 2.6 m beyond)
    pieces = [
        _rect_outline((a + b) / 2, -0.665, b - a, 1.33, step)
        for a, b in ((8.7, 10.0), (11.1, 12.3), (13.9, 15.9))
    ]
    pier = _rect_outline(10.0, 3.0, 0.8, 0.8, step)  # a free pier in front of the wall
    xy = np.vstack([face_out, face_in, *pieces, pier]) + rng.normal(0, 0.002, (1, 2))
    isl = section_islands(xy, SupportParams(), 0.04)
    sc = Scales(spacing=step, distance=0.04, thickness=0.05, tol=0.03)
    bad = wall_pieces(xy, isl, sc)
    kinds = {k: i for k, i in enumerate(isl) if i.kind == "pier"}
    assert len(kinds) == 4
    free = [k for k, i in kinds.items() if np.hypot(*(i.center - (10.0, 3.0))) < 0.05]
    assert len(free) == 1
    assert bad == set(kinds) - set(free)


def _arc(cx: float, cy: float, r: float, a0: float, a1: float, n: int, rng) -> np.ndarray:
    a = rng.uniform(a0, a1, n)
    return np.c_[cx + r * np.cos(a), cy + r * np.sin(a)] + rng.normal(0, 0.003, (n, 2))


def test_half_ring_of_a_small_column_is_a_column_not_a_pier() -> None:
    """Draw 21: a ruined peristyle with small columns (radius 0.09 m) scanned from one
    side: the half rings (hull circularity 1.35-1.55) fit a circle within the noise
    (3 mm) but a rectangle nearly as well, and were called piers (6 columns)."""
    rng = np.random.default_rng(21)
    for n in (20, 40, 80):
        p = _arc(0.0, 0.0, 0.089, -0.2, np.pi + 0.2, n, rng)
        isl = classify_island(p, np.arange(n), SupportParams())
        assert isl.kind == "column", n
        assert abs(isl.radius - 0.089) < 0.01
    # a pier seen on two faces (an L) stays a pier
    leg = np.linspace(0.0, 0.3, 30)
    ell = np.r_[np.c_[leg, np.zeros(30)], np.c_[np.zeros(30), leg]] + rng.normal(0, 0.003, (60, 2))
    assert classify_island(ell, np.arange(60), SupportParams()).kind == "pier"


def test_twin_rings_grouped_as_one_are_two_columns() -> None:
    """Draw 29: a portico of columns of radius 0.17 m, some in twin pairs, sparse at the
    section (25-40 points each): at the largest regrouping gap two rings side by side
    were one group whose rectangle (0.72 x 0.32 m) passed the pier test (5 columns
    classed as piers)."""
    rng = np.random.default_rng(29)
    p = np.r_[
        _arc(0.0, 0.0, 0.17, 0, 2 * np.pi, 30, rng), _arc(0.38, 0.0, 0.17, 0, 2 * np.pi, 30, rng)
    ]
    got = sparse_group(p, np.arange(len(p)), SupportParams())
    assert [i.kind for i in got] == ["column", "column"]
    centres = sorted(tuple(np.round(i.center, 1)) for i in got)
    assert np.allclose(centres, [(0.0, 0.0), (0.4, 0.0)], atol=0.05)
    # a real sparse pier stays one pier
    sq = _rect_outline(0.0, 0.0, 0.72, 0.32, 0.02) + rng.normal(0, 0.003, (104, 2))
    got = sparse_group(sq, np.arange(len(sq)), SupportParams())
    assert [i.kind for i in got] == ["pier"]


def test_sparse_columns_found_on_the_thick_section() -> None:
    """Draw 5: a ruined peristyle far from its stations: columns of radius 0.18 m hold
    a few hundred points each (10-20 in the thin section, below ``min_points``), while a
    dense wall sets the spacing: 21 of 65 columns missed."""
    rng = np.random.default_rng(5)
    g = np.arange(0.0, 12.0, 0.01)
    gz = np.arange(0.0, 3.5, 0.01)
    wx, wz = np.meshgrid(g, gz)
    wall = np.c_[wx.ravel(), np.full(wx.size, -2.0), wz.ravel()]  # dense: 1 cm
    fg = np.arange(-1.0, 12.0, 0.05)
    fx, fy = np.meshgrid(fg, np.arange(-2.0, 4.0, 0.05))
    floor = np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]
    centres = [(1.0 + 2.0 * k, 1.5) for k in range(5)]
    cols = []
    for cx, cy in centres:  # 250 points each on 3.5 m: ~4 in a 5 cm slab, ~21 in 30 cm
        a = rng.uniform(0, 2 * np.pi, 250)
        z = rng.uniform(0.0, 3.5, 250)
        cols.append(np.c_[cx + 0.18 * np.cos(a), cy + 0.18 * np.sin(a), z])
    xyz = np.vstack([wall, floor, *cols]) + rng.normal(0, 0.002, (1, 3))
    found = detect_supports(xyz, SupportParams(section_height_m=None))
    got = found.objects[found.objects["class"] == "column"]
    assert len(got) == 5
    for cx, cy in centres:
        assert np.min(np.hypot(got["x"] - cx, got["y"] - cy)) < 0.05


def test_scaffold_tower_round_a_column_is_no_wall() -> None:
    """Draw 1: a kiosk column standing in a scaffold tower (corner tubes of 2.4 cm
    radius 5 cm beyond the column, seen from one side): the two tubes in front fill
    two cells each on one line over the whole height, which the wall test took for the
    wall the column is engaged in (a free column classed engaged)."""
    from pyheracles.supports.profile import wall_beside

    rng = np.random.default_rng(1)
    sc = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)
    r = 0.3
    a = r + 0.05
    pts = []
    for tx in (-a, a):  # the two front tubes, their front halves seen, 6 m tall
        t = rng.uniform(np.pi, 2 * np.pi, 4000)
        z = rng.uniform(0, 6, 4000)
        pts.append(np.c_[tx + 0.024 * np.cos(t), -a + 0.024 * np.sin(t), z])
    tower = np.vstack(pts)
    tower[:, :2] += rng.normal(0, 0.005, (len(tower), 2))  # the scan noise

    rho = np.hypot(tower[:, 0], tower[:, 1]) - r
    assert wall_beside(tower[:, :2], tower[:, 2], rho, np.zeros(2), r, sc, (3.0, 5.9)) is None
    # a continuous face on the same line is a wall
    x = rng.uniform(-1.0, 1.0, 24_000)
    face = np.c_[x, np.full(len(x), -a), rng.uniform(0, 6, len(x))]
    rho_f = np.hypot(face[:, 0], face[:, 1]) - r
    assert wall_beside(face[:, :2], face[:, 2], rho_f, np.zeros(2), r, sc, (3.0, 5.9)) is not None


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed",
    [
        1,
        pytest.param(3, marks=pytest.mark.xfail(strict=True, reason=(
            "per-ray noise draw: clutter merged, a jamb as a pier"))),
        pytest.param(8, marks=pytest.mark.xfail(strict=True, reason=(
            "per-ray noise draw: clutter merged, a support missed, plinth lost"))),
        9,
        pytest.param(10, marks=pytest.mark.xfail(strict=True, reason=(
            "per-ray noise draw: attic cut, clutter merged, a wrong class"))),
        17,
        28,
    ],
)  # fmt: skip
def test_family_draws_meet_the_main_target(seed: int) -> None:
    """Draw 1 (a kiosk whose scaffold tower gave a 'column' of a tube's 2 cm radius and
    made a free column engaged), draw 28 (a portico whose thick back wall gave three
    piers), draws 3 and 9 (wall pieces between openings as piers; in draw 3 a fence
    post carrying its rail too), draw 8 (a 0.3 m pier with 7 points in the thin
    section, found in the thick one), draw 10 (a sign's panel and a pile of debris,
    0.2-0.44 m tall, "carrying" their board and a block) and draw 17 (pulpit stems as
    broken columns, a fallen drum as a pier): support count exact, every class right,
    median per-support F1 >= 0.95."""
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", seed)
    seg, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    m = score_supports(
        sim, found.instance, found.objects, section_height=found.section_height,
        attic_mask=seg.class_id == 2,
    )  # fmt: skip
    assert m["pass"]["main"], m["failure_modes"]
    cols = found.objects[found.objects["class"] != "pier"]
    assert (cols["radius_m"] >= 0.05).all()
