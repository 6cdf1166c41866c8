"""Short arcs of small rings confirmed at several heights (issue 12, step 2a, missed
columns).

A small column far from the stations, or shadowed by its twin, shows 40-80 degrees of
its ring at every height, in a few scan-line bunches.  In one section its arc does not
bulge enough out of its chord to be told from a pier's corner
(:func:`pyheracles.supports.rings.ring_covered` asks a quarter of rings up to 0.2 m),
and such columns were missed (draw 36 of the supports family: twin columns of
0.14-0.16 m, 6-8 points in the thin section over 4-8 sectors).  The same tight circle
fitted again on its own in the slabs above and below tells it from noise and clutter
(:func:`pyheracles.supports.ring_heights.rings_over_heights`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams
from pyheracles.supports.ring_heights import rings_over_heights
from supports_draws import scored_supports_draw

PARAMS = SupportParams()


def _column(centre, radius: float, az_deg, z, seed: int) -> np.ndarray:
    """Points of a vertical shaft crossed by vertical scan lines at the azimuths
    ``az_deg`` (degrees), at the heights ``z``; 3 mm noise."""
    rng = np.random.default_rng(seed)
    t, h = np.meshgrid(np.radians(np.asarray(az_deg, dtype=float)), np.asarray(z))
    t, h = t.ravel(), h.ravel()
    p = np.c_[np.asarray(centre) + radius * np.c_[np.cos(t), np.sin(t)], h]
    return p + rng.normal(0, 0.003, p.shape)


def _corner(centre, half: float, z, step: float, seed: int) -> np.ndarray:
    """Points of the two faces of a square pier's corner (faces ``half`` metres long
    each side of it, scan lines ``step`` metres apart) at the heights ``z``."""
    rng = np.random.default_rng(seed)
    s = np.arange(0.0, half, step)
    face = np.r_[np.c_[s, np.zeros_like(s)], np.c_[np.zeros_like(s), s]]
    xy = np.repeat(face, len(z), axis=0)
    h = np.tile(np.asarray(z), len(face))
    p = np.c_[np.asarray(centre) + xy, h]
    return p + rng.normal(0, 0.003, p.shape)


def _run(p: np.ndarray, h: float):
    order = np.argsort(p[:, 2], kind="stable")
    left = order[np.abs(p[order, 2] - h) <= 0.15]
    return rings_over_heights(p, order, p[order, 2], h, left, PARAMS)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_short_arc_of_a_small_column_at_every_height_is_a_column(seed: int) -> None:
    """A shaft of 0.14 m seen over 60 degrees in seven scan-line bunches, every 2 cm of
    height over 2.6 m: the arc of each slab covers 6-7 sectors (not a quarter), its
    circle comes back above and below: one column island there."""
    z = np.arange(0.0, 2.6, 0.02)
    p = _column([3.0, 4.0], 0.14, 100.0 + 10.0 * np.arange(7), z, seed)
    found = _run(p, 1.3)
    assert len(found) == 1
    isl = found[0]
    assert isl.kind == "column"
    assert np.hypot(*(isl.center - [3.0, 4.0])) < 0.02
    assert abs(isl.radius - 0.14) < 0.02


def test_arc_at_one_height_only_is_no_column() -> None:
    """The same arc over 0.3 m of height only (a round piece of clutter, a lamp): its
    circle does not come back in the other slabs: none."""
    z = np.arange(1.15, 1.45, 0.02)
    p = _column([3.0, 4.0], 0.14, 100.0 + 10.0 * np.arange(7), z, 0)
    assert _run(p, 1.3) == []


def test_corner_of_a_pier_at_every_height_is_no_column() -> None:
    """A pier's corner seen at every height (two faces of 0.25 m, scan lines 4 cm
    apart): the same shape in every slab, but no ring (the ring test's rectangle and
    line comparisons): none."""
    z = np.arange(0.0, 2.6, 0.02)
    assert _run(_corner([3.0, 4.0], 0.25, z, 0.04, 0), 1.3) == []


@pytest.mark.slow
def test_draw_36_twin_columns_seen_over_short_arcs_are_found() -> None:
    """Draw 36 (twin columns of 0.14-0.16 m, one station inside): 11 columns were
    missed, among them 5, 8 and 61 whose section arcs cover 6-8 sectors; they are found,
    and no support found is false."""
    m = scored_supports_draw(36)
    missed = {f["instance"] for f in m["failures"] if f["mode"] == "missed"}
    assert not missed & {5, 8, 61}
    assert len(missed) <= 8
    assert m["n_supports_found"] - m["n_matched"] <= 4  # as before: no new false one
