"""A column carries what it reaches: one ending far under the surface found over it does
not carry that surface.

Supports draws 7, 12 and 16: the posts of pulpits (0.12 m in radius) ending 1.2-2.3 m
under the ceiling found over them "carried" it; judged by that surface they stood as
high as the building's supports (:func:`~pyheracles.supports.detect.low_carriers`) and
carried something, so the thin-column test
(:func:`~pyheracles.supports.detect.thin_free_columns`) did not judge them.
A ruin keeps judging by what is carried (draw 6: a broken column 4.3 m tall inside a
scaffold whose deck is at 6.9 m is a column), and so do piers (draw 32: the piers of an
arcade end where their arches spring, 0.7 of the way up to the ceiling).
"""

from __future__ import annotations

import pytest

from pyheracles.supports.detect import low_carriers


def _col(z_max: float, z_min: float = 0.0, radius: float = 0.3) -> dict:
    return {"class": "column", "z_min": z_min, "z_max": z_max, "radius_m": radius}


def test_a_post_under_a_ceiling_it_does_not_reach_is_low() -> None:
    """Draw 16: six columns carry the ceiling at 3.44 m; a post seen up to 1.93 m under
    the ceiling found over it at 3.74 m goes; judged by what it carries it stayed."""
    rows = [_col(3.4)] * 6 + [_col(1.93, radius=0.12)]
    carries, tops = [True] * 7, [3.44] * 6 + [3.74]
    reaches = [True] * 6 + [False]
    assert low_carriers(rows, carries, tops, [False] * 7) == set()
    assert low_carriers(rows, carries, tops, [False] * 7, reaches) == {6}


def test_the_piers_of_an_arcade_stay() -> None:
    """Draw 32: piers found in the thick section only end where their arches spring,
    2.67 m, under the ceiling found over them at 3.81-3.96 m: they stay."""
    rows = [_col(3.8, 0.2)] * 6 + [{"class": "pier", "z_min": 0.2, "z_max": 2.67}] * 2
    carries, tops = [True] * 8, [3.81] * 6 + [3.96, 3.81]
    sparse, reaches = [False] * 6 + [True] * 2, [True] * 6 + [False] * 2
    assert low_carriers(rows, carries, tops, sparse, reaches) == set()


@pytest.mark.parametrize("z_max", [2.45, 2.2])
def test_a_column_reaching_what_it_carries_stays(z_max: float) -> None:
    """A top shadowed over a few decimetres still reaches the ceiling (draw 36)."""
    rows = [_col(2.54)] * 6 + [_col(z_max)]
    carries, tops, reaches = [True] * 7, [2.56] * 7, [True] * 7
    assert low_carriers(rows, carries, tops, [False] * 7, reaches) == set()


def test_in_a_ruin_what_is_carried_still_judges() -> None:
    """Draw 6 (most supports carry nothing): a broken column 4.3 m tall under a
    scaffold's deck at 6.9 m stays, though it does not reach the deck."""
    rows = [_col(4.69, 0.39)] + [_col(8.2, 0.39)] * 6 + [_col(4.0, 0.39)] * 4
    carries = [True, True, True] + [False] * 8
    tops = [6.89, 6.89, 6.89] + [float("inf")] * 8
    reaches = [False, True, True] + [False] * 8
    assert low_carriers(rows, carries, tops, [False] * 11, reaches) == set()


@pytest.mark.slow
@pytest.mark.parametrize("seed", [7, 12, 16])
def test_pulpit_posts_are_no_columns_on_their_draws(seed: int) -> None:
    """Draws 7, 12 and 16: no found column is 90 % clutter (a pulpit's post was one).
    Draw 7's post goes as a thin column (it carries nothing it reaches, and the column
    merged with the pulpit's tub, 0.62 m, carries the ceiling), those of 12 and 16 as
    low ones."""
    import numpy as np

    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", seed)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    clutter = res.class_id == {v: k for k, v in sim.scene.class_names.items()}["clutter"]
    posts = [
        int(k)
        for k, c in zip(found.objects["instance"], found.objects["class"], strict=True)
        if c == "column" and np.mean(clutter[found.instance == k]) >= 0.9
    ]
    assert not posts, posts
