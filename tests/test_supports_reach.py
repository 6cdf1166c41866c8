"""A support carries what it reaches (issue 12, step 2a, failure mode 8: clutter taken for
supports): a candidate ending well below the surface found over it is judged, in a
ruin, by what stands round its top, as one carrying nothing is."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, detect_supports
from pyheracles.supports.cookies import reaches_carried
from test_supports_clutter import box_sides, horizontal, tube


def test_reaching_is_judged_from_the_floor() -> None:
    """A column seen up to 2.58 m under a ceiling at 2.8 m reaches it; the post of a
    pulpit ending at 1.86 m under its tub's rim at 2.9 m does not (draw 26)."""
    assert reaches_carried(2.58, 0.0, 2.8)
    assert not reaches_carried(1.86, 0.0, 2.9)
    assert reaches_carried(3.3, 0.8, 3.4)  # on a dais: from its own floor


def _ruin_with_a_pulpit(rng: np.random.Generator, desk: bool) -> np.ndarray:
    """A roofless ruin of four columns (0.175 m, 3.2 m tall) and a pulpit: a post of
    0.12 m radius up to 1.85 m, a 1.2 x 1.1 m tub from 1.75 to 2.85 m (its underside,
    level with the scanners, unseen) and, with ``desk``, a reading desk across its top."""
    step = 0.03
    parts = [horizontal(0.0, 10.0, 0.0, 6.0, 0.0, step)]
    for x, y in ((2.0, 1.5), (2.0, 4.5), (5.0, 1.5), (5.0, 4.5)):
        parts.append(tube((x, y), 0.175, 0.0, 3.2, step))
    cx, cy = 7.5, 3.0
    parts += [
        tube((cx, cy), 0.12, 0.0, 1.85, step),
        box_sides((cx - 0.6, cy - 0.55, 1.75), (cx + 0.6, cy + 0.55, 2.85), step),
    ]
    if desk:
        parts.append(horizontal(cx - 0.6, cx + 0.6, cy - 0.55, cy + 0.1, 2.9, step))
    xyz = np.vstack(parts)
    return xyz + rng.normal(0, 0.003, xyz.shape)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("desk", [False, True])
def test_a_post_under_its_pulpit_in_a_ruin_is_no_column(seed: int, desk: bool) -> None:
    """Draw 26 (a roofless peristyle, columns of 0.175 m): a pulpit's post, 0.12 m in
    radius and 1.86 m tall, "carried" a surface found over its tub 1 m above its top,
    and only a column carrying nothing was judged by what stands round its top (the
    tub's sides: it stands under what it does not carry).  Without the desk the post
    carries nothing (the rule as it was); with it, it carries the desk it does not
    reach (fails without :func:`reaches_carried`)."""
    xyz = _ruin_with_a_pulpit(np.random.default_rng(seed), desk)
    found = detect_supports(xyz, SupportParams(section_height_m=1.2))
    assert list(found.objects["class"]) == ["column"] * 4, found.objects
    post = np.hypot(xyz[:, 0] - 7.5, xyz[:, 1] - 3.0) < 0.2
    assert not found.instance[post].any()  # the post stays in the body


@pytest.mark.slow
def test_a_pulpit_post_under_its_tub_in_a_ruin_is_no_column() -> None:
    """Draw 26 (a roofless peristyle, columns of 0.175 m): a pulpit's post, 0.12 m in
    radius and 1.86 m tall, "carried" the tub's rim found 1 m over its top, so the rule
    for a post standing under what it does not carry in a ruin (only for supports
    carrying nothing) let it pass as a column."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 26)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    m = score_supports(sim, found.instance, found.objects, section_height=found.section_height)
    clutter = [f for f in m["failures"] if f.get("clutter_share", 0.0) > 0.5]
    assert not clutter, clutter
    assert m["n_supports_found"] == m["n_supports_visible"]
