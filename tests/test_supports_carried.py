"""What a support stands on and carries (issue 12, step 2a): pulpit posts taken for
columns (failure mode 8) and wall pieces on a podium taken for piers (mode 4), each
rebuilt from the draw of the supports family that showed it."""

from __future__ import annotations

import numpy as np

from pyheracles.supports import SupportParams, detect_supports
from pyheracles.supports.carriers import low_carriers
from pyheracles.supports.cookies import foot_levels
from supports_draws import tub_sides, tube


def _grid(u0: float, u1: float, v0: float, v1: float, step: float) -> np.ndarray:
    """``(M, 2)`` points every ``step`` metres over a rectangle."""
    u, v = np.meshgrid(np.arange(u0, u1 + 1e-9, step), np.arange(v0, v1 + 1e-9, step))
    return np.c_[u.ravel(), v.ravel()]


def _horizontal(x0, x1, y0, y1, z: float, step: float) -> np.ndarray:
    xy = _grid(x0, x1, y0, y1, step)
    return np.c_[xy, np.full(len(xy), z)]


def _tub_underside(centre, z: float, step: float) -> np.ndarray:
    """The underside of a pulpit's 1.2 x 1.0 m tub (its sides lie beyond the cookie)."""
    cx, cy = centre
    return _horizontal(cx - 0.6, cx + 0.6, cy - 0.5, cy + 0.5, z, step)


def _room(ceiling: float | None, post_m: float, step: float = 0.03) -> np.ndarray:
    """Four columns 0.15 m in radius from the floor to ``ceiling`` (or broken at 2.0 m
    under the open sky when ``None``) and a pulpit post of 0.12 m up to ``post_m``."""
    top = ceiling if ceiling is not None else 2.0
    parts = [_horizontal(0.0, 9.0, 0.0, 6.0, 0.0, step)]
    if ceiling is not None:
        parts.append(_horizontal(0.0, 9.0, 0.0, 6.0, ceiling, step))
    for x in (1.5, 3.5, 5.5, 7.5):
        parts.append(tube((x, 1.5), 0.15, 0.0, top, step))
    parts += [tube((4.5, 4.0), 0.12, 0.0, post_m, step), _tub_underside((4.5, 4.0), post_m, step)]
    rng = np.random.default_rng(8)
    xyz = np.vstack(parts)
    return xyz + rng.normal(0, 0.002, xyz.shape)


def test_pulpit_post_under_a_ceiling_is_no_column() -> None:
    """Draws 8 and 25 (peristyles under a flat ceiling or an attic at 2.6 m): pulpit posts
    0.12 m in radius, 1.2-1.8 m tall, "carried" their tubs and were columns (12 false
    columns in draw 8; the one false support of draw 25).  A column carries the building
    where its other supports carry it; a post carrying its tub 1.5 m up under a 2.6 m
    ceiling stays in the body; the four columns are found."""
    xyz = _room(2.6, 1.5)
    found = detect_supports(xyz, SupportParams(section_height_m=1.0))
    assert list(found.objects["class"]) == ["column"] * 4, found.objects
    post = np.hypot(xyz[:, 0] - 4.5, xyz[:, 1] - 4.0) < 0.7
    assert not found.instance[post].any()


def test_broken_columns_of_a_ruin_stay() -> None:
    """Under the open sky the broken columns (2.0 m) carry nothing and are all kept; the
    pulpit post (1.5 m, 0.8 of their radius) carries its tub below the tops they stand
    to, and goes (draw 3: a fence post carrying its rail among broken columns)."""
    xyz = _room(None, 1.5)
    found = detect_supports(xyz, SupportParams(section_height_m=1.0))
    assert (found.objects["class"] == "column").sum() == 4, found.objects
    assert (found.objects["z_max"] > 1.9).all()


def test_low_carriers_by_level() -> None:
    """The carried level is the median underside of what the supports carry: a column on
    a dais reaching it from a higher floor stays, and one seen only from 1.35 to 2.58 m
    that carries the ceiling (draw 36); a low column goes, carrying or not, where most
    supports carry, a pier carrying something low stays (a gallery may cut it: held-out
    draw 44); in a ruin (most carry nothing) only a low carrier goes, pier or column (a
    post under its rail: draw 3), below the median top of the supports carrying
    nothing when fewer than three carry."""
    col = {"class": "column", "z_min": 0.0, "z_max": 2.6}
    rows = [col] * 4 + [
        {"class": "column", "z_min": 0.8, "z_max": 2.6},  # on a dais
        {"class": "column", "z_min": 1.35, "z_max": 2.58},  # foot and top unseen
        {"class": "column", "z_min": 0.0, "z_max": 1.5},  # a post under its tub
        {"class": "column", "z_min": 0.0, "z_max": 1.8},  # a post, its tub unseen
        {"class": "pier", "z_min": 0.0, "z_max": 1.5},  # cut by a gallery / a post
        {"class": "engaged_column", "z_min": 0.0, "z_max": 1.5},
    ]
    rows = [{**r, "x": 3.0 * (k % 5), "y": 3.0 * (k // 5)} for k, r in enumerate(rows)]
    inf = float("inf")
    carried_z = [2.62] * 6 + [1.52, inf, 1.52, 1.52]
    carries = [True] * 7 + [False, True, True]
    assert low_carriers(rows, carries, carried_z) == {6, 7}
    ruin = [False] * 6 + [True, False, False, False]  # one carries, at 1.52 m
    assert low_carriers(rows, ruin, carried_z) == {6}  # the others stand to 2.6 m
    ruin[8] = True  # the pier on a post carries too: two carry, eight stand free
    assert low_carriers(rows, ruin, carried_z) == {6, 8}
    high = [2.62 if c else inf for c in ruin]  # a block still lying on them, up high
    assert low_carriers(rows, ruin, high) == set()
    few = [True] * 3 + [False] * 7
    assert low_carriers(rows, few, carried_z) == set()  # a ruin: low free ones are broken
    assert low_carriers(rows[:3], [False, False, True], carried_z[:3]) == set()  # too few


def test_foot_of_a_wall_piece_on_a_podium() -> None:
    """Draw 15 (a portico on a 0.6 m podium): the ring round the wall piece between two
    windows held the ground outside the podium, so its floor was 0.04 m and its foot band
    lay in the podium's side, not in the wall below the sills; the foot is where its own
    points end when that is above the floor's noise."""
    z = np.linspace(0.68, 4.0, 200)
    assert foot_levels(z, 0.04, 0.03) == (0.04, 0.68 - 0.03)
    assert foot_levels(np.linspace(0.05, 4.0, 200), 0.04, 0.03) == (0.04,)  # on its floor


def test_wall_between_windows_on_a_podium_is_no_pier_on_draw_15() -> None:
    """Draw 15, a portico of 8 columns and a pier on a 0.6 m podium with two windows per
    bay: the wall between two windows (0.3 x 0.8 m in the section, joined to the wall
    below the sills in 49 % of its layers) was a tenth support; its foot stands in the
    wall that runs on below the sills.  With the simulator's noise drawn per ray its
    lowest points (the podium's side joined to it) put the foot band at 0.25-0.35 m, in
    the podium's side; over the bands of its whole height the wall runs on beyond both
    of its ends in 14 (:func:`~pyheracles.supports.cookies.walled_in_bands`)."""
    assert_no_support_is_a_wall(15, 9)


def assert_no_support_is_a_wall(seed: int, n_supports: int) -> None:
    """Step 2a on supports draw ``seed``: no support found is mostly wall points, and
    ``n_supports`` are found (also used by ``test_supports_wall_bands`` on rescans)."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", seed)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    wall_code = {v: k for k, v in sim.scene.class_names.items()}["wall"]
    ok = ~res.outlier
    for k in found.objects["instance"]:
        mine = ok & (found.instance == k)
        assert np.mean(res.class_id[mine] == wall_code) < 0.5, f"support {k} is a wall"
    assert len(found.objects) == n_supports


def test_pulpit_post_in_a_ruin_is_no_broken_column() -> None:
    """Draw 26 (a roofless peristyle, columns 0.17 m in radius broken or standing at
    3.2 m): a pulpit post 0.12 m in radius, its tub's underside unseen, carried nothing
    and was a broken column.  A broken column's top is open; over the post stand the
    tub's sides, round it in every sector.  The broken columns (2.0 m, one beside a
    standing one) stay."""
    step = 0.03
    parts = [_horizontal(0.0, 9.0, 0.0, 6.0, 0.0, step)]
    for x, top in ((1.5, 2.0), (3.5, 3.2), (3.9, 2.0), (5.5, 3.2), (7.5, 2.0)):
        parts.append(tube((x, 1.5), 0.17, 0.0, top, step))
    parts += [tube((4.5, 4.0), 0.12, 0.0, 1.6, step), tub_sides((4.5, 4.0), 1.6, step)]
    rng = np.random.default_rng(26)
    xyz = np.vstack(parts)
    xyz = xyz + rng.normal(0, 0.002, xyz.shape)
    found = detect_supports(xyz, SupportParams(section_height_m=1.0))
    assert list(found.objects["class"]) == ["column"] * 5, found.objects
    post = np.hypot(xyz[:, 0] - 4.5, xyz[:, 1] - 4.0) < 0.3
    assert not found.instance[post].any()


def test_low_carriers_under_a_vault() -> None:
    """Draw 32 (a nave on a 0.18 m platform, its supports 2.5 m tall under a vault
    springing at 2.68 m and rising 1.8 m): the surface found over each support lay up
    the vault (2.68-4.03 m, their median 3.32 m) and the engaged column carrying the
    springing at 2.68 m reached 0.799 of the way up to the median: dropped.  Each
    candidate is judged against what the supports next to it carry (2.88 m for the
    column): it stays; a pulpit's post beside the arcade, carrying its tub at 1.6 m or
    its tub unseen (ending at 1.58 m), goes."""
    carriers = [
        (0.48, 8.89, 3.53),
        (11.96, 2.97, 2.98),
        (14.21, 2.96, 2.88),
        (2.95, 7.03, 2.93),
        (16.48, 2.97, 2.78),
        (5.20, 7.03, 2.83),
        (18.64, 3.03, 2.83),
        (2.94, 2.97, 3.44),
        (5.15, 2.96, 3.59),
        (-0.16, 2.50, 3.19),
        (7.45, 7.03, 2.88),
        (20.75, 3.02, 3.54),
        (9.71, 2.97, 3.57),
        (9.57, 7.04, 3.69),
        (5.21, 0.04, 4.03),
        (9.48, 9.81, 3.96),
        (11.80, 7.04, 3.81),
    ]  # fmt: skip  (x, y, carried_z) of the supports of the draw that carry
    rows = [{"class": "pier", "x": x, "y": y, "z_min": 0.18, "z_max": 2.68} for x, y, _ in carriers]
    rows += [
        {"class": "column", "x": 5.22, "y": 9.95, "z_min": 0.18, "z_max": 2.68},  # engaged
        {"class": "column", "x": 6.3, "y": 7.6, "z_min": 0.18, "z_max": 1.58},  # a post
    ]
    carried_z = [t for *_, t in carriers] + [2.68, float("inf")]  # the tub unseen
    carries = [True] * (len(carriers) + 1) + [False]
    post = len(carriers) + 1
    assert low_carriers(rows, carries, carried_z) == {post}
    carried_z[-1], carries[-1] = 1.6, True  # its tub seen over it
    assert low_carriers(rows, carries, carried_z) == {post}
