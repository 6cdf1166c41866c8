"""The thick section's islands from a forked child (issue 12, speed): the islands of
the thick slabs (:func:`~pyheracles.supports.thick_slab.thick_islands`) draw no random
numbers, so step 2a computes them in a forked child while it searches the thin
sections, and builds the tree of the thick slab's wall points once for its
half-columns and its walls' test (``support_shapes(..., wall_tree=...)``).  Each gives
what the one-process code gives (on the 10 M point hall and draws 8, 24, 36 of the
supports family: the same label on every point)."""

from __future__ import annotations

from functools import partial

import numpy as np
from scipy.spatial import cKDTree

from pyheracles.forks import ForkedCall
from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.detect import detect_supports, support_shapes
from pyheracles.supports.thick_slab import THICK_SECTION_M, slab_indices, thick_islands
from supports_draws import section_line, tube


def _room(seed: int = 0, step: float = 0.02, size=(10.0, 6.0, 4.0)) -> np.ndarray:
    """A room ``size`` (x, y, height, metres): four walls and two free columns of 0.2 m,
    points every ``step`` metres along the walls and 2 cm up, 5 mm noise, random order."""
    rng = np.random.default_rng(seed)
    lx, ly, h = size
    zs = np.arange(0.0, h, 0.02)
    walls = []
    for a, b in (((0, 0), (lx, 0)), ((lx, 0), (lx, ly)), ((lx, ly), (0, ly)), ((0, ly), (0, 0))):
        line = section_line(a, b, step)
        walls.append(np.c_[np.repeat(line, len(zs), axis=0), np.tile(zs, len(line))])
    cols = [tube((x, ly / 2), 0.2, 0.0, h - 0.02, step) for x in (lx / 3, 2 * lx / 3)]
    p = np.vstack([*walls, *cols])
    p = p + rng.normal(0.0, 0.005, p.shape)
    return p[rng.permutation(len(p))]


def _same_islands(a: list, b: list) -> bool:
    return len(a) == len(b) and all(
        x.kind == y.kind and np.array_equal(x.index, y.index) and np.allclose(x.center, y.center)
        for x, y in zip(a, b, strict=True)
    )


def test_thick_islands_from_a_forked_child_are_the_same():
    p = _room()
    order = np.argsort(p[:, 2], kind="stable")
    z_sorted = p[order, 2]
    params = SupportParams()
    heights = [1.5, 0.8]
    here = thick_islands(p, order, z_sorted, heights, params, 0.08)
    there = ForkedCall(partial(thick_islands, p, order, z_sorted, heights, params, 0.08)).result()
    assert len(here) == len(there) == 2
    assert all(_same_islands(a, b) for a, b in zip(here, there, strict=True))
    kinds = sorted(i.kind for i in here[0])
    assert kinds.count("column") == 2 and "wall" in kinds
    idx = slab_indices(order, z_sorted, 1.5, THICK_SECTION_M)
    assert np.all(np.abs(p[idx, 2] - 1.5) <= THICK_SECTION_M / 2)


def test_support_shapes_with_the_callers_wall_tree_are_the_same():
    p = _room()
    order = np.argsort(p[:, 2], kind="stable")
    z_sorted = p[order, 2]
    params = SupportParams()
    sc = scales(0.02, params)
    isl = thick_islands(p, order, z_sorted, [1.5], params, sc.distance)[0]
    xy = p[slab_indices(order, z_sorted, 1.5, THICK_SECTION_M), :2]
    walls = np.vstack([xy[i.index] for i in isl if i.kind == "wall"])
    own, _ = support_shapes(xy, isl, params, sc, np.random.default_rng(0), responds=False)
    given, _ = support_shapes(
        xy, isl, params, sc, np.random.default_rng(0), responds=False, wall_tree=cKDTree(walls)
    )
    assert [s["class"] for s in own] == [s["class"] for s in given]
    assert sorted(s["class"] for s in own) == ["column", "column"]
    for a, b in zip(own, given, strict=True):
        assert np.array_equal(a["centre"], b["centre"]) and a["radius"] == b["radius"]


def test_detect_supports_same_labels_in_one_process(monkeypatch):
    """Step 2a with the thick slabs' islands from a forked child and all in one process
    (``HERACLES_THREADS=1``): the same labels.  The room is dense (1 cm) so that the thick
    slab is searched (its thin section is thinner than ``THICK_SECTION_M / 1.5``)."""
    from pyheracles.supports import detect

    calls = []

    class Counted(ForkedCall):
        def __init__(self, fn):
            calls.append(fn)
            super().__init__(fn)

    monkeypatch.setattr(detect, "ForkedCall", Counted)
    p = _room(1, step=0.01, size=(6.0, 4.0, 2.4))
    forked = detect_supports(p)
    assert calls and all(c.func is thick_islands for c in calls)
    monkeypatch.setenv("HERACLES_THREADS", "1")
    alone = detect_supports(p)
    assert np.array_equal(forked.instance, alone.instance)
    assert sorted(forked.objects["class"]) == ["column", "column"]
