"""Walls: the foot of a door where clutter hides the foot of the inner face (church
draw 4, interior + exterior TLS)."""

from __future__ import annotations

import numpy as np
import pytest

from church_walls import church_walls

pytestmark = pytest.mark.slow  # a 2.6 M point draw: about 30 s


@pytest.fixture(scope="module")
def church4():
    return church_walls(4)


def test_door_foot_is_the_floor_seen_through_it(church4) -> None:
    """Draw 4, north door: the floor inside stands 0.1 m above the ground outside, and
    the inner face's points by the door began 0.58 m above the floor (its foot hidden),
    so no face's foot was within a step of the door's measured foot (the outer face's,
    ragged under the door) and the door started on the ground, 11 cm low.  The floor
    seen through the doorway on either side of the wall is a level the door's foot may
    take now (:func:`~pyheracles.walls.outlines.floor_levels`), when flat."""
    r, objs = church4
    tw = next(o for o in objs if o["class"] == "wall" and o["name"] == "north")
    n, d = np.asarray(tw["outer_plane"]["normal"]), tw["outer_plane"]["d"]
    w = next(w for w in sorted(r.walls, key=lambda x: -x.n_points)
             if any(abs(f.normal @ n) > 0.999 and abs(np.sign(f.normal @ n) * f.d - d) < 0.05
                    for f in w.faces))  # fmt: skip
    door = next(o for o in objs if o["class"] == "door" and o["wall"] == "north")
    bc = np.asarray(door["box_corners_m"])
    uc = float((bc.mean(axis=0) - w.origin) @ w.u_axis)
    got = min((o for o in w.openings if o.kind == "door"),
              key=lambda o: abs(0.5 * (o.u_min + o.u_max) - uc))  # fmt: skip
    assert got.z_min == pytest.approx(float(bc[:, 2].min()), abs=0.04)
    assert got.height_m == pytest.approx(door["height_m"], abs=0.05)
