"""Support detection on draws of the supports scene family that showed a failure mode
(issue 12).  Each test names the draw (seed) it is built from; the fast ones rebuild the
mechanism on a small synthetic support with the dimensions of that draw."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.building import segment_building
from pyheracles.geometry.sections import robust_floor, sort_order
from pyheracles.supports import SupportParams, detect_supports, section_islands
from pyheracles.supports.core import Scales
from pyheracles.supports.detect import support_shapes
from pyheracles.supports.profile import (
    attached_share,
    band_reach,
    carried_surface,
    wall_beside,
)
from pyheracles.synthetic.families import simulate


@pytest.fixture(scope="module")
def portico_with_outliers():
    """Draw 2: a portico whose outliers reach 2 m below the floor (the section search
    went down to 0.6 m above the floor, among the plinths)."""
    return simulate("supports", 2)


@pytest.fixture(scope="module")
def far_column():
    """Draw 16: a portico scanned from five stations; the columns far from them are
    crossed by scan lines up to 15 cm apart at the section, so the ring fell into arcs
    shorter than a support (noise) and pieces below ``min_points``: 12 of 14 missed.
    Cropped around column 12 (radius 0.28 m), 3 m x 3 m, every height."""
    sim = simulate("supports", 16)
    res = sim.clouds["cloud"]
    xy = res.xyz[:, :2]
    crop = (np.abs(xy[:, 0] - 31.0) <= 1.5) & (np.abs(xy[:, 1] - 3.2) <= 1.5)
    row = next(o for o in sim.scene.objects if o["instance"] == 12)
    return res.xyz[crop], res.instance[crop], res.outlier[crop], row


@pytest.mark.slow
def test_floor_is_the_lowest_dense_level_not_the_lowest_point(portico_with_outliers):
    sim = portico_with_outliers
    res = sim.clouds["cloud"]
    floor = float(sim.params.get("floor_z_m", 0.0))
    _, z_sorted = sort_order(res.xyz[:, 2])
    assert z_sorted[0] < floor - 1.0  # the outliers
    assert abs(robust_floor(z_sorted) - floor) < 0.05
    clean = np.sort(res.xyz[~res.outlier, 2])
    assert robust_floor(clean) == clean[0]  # a clean cloud: its lowest point


@pytest.mark.slow
def test_section_search_starts_at_the_floor(portico_with_outliers):
    sim = portico_with_outliers
    res = sim.clouds["cloud"]
    floor = float(sim.params.get("floor_z_m", 0.0))
    found = detect_supports(res.xyz)
    top = float(res.xyz[~res.outlier, 2].max())
    # the automatic section lies in 25-85 % of the body above the floor
    assert found.section_height >= floor + 0.2 * (top - floor)


@pytest.mark.slow
def test_ring_broken_into_arcs_is_one_column(far_column):
    xyz, inst, outlier, row = far_column
    true = (inst == 12) & ~outlier
    found = detect_supports(xyz)
    cols = found.objects[found.objects["class"] == "column"]
    assert len(cols) >= 1
    # the column found is the true one: most of its points, radius within 1 cm
    best = max(cols["instance"], key=lambda k: np.count_nonzero(true & (found.instance == k)))
    mine = found.instance == best
    tp = np.count_nonzero(true & mine)
    f1 = 2 * tp / (np.count_nonzero(true) + np.count_nonzero(mine))
    assert f1 > 0.9
    r = float(cols.set_index("instance").loc[best, "radius_m"])
    assert abs(r - row["radius_mean_m"]) < 0.01


@pytest.mark.slow
def test_section_of_far_column_gives_one_ring(far_column):
    xyz, inst, _, _ = far_column
    z = xyz[:, 2]
    sec = np.abs(z - 1.8) <= 0.045  # the step's 9 cm section at 1.8 m
    on = inst[sec] == 12
    islands = section_islands(xyz[sec, :2], SupportParams(), 0.036)
    rings = [i for i in islands if i.kind == "column" and on[i.index].mean() > 0.9]
    assert len(rings) == 1
    assert np.count_nonzero(on[rings[0].index]) >= 0.9 * np.count_nonzero(on)


# ------------------------------------------------------------------ synthetic (fast)
def _column(
    rng: np.random.Generator,
    radius: float = 0.2,
    plinth_half: float = 0.45,
    plinth_h: float = 0.108,
    top: float = 3.9,
    spacing: float = 0.01,
) -> tuple[np.ndarray, np.ndarray]:
    """Draw 0's aisle column (radius 0.2 m, square plinth of 0.45 m half width and
    0.108 m height, 3.9 m tall) as surface points with 3 mm noise; returns (xyz, part)
    with part 1 plinth, 2 shaft."""
    n_sh = int(2 * np.pi * radius * (top - plinth_h) / spacing**2)
    a = rng.uniform(-np.pi, np.pi, n_sh)
    shaft = np.c_[radius * np.cos(a), radius * np.sin(a), rng.uniform(plinth_h, top, n_sh)]
    n_top = int((4 * plinth_half**2 - np.pi * radius**2) / spacing**2)
    q = rng.uniform(-plinth_half, plinth_half, (3 * n_top, 2))
    q = q[np.hypot(q[:, 0], q[:, 1]) > radius][:n_top]
    ptop = np.c_[q, np.full(len(q), plinth_h)]
    n_side = int(8 * plinth_half * plinth_h / spacing**2)
    s = rng.uniform(-plinth_half, plinth_half, n_side)
    face = rng.integers(0, 4, n_side)
    x = np.select([face == 0, face == 1, face == 2], [s, plinth_half, s], -plinth_half)
    y = np.select([face == 0, face == 1, face == 2], [-plinth_half, s, plinth_half], s)
    side = np.c_[x, y, rng.uniform(0.0, plinth_h, n_side)]
    xyz = np.vstack([ptop, side, shaft])
    part = np.r_[np.ones(len(ptop) + len(side), int), np.full(len(shaft), 2)]
    return xyz + rng.normal(0, 0.003, xyz.shape), part


def _offsets(xyz: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    return np.hypot(xyz[:, 0], xyz[:, 1]) - radius, np.arctan2(xyz[:, 1], xyz[:, 0])


def test_band_reach_keeps_a_square_plinth_and_not_a_chair() -> None:
    """Mode 5 (draw 0: 50 of 50 columns lost their plinths, 5 % of plinth points kept): the
    reach comes from the support's own profile per height band; the plinth is reached to
    its corners, a chair seat touching the shaft (one side, 0.45 m high) is not."""
    rng = np.random.default_rng(0)
    xyz, part = _column(rng)
    seat = np.c_[rng.uniform(0.2, 0.6, 800), rng.uniform(-0.2, 0.2, 800), np.full(800, 0.45)]
    seat += rng.normal(0, 0.003, seat.shape)
    pts = np.vstack([xyz, seat])
    rho, ang = _offsets(pts, 0.2)
    reach = band_reach(rho, ang, pts[:, 2], 0.05, 48, 0.2, 0.03)
    keep = rho <= reach
    assert keep[: len(xyz)][part == 1].mean() > 0.97  # plinth top and sides, corners too
    assert keep[: len(xyz)][part == 2].mean() > 0.99
    assert keep[len(xyz) :][rho[len(xyz) :] > 0.06].mean() < 0.05  # the chair beyond 6 cm


def test_carried_surface_is_the_underside_of_a_ceiling_not_eaves_it_passes() -> None:
    """Mode 6 (draws 1 and 4: kiosks whose eaves hang below the column tops lost 29-50 %
    of each column to the attic): the top of a support is the underside of what it
    carries; a surface it passes through (its shaft goes on above) is not that."""
    rng = np.random.default_rng(1)
    xyz, _ = _column(rng, top=4.8)

    def slab(z: float, hole: float) -> np.ndarray:
        q = rng.uniform(-2.0, 2.0, (40_000, 2))
        q = q[np.hypot(q[:, 0], q[:, 1]) > hole]
        return np.c_[q, z + rng.normal(0, 0.003, len(q))]

    sc = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)
    buffer = 2.6 * 0.2
    # eaves at 3.7 m with the column passing through them, ceiling on top at 4.8 m
    pts = np.vstack([xyz, slab(3.7, 0.2), slab(4.8, 0.0)])
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= 0.2 + buffer + 0.3]
    rho, _ = _offsets(pts, 0.2)
    z_c, carried = carried_surface(pts[:, :2], pts[:, 2], rho, np.zeros(2), buffer, 0.3, sc, 2.0)
    assert z_c == pytest.approx(4.8, abs=0.015)
    assert not carried[pts[:, 2] < 4.7].any()
    # open sky (a broken column, a ruin): nothing carried
    rho0, _ = _offsets(xyz, 0.2)
    z0, _ = carried_surface(xyz[:, :2], xyz[:, 2], rho0, np.zeros(2), buffer, 0.3, sc, 2.0)
    assert z0 == np.inf


# ------------------------------------------------------------------ family draws (slow)
@pytest.mark.slow
def test_plinths_kept_on_draw_0() -> None:
    """Mode 5 on draw 0 itself (a hypostyle of 70 supports): column 22 with its plinth
    (0.45 m half width for a 0.2 m radius) cropped 2 m x 2 m, every height."""
    sim = simulate("supports", 0)
    res = sim.clouds["cloud"]
    crop = (np.abs(res.xyz[:, 0] - 6.04) <= 1.0) & (np.abs(res.xyz[:, 1] - 8.51) <= 1.0)
    inst, part = res.instance[crop], res.part[crop]
    found = detect_supports(res.xyz[crop])
    plinth = [k for k, v in sim.scene.part_names.items() if v == "plinth"]
    true = (inst == 22) & ~res.outlier[crop]
    best = np.bincount(found.instance[true]).argmax()
    assert best > 0
    mine = found.instance == best
    in_plinth = true & np.isin(part, plinth)
    assert np.count_nonzero(mine & in_plinth) >= 0.85 * np.count_nonzero(in_plinth)
    f1 = 2 * np.count_nonzero(mine & true) / (np.count_nonzero(mine) + np.count_nonzero(true))
    assert f1 > 0.95


@pytest.mark.slow
def test_columns_keep_their_height_above_the_attic_limit_on_draw_1() -> None:
    """Mode 6 on draw 1 (a kiosk of 10 columns 13.8 m tall whose attic split fell at
    4.75 m): the supports are cut from the whole cloud up to what they carry."""
    sim = simulate("supports", 1)
    res = sim.clouds["cloud"]
    seg, found, split, _ = segment_building(res.xyz)
    assert split.has_attic and split.limit_z < 6.0  # the split still falls low
    sup_ids = [o["instance"] for o in sim.scene.objects if o["class"] == "column"]
    true = np.isin(res.instance, sup_ids) & ~res.outlier
    assert np.mean(seg.class_id[true] == 2) < 0.05  # was 0.29 in the attic
    assert np.mean(found.instance[true] > 0) > 0.85
    assert seg.check_balance()["remainder"] == 0


def test_a_wall_edge_is_attached_a_free_pier_is_not() -> None:
    """Mode 4 (draws 2, 6 and 7: door jambs and ruined wall pieces cut off in the section
    became piers): a wall edge is joined to its wall in every height layer, a free pier
    only at the floor."""
    rng = np.random.default_rng(2)

    def plane(x0, x1, y0, y1, z0, z1, n):  # an axis-aligned rectangle of points
        return np.c_[rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(z0, z1, n)]

    pier = np.vstack(
        [plane(-0.3, 0.3, s, s, 0, 3, 6000) for s in (-0.3, 0.3)]
        + [plane(s, s, -0.3, 0.3, 0, 3, 6000) for s in (-0.3, 0.3)]
    )
    floor = plane(-1.5, 1.5, -1.5, 1.5, 0, 0, 20_000)
    wall = np.vstack(
        [plane(0.3, 1.5, -0.3, -0.3, 0, 3, 10_000), plane(0.3, 1.5, 0.3, 0.3, 0, 3, 10_000)]
    )
    sc = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)

    def share(pts: np.ndarray) -> float:
        pts = pts + rng.normal(0, 0.003, pts.shape)
        u = np.abs(pts[:, :2])
        rho = np.maximum(u[:, 0] - 0.3, u[:, 1] - 0.3)
        return attached_share(pts[:, :2], pts[:, 2], rho, np.zeros(2), 0.2, 0.3, sc, (0.1, 2.9))

    assert share(np.vstack([pier, floor])) < 0.1
    assert share(np.vstack([pier, floor, wall])) > 0.9


@pytest.fixture(scope="module")
def peristyle_ruin():
    """Draw 5: a ruined peristyle of 67 supports, the aisle and twin columns 0.118 m in
    radius, scanned sparsely (13-40 points of each in a 5 cm slab at the section)."""
    return simulate("supports", 5)


def _section_rings(sim, inst: int):
    res = sim.clouds["cloud"]
    row = next(o for o in sim.scene.objects if o["instance"] == inst)
    c = np.asarray(row["axis_base"][:2])
    crop = (np.abs(res.xyz[:, 0] - c[0]) <= 1.5) & (np.abs(res.xyz[:, 1] - c[1]) <= 1.5)
    xyz, ins = res.xyz[crop], res.instance[crop]
    sec = np.abs(xyz[:, 2] - 1.83) <= 0.0255  # the step's section on this draw
    on = ins[sec] == inst
    islands = section_islands(xyz[sec, :2], SupportParams(), 0.030)
    return [i for i in islands if i.kind == "column" and on[i.index].mean() > 0.9], on, row


@pytest.mark.slow
def test_small_column_ring_from_its_arcs(peristyle_ruin):
    """Mode 1 on draw 5: a column of radius 0.118 m whose ring broke into arcs was below
    the ring radii recognised (0.15-1.5 m): 52 of 65 supports missed."""
    rings, on, row = _section_rings(peristyle_ruin, 4)
    assert len(rings) == 1
    assert len(rings[0].index) >= 0.9 * np.count_nonzero(on)
    assert abs(rings[0].radius - row["radius_bottom_m"]) < 0.01


@pytest.mark.slow
def test_sparse_section_points_grouped_at_their_own_spacing(peristyle_ruin):
    """Mode 1 on draw 5: column 21's 35 section points are further apart than the
    clustering distance of the dense surfaces (3 cm): grouped again at their own spacing
    they are one column."""
    rings, _, row = _section_rings(peristyle_ruin, 21)
    assert len(rings) == 1
    assert abs(rings[0].radius - row["radius_bottom_m"]) < 0.01


def test_engaged_column_found_from_the_wall_plane_not_a_point_count() -> None:
    """Mode 3 (draw 0: engaged columns of 0.2 m radius standing 0.1 m in front of the
    wall face, the wall beside them in their shadow, classed free-standing): the wall
    plane is found from the cells a wall fills over the upper half of the column; a
    fence 1 m high beside a column is no wall."""
    rng = np.random.default_rng(3)
    sc = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)
    n = 30_000
    # the wall face y = -0.1 on both sides of the column, with a 0.3 m shadow next to it
    x = rng.uniform(-0.9, 0.9, n)
    x = x[np.abs(x) > 0.3]
    wall = np.c_[x, np.full(len(x), -0.1), rng.uniform(0.0, 4.0, len(x))]
    wall += rng.normal(0, 0.003, wall.shape)
    rho = np.hypot(wall[:, 0], wall[:, 1]) - 0.2
    face = wall_beside(wall[:, :2], wall[:, 2], rho, np.zeros(2), 0.2, sc, (2.0, 3.9))
    assert face is not None
    normal, d = face
    assert abs(abs(normal[1]) - 1.0) < 0.01 and normal[1] > 0  # towards the axis
    assert d == pytest.approx(-0.1 * normal[1], abs=0.03)
    fence = wall[wall[:, 2] < 1.0]
    rho_f = np.hypot(fence[:, 0], fence[:, 1]) - 0.2
    assert wall_beside(fence[:, :2], fence[:, 2], rho_f, np.zeros(2), 0.2, sc, (2.0, 3.9)) is None
    # a wall 0.8 m away (the side clearance of the family) is not one the column stands in
    far = wall + [0.0, -0.7, 0.0]
    rho_w = np.hypot(far[:, 0], far[:, 1]) - 0.2
    assert wall_beside(far[:, :2], far[:, 2], rho_w, np.zeros(2), 0.2, sc, (2.0, 3.9)) is None


@pytest.mark.slow
def test_broken_columns_below_the_section_on_draw_6() -> None:
    """Mode 2 on draw 6 (a ruined hypostyle; its section at 3.4 m above the platform):
    broken columns of 1.5-3.3 m never reached the section and were missed; the lower
    section finds them, and a column carrying nothing needs 1.5 m, not half the body."""
    sim = simulate("supports", 6)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    for inst in (2, 16):  # 1.53 m and 3.12 m tall stumps
        row = next(o for o in sim.scene.objects if o["instance"] == inst)
        assert row["broken"] and row["z_top"] < found.section_height
        true = (res.instance == inst) & ~res.outlier
        best = np.bincount(found.instance[true]).argmax()
        assert best > 0
        mine = found.instance == best
        f1 = 2 * np.count_nonzero(mine & true) / (np.count_nonzero(mine) + np.count_nonzero(true))
        assert f1 > 0.95
        assert found.objects.set_index("instance").loc[best, "class"] == "column"


def _outline_in_two_pieces(gap_m: float) -> np.ndarray:
    """Section points of a 0.94 m x 0.80 m pier (draw 14, pier 17) whose outline broke at
    two opposite corners, ``gap_m`` wide: two L-shaped pieces, each a pier island."""
    rng = np.random.default_rng(14)
    w, d, step = 0.94, 0.80, 0.01
    c = np.array([[0.0, 0.0], [w, 0.0], [w, d], [0.0, d]])

    def face(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        t = np.arange(0.0, 1.0, step / float(np.hypot(*(b - a))))[:, None]
        return a + t * (b - a)

    pts = np.vstack(
        [
            face(c[0] + [gap_m, 0], c[1]),
            face(c[1], c[2] - [0, gap_m]),
            face(c[2] - [gap_m, 0], c[3]),
            face(c[3], c[0] + [0, gap_m]),
        ]
    )
    pts = np.vstack([pts, pts])
    return pts + rng.normal(0, 0.003, pts.shape)


def test_pier_outline_broken_at_its_corners_is_one_pier() -> None:
    """Draws 12 and 14 (one-face piers): the outline of a pier seen from one or two sides
    broke at its corners, where the scan lines graze its faces; each piece was a pier
    island of its own, a partial rectangle later taken for a jamb (joined, in every
    layer, to its own other faces).  The pieces are grouped again into one rectangle."""
    params = SupportParams()
    sc = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)
    rng = np.random.default_rng(0)

    def piers(xy: np.ndarray) -> list[dict]:
        islands = section_islands(xy, params, sc.distance)
        shapes, _ = support_shapes(xy, islands, params, sc, rng)
        return [sh for sh in shapes if sh["class"] == "pier"]

    one = _outline_in_two_pieces(0.12)
    assert sum(i.kind == "pier" for i in section_islands(one, params, sc.distance)) == 2
    found = piers(one)
    assert len(found) == 1
    np.testing.assert_allclose(np.sort(2 * found[0]["half"]), [0.80, 0.94], atol=0.03)
    # two piers side by side 0.5 m apart stay two (wider than any regrouping gap)
    assert len(piers(np.vstack([one, one + [1.44, 0.0]]))) == 2


@pytest.mark.slow
def test_piers_seen_in_pieces_found_on_draw_14() -> None:
    """Draw 14 (a peristyle): corner pier 1 (1.88 m x 1.60 m) was missed, its section
    island one face and a corner (1.96 m x 0.44 m), the rest of its outline in noise and
    unclustered points, taken for a wall edge (joined to its own other faces)."""
    sim = simulate("supports", 14)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    for inst in (1,):
        true = (res.instance == inst) & ~res.outlier
        best = np.bincount(found.instance[true]).argmax()
        assert best > 0
        row = found.objects.loc[found.objects["instance"] == best].iloc[0]
        assert row["class"] == "pier"
        mine = found.instance == best
        f1 = 2 * np.count_nonzero(mine & true) / (np.count_nonzero(mine) + np.count_nonzero(true))
        assert f1 > 0.8  # 0.83: missed before (F1 0)
