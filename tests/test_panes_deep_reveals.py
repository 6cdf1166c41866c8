"""Openings of thick walls seen from below, and windows scanned closer than their wall.

Church draw 9 (walls 1.02 m thick, panes 0.78 m behind the outer face, an exterior
TLS from the ground with a detail scan of each window) was refused: "no 3 openings in
a consistent arrangement" with 19 openings found in each cloud.  Two mechanisms made
the exterior openings 2.5-2.8 m tall for windows of 3.6-4.1 m:

* the face raster's cell follows the wall's median spacing (8 cm, so 0.2 m cells):
  with its closing, the narrow head of a pointed light was filled and the glass and
  reveals above it fell outside the opening's prism (the top 0.65 m lost);
* from below, the sill of a deep recess is hidden (its top faces up) and so is the
  glass just above it: the outline stopped at the visible jambs, 0.35 m above the sill.

Now a hole is rastered again at its own neighbourhood's spacing, and a side that no
reveal shows is taken from the hole in the wall face.
"""

from __future__ import annotations

import numpy as np
import pytest

from church_registration import error_at_interior, register_church
from pyheracles.registration.face_holes import unseen_sides_from_hole
from pyheracles.registration.panes import PaneParams, detect_openings

WIDTH, SILL_Z, HEIGHT = 1.0, 2.0, 3.8
DEPTH = 0.78  # outer face to the near glass face


def _deep_window(rng, coarse: float = 0.10, fine: float = 0.02) -> np.ndarray:
    """A 10 x 8 m wall face (y = 0, the wall behind it at y > 0) scanned at ``coarse``,
    with a detail scan at ``fine`` round one deep window seen from below."""
    u, z = np.meshgrid(np.arange(-5, 5, coarse), np.arange(0, 8, coarse))
    u, z = u.ravel(), z.ravel()
    # the detail scan covers the window and 0.5 m round it
    near = (np.abs(u) < WIDTH / 2 + 0.5) & (z > SILL_Z - 0.5) & (z < SILL_Z + HEIGHT + 0.5)
    du, dz = np.meshgrid(
        np.arange(-WIDTH / 2 - 0.5, WIDTH / 2 + 0.5, fine),
        np.arange(SILL_Z - 0.5, SILL_Z + HEIGHT + 0.5, fine),
    )
    u = np.concatenate([u[~near], du.ravel()])
    z = np.concatenate([z[~near], dz.ravel()])
    hole = (np.abs(u) < WIDTH / 2) & (z > SILL_Z) & (z < SILL_Z + HEIGHT)
    parts = [np.column_stack([u[~hole], np.zeros((~hole).sum()), z[~hole]])]
    d = np.arange(fine / 2, DEPTH, fine)
    zz = np.arange(SILL_Z, SILL_Z + HEIGHT, fine)
    for a in (-WIDTH / 2, WIDTH / 2):  # jambs, hidden near the sill deeper in
        D, Z = np.meshgrid(d, zz)
        seen = Z > SILL_Z + 0.45 * D / DEPTH
        parts.append(np.column_stack([np.full(seen.sum(), a), D[seen], Z[seen]]))
    uu = np.arange(-WIDTH / 2, WIDTH / 2, fine)
    D, U = np.meshgrid(d, uu)  # the head's soffit faces the viewer below; the sill does not
    parts.append(np.column_stack([U.ravel(), D.ravel(), np.full(D.size, SILL_Z + HEIGHT)]))
    n_glass = int(0.2 * WIDTH * (HEIGHT - 0.45) / fine**2)  # glass above the hidden strip
    g = rng.uniform([-WIDTH / 2, SILL_Z + 0.45], [WIDTH / 2, SILL_Z + HEIGHT], (n_glass, 2))
    parts.append(np.column_stack([g[:, 0], np.full(n_glass, DEPTH), g[:, 1]]))
    xyz = np.vstack(parts)
    return xyz + rng.normal(0, 0.002, xyz.shape)


def test_a_sill_hidden_in_a_deep_recess_is_taken_from_the_wall_face() -> None:
    rng = np.random.default_rng(9)
    ops = detect_openings(_deep_window(rng), PaneParams(level=False))
    assert len(ops) == 1
    o = ops[0]
    assert abs(o.width - WIDTH) < 0.05
    assert abs(o.height - HEIGHT) < 0.05  # 3.35 m from the glass and jambs alone
    assert "bottom" in o.sides_from_face and "top" not in o.sides_from_face
    assert abs(o.centre[2] - (SILL_Z + HEIGHT / 2)) < 0.03
    assert abs(o.depth_m - (DEPTH + 0.01)) < 0.01  # pane mid-plane, 2 cm glass


def _outline(sides: tuple[str, ...], rng, jamb_scatter: int = 0):
    """Outline points of a 1 x 3 m opening on the sides given, with their normals."""
    pts, nrm = [], []
    along = {"left": (0, -1.0), "right": (0, 1.0), "bottom": (1, -1.0), "top": (1, 1.0)}
    for s in sides:
        axis, sgn = along[s]
        t = rng.uniform(0, 3.0 if axis == 0 else 1.0, 300)
        p = np.zeros((300, 2))
        p[:, axis] = (0.0 if sgn < 0 else 1.0) if axis == 0 else (0.0 if sgn < 0 else 3.0)
        p[:, 1 - axis] = t
        n = np.zeros((300, 2))
        n[:, axis] = sgn
        pts.append(p)
        nrm.append(n)
    if jamb_scatter:  # jamb points whose normals turned down, anywhere along both jambs
        p = np.column_stack(
            [rng.integers(0, 2, jamb_scatter).astype(float), rng.uniform(0, 3.0, jamb_scatter)]
        )
        pts.append(p)
        nrm.append(np.tile([0.0, -1.0], (jamb_scatter, 1)))
    return np.vstack(pts), np.vstack(nrm)


def test_a_side_is_seen_only_where_its_reveal_is() -> None:
    rng = np.random.default_rng(1)
    cell = 0.04
    # the face's hole (its empty cells, half a cell inside each edge): 0.2 m of splay
    hole = (-0.2 + cell / 2, 1.2 - cell / 2, -0.2 + cell / 2, 3.2 - cell / 2)
    # every side seen: the extent stays as measured
    uv, n = _outline(("left", "right", "bottom", "top"), rng)
    ext = unseen_sides_from_hole(uv, n, (0.0, 1.0, 0.0, 3.0), hole, cell)
    assert ext.from_face == () and ext.extent == (0.0, 1.0, 0.0, 3.0)
    # the sill unseen and the jambs stopping 0.5 m above it; a few jamb normals turned
    # down all along both jambs do not make a sill: the sill is the hole's edge less
    # the splay of the head
    uv, n = _outline(("left", "right", "top"), rng, jamb_scatter=40)
    keep = uv[:, 1] > 0.5
    ext = unseen_sides_from_hole(uv[keep], n[keep], (0.0, 1.0, 0.5, 3.0), hole, cell)
    assert ext.from_face == ("bottom",)
    assert ext.extent == pytest.approx((0.0, 1.0, 0.0, 3.0), abs=1e-9)


def test_a_window_over_an_unscanned_wall_is_an_opening() -> None:
    """Church draw 49: clerestory windows seen from the ground over the aisle roofs,
    which hide the wall under their sills; each window's hole ran into that unscanned
    part of the face, was not enclosed, and 9 of 38 exterior windows were never tried
    (7 openings found, the pair refused; now 19 and registered within 8 mm)."""
    rng = np.random.default_rng(49)
    sp, sill, top, recess = 0.05, 3.0, 5.0, 0.15
    u, z = np.meshgrid(np.arange(-5, 5, sp), np.arange(sill, 8, sp))  # nothing under the sill
    u, z = u.ravel(), z.ravel()
    hole = (np.abs(u) < 0.5) & (z < top)
    parts = [np.column_stack([u[~hole], np.zeros((~hole).sum()), z[~hole]])]
    d = np.arange(sp / 2, recess, sp / 2)
    for a in (-0.5, 0.5):  # jambs
        D, Z = np.meshgrid(d, np.arange(sill, top, sp / 2))
        parts.append(np.column_stack([np.full(D.size, a), D.ravel(), Z.ravel()]))
    D, U = np.meshgrid(d, np.arange(-0.5, 0.5, sp / 2))  # head
    parts.append(np.column_stack([U.ravel(), D.ravel(), np.full(D.size, top)]))
    g = rng.uniform([-0.5, sill], [0.5, top], (300, 2))  # glass
    parts.append(np.column_stack([g[:, 0], np.full(300, recess), g[:, 1]]))
    xyz = np.vstack(parts)
    xyz += rng.normal(0, 0.002, xyz.shape)
    ops = detect_openings(xyz, PaneParams(level=False))
    assert len(ops) == 1
    o = ops[0]
    assert abs(o.width - 1.0) < 0.05 and abs(o.height - (top - sill)) < 0.1
    assert np.linalg.norm(o.centre[[0, 2]] - [0.0, (sill + top) / 2]) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed",
    [
        pytest.param(9, marks=pytest.mark.xfail(strict=True, reason=(
            "per-ray noise draw: refused (loose pose: its 3 verified openings leave a turn "
            "about the vertical free; was 15.5 cm off without a flag), see "
            "test_panes_loose_pose"))),
        49,
    ],
)  # fmt: skip
def test_the_draws_that_showed_it_register(seed: int) -> None:
    """Church draws 9 (deep recesses, detail scans) and 49 (clerestory over aisles):
    refused before ("no 3 openings in a consistent arrangement"), now within 1.5 cm."""
    sim, clouds, tp, res = register_church(seed)
    assert error_at_interior(sim, clouds["interior"], res.T_target_source) < 0.015
    assert tp.details["n_recess_verified"] >= 3


def test_an_open_hole_is_bounded_by_the_face_on_three_sides() -> None:
    """A clerestory window over an unscanned wall is bounded left, right and above; a
    patch of shadow at the face's corner (an interior: a small church had 23 such
    patches besides its 17 windows) is bounded on two sides only."""
    from pyheracles.registration.face_holes import sides_bounded

    occ = np.ones((20, 30), bool)
    occ[:, :8] = False  # nothing scanned under the sill
    window = np.zeros_like(occ)
    window[8:12, 0:20] = True  # the window's empty cells run down into it
    occ[8:12, 8:20] = False
    assert sides_bounded(window, occ) == 3
    occ2 = np.ones((20, 30), bool)
    occ2[:10, :10] = False  # unscanned corner
    patch = np.zeros_like(occ2)
    patch[:10, :10] = True
    assert sides_bounded(patch, occ2) == 2
