"""Glazed openings of a box building: levelling, the face histogram's wrap, the glass layer.

Seed 4 of the church family (exterior TLS tilted by 1 deg) showed two mechanisms: a
wall 8 m high leans 14 cm out of a vertical plane, its face broke into bands of 4 cm
and only 2 of 18 windows were found (14 with the vertical from the walls); and the
pane depth of four lights came from a shallow layer of a pointed head's intrados seen
from below instead of the glass (17 cm off).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from pyheracles.geometry.neighbours import estimate_normals
from pyheracles.registration.panes import PaneParams, detect_openings, estimate_up

#: Window lights (centre along the wall, width, height) on each long wall.
LIGHTS = ((-3.0, 1.0, 2.2), (0.0, 1.2, 2.4), (3.0, 0.9, 2.0))
SILL_Z = 3.0
RECESS_M = 0.15


def _box_with_windows(
    rng, spacing: float = 0.05, head_layer: int = 0, noise_m: float = 0.002, glass: int = 300
) -> tuple[np.ndarray, np.ndarray]:
    """Exterior of a 12 x 8 x 8 m box, three recessed glazed lights per long wall.

    ``head_layer`` points of a surface parallel to the face 6 cm deep in the top
    fifth of each light (more than its 300 glass points: an intrados seen from below);
    ``glass`` points on each pane (photogrammetry: none); Gaussian noise ``noise_m``.
    Returns the points and the window centres on the glass (scene frame).
    """
    pts, centres = [], []
    for axis, half, length in ((1, 4.0, 12.0), (0, 6.0, 8.0)):  # long walls, gables
        for sgn in (-1.0, 1.0):
            nu = int(length / spacing)
            nz = int(8.0 / spacing)
            u, z = np.meshgrid(np.linspace(-length / 2, length / 2, nu), np.linspace(0, 8, nz))
            u, z = u.ravel(), z.ravel()
            keep = np.ones(len(u), bool)
            extra = []
            if axis == 1:
                for uc, w, hgt in LIGHTS:
                    hole = (np.abs(u - uc) < w / 2) & (z > SILL_Z) & (z < SILL_Z + hgt)
                    keep &= ~hole
                    d = np.arange(spacing / 2, RECESS_M, spacing / 2)
                    zz = np.arange(SILL_Z, SILL_Z + hgt, spacing / 2)
                    uu = np.arange(uc - w / 2, uc + w / 2, spacing / 2)
                    for a in (uc - w / 2, uc + w / 2):  # jambs
                        D, Z = np.meshgrid(d, zz)
                        extra.append(np.column_stack([np.full(D.size, a), D.ravel(), Z.ravel()]))
                    for zl in (SILL_Z, SILL_Z + hgt):  # sill and head
                        D, U = np.meshgrid(d, uu)
                        extra.append(np.column_stack([U.ravel(), D.ravel(), np.full(D.size, zl)]))
                    # sparse glass at the recess depth
                    g = rng.uniform([uc - w / 2, SILL_Z], [uc + w / 2, SILL_Z + hgt], (glass, 2))
                    extra.append(np.column_stack([g[:, 0], np.full(glass, RECESS_M), g[:, 1]]))
                    if head_layer:
                        lo_, hi_ = [uc - 0.2 * w, SILL_Z + 0.8 * hgt], [uc + 0.2 * w, SILL_Z + hgt]
                        q = rng.uniform(lo_, hi_, (head_layer, 2))
                        extra.append(np.column_stack([q[:, 0], np.full(head_layer, 0.06), q[:, 1]]))
                    centres.append((uc, sgn * (half - RECESS_M), SILL_Z + hgt / 2))
            face = np.column_stack([u[keep], np.zeros(keep.sum()), z[keep]])
            local = np.vstack([face, *extra])  # (along, depth into the wall, z)
            if axis == 1:
                xyz = np.column_stack([local[:, 0], sgn * (half - local[:, 1]), local[:, 2]])
            else:
                xyz = np.column_stack([sgn * (half - local[:, 1]), local[:, 0], local[:, 2]])
            pts.append(xyz)
    xyz = np.vstack(pts)
    return xyz + rng.normal(0, noise_m, xyz.shape), np.array(centres)


def _tilted(deg: float):
    rng = np.random.default_rng(4)
    xyz, centres = _box_with_windows(rng)
    R = Rotation.from_rotvec(np.deg2rad(deg) * np.array([0.6, 0.8, 0.0])).as_matrix()
    return xyz @ R.T, centres @ R.T, R


def test_the_vertical_of_a_tilted_cloud_comes_from_its_walls() -> None:
    xyz, _, R = _tilted(1.5)
    normals, _ = estimate_normals(xyz[::4], k=12)
    up = estimate_up(normals, np.array([0.0, 0.0, 1.0]))
    assert up is not None
    assert np.degrees(np.arccos(np.clip(up @ R[:, 2], -1, 1))) < 0.05
    # walls of one direction leave the vertical free along them: no estimate
    rng = np.random.default_rng(1)
    wall = np.column_stack([rng.uniform(0, 8, 5000), np.zeros(5000), rng.uniform(0, 6, 5000)])
    normals, _ = estimate_normals(wall @ R.T + rng.normal(0, 0.002, wall.shape), k=12)
    assert estimate_up(normals, np.array([0.0, 0.0, 1.0])) is None


def _errors(ops, centres) -> tuple[np.ndarray, np.ndarray]:
    """Distance of each light to the nearest opening, and of each opening to its light."""
    found = np.array([o.centre for o in ops]).reshape(-1, 3)
    D = np.linalg.norm(found[:, None, :] - centres[None, :, :], axis=2)
    return D.min(axis=0), D.min(axis=1)


def test_walls_facing_the_azimuth_wrap_are_found() -> None:
    # walls along the frame axes: normals at 0 and 180 deg of the face histogram's
    # azimuth, where the canonical normal (and the offset's sign) flips; mixing the two
    # long walls in one candidate set lost both and all six lights
    xyz, centres, _ = _tilted(0.0)
    per_light, per_opening = _errors(detect_openings(xyz, PaneParams(level=False)), centres)
    assert np.all(per_light < 0.015) and np.all(per_opening < 0.015)


def test_openings_of_a_tilted_cloud_are_found() -> None:
    xyz, centres, _ = _tilted(1.5)
    # on the mid-plane: half the 2 cm glass behind the glass centre
    per_light, per_opening = _errors(detect_openings(xyz, PaneParams()), centres)
    assert np.all(per_light < 0.015) and np.all(per_opening < 0.015)
    # the faces of walls tilted by 4 deg, taken as vertical planes, break into bands:
    # openings are lost (at 1.5 deg the face scatter measured round each hole now keeps
    # them); levelled, all are found
    xyz, centres, _ = _tilted(4.0)
    per_light, _ = _errors(detect_openings(xyz, PaneParams()), centres)
    assert np.all(per_light < 0.015)
    ops = detect_openings(xyz, PaneParams(level=False))
    assert len(ops) < len(centres) or _errors(ops, centres)[1].max() > 0.05


def test_the_glass_is_the_layer_spreading_over_the_opening() -> None:
    rng = np.random.default_rng(5)
    xyz, centres = _box_with_windows(rng, head_layer=450)
    ops = detect_openings(xyz, PaneParams())
    assert len(ops) == len(centres)
    # mid-plane: half the 2 cm glass behind the glass, not at the 6 cm head layer
    assert np.allclose([o.depth_m for o in ops], RECESS_M + 0.01, atol=0.01)
    per_light, _ = _errors(ops, centres)
    assert np.all(per_light < 0.03)


def test_the_scatter_of_a_noisy_face_is_no_glass() -> None:
    # church draw 7: a photogrammetric exterior (no glass points, the face scattering
    # 1-2 cm) put face points behind the plane all round each hole; they passed for a
    # glass layer 4 cm deep (true reveal 10 cm) and widened the lights by 0.25 m, and
    # no arrangement of the openings verified
    rng = np.random.default_rng(7)
    xyz, centres = _box_with_windows(rng, spacing=0.03, noise_m=0.012, glass=0)
    ops = detect_openings(xyz, PaneParams(level=False))  # the old detector found none
    assert len(ops) == len(centres)
    assert all(o.n_glass == 0 for o in ops)
    # the depth where the reveals end (15 cm) plus half the 2 cm glass, the noise's
    # tail beyond it
    assert np.allclose([o.depth_m for o in ops], RECESS_M + 0.01, atol=0.03)
    per_light, per_opening = _errors(ops, centres)
    assert np.all(per_light < 0.04) and np.all(per_opening < 0.04)
    # sizes from the outline's 1st-99th percentiles widen with the noise (2 x 2.3 sigma)
    found = np.array([o.centre for o in ops])
    light = np.argmin(np.linalg.norm(found[:, None] - centres[None], axis=2), axis=1)
    excess = np.array(
        [o.width - LIGHTS[j % len(LIGHTS)][1] for o, j in zip(ops, light, strict=True)]
    )
    assert np.all((excess > -0.01) & (excess < 0.2))


def test_glass_of_a_detail_scan_is_no_door_leaf() -> None:
    # church draws 40 and 49: a finer region scan of each window covers the glass and
    # the face round it; glass returning a fifth of those beams was denser than 0.7 x
    # the face's overall density and every window was taken for a door leaf (4 of 8
    # exterior openings found in draw 40, which then registered)
    rng = np.random.default_rng(40)
    xyz, centres = _box_with_windows(rng, spacing=0.05)
    detail, fine = [], 0.02
    for uc, w, hgt in LIGHTS:  # the long wall at y = -4 (its face), seen from outside
        u, z = np.meshgrid(
            np.arange(uc - w / 2 - 0.4, uc + w / 2 + 0.4, fine),
            np.arange(SILL_Z - 0.4, SILL_Z + hgt + 0.4, fine),
        )
        u, z = u.ravel(), z.ravel()
        face = ~((np.abs(u - uc) < w / 2) & (z > SILL_Z) & (z < SILL_Z + hgt))
        detail.append(np.column_stack([u[face], np.full(face.sum(), -4.0), z[face]]))
        n_glass = int(0.2 * w * hgt / fine**2)  # a fifth of the detail scan's beams
        g = rng.uniform([uc - w / 2, SILL_Z], [uc + w / 2, SILL_Z + hgt], (n_glass, 2))
        detail.append(np.column_stack([g[:, 0], np.full(n_glass, -4.0 + RECESS_M), g[:, 1]]))
    xyz = np.vstack([xyz, *detail])
    xyz[-sum(len(d) for d in detail) :] += rng.normal(0, 0.002, (sum(len(d) for d in detail), 3))
    ops = detect_openings(xyz, PaneParams(level=False))
    per_light, _ = _errors(ops, centres)
    assert np.all(per_light < 0.03)  # the three detail-scanned lights too
    assert {o.n_glass > 300 for o in ops if o.centre[1] < 0} == {True}
