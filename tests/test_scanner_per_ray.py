"""A ray's point depends on that ray only: the same draw on every CPU.

Embree's hits at triangle edges differ between instruction sets, so another
CPU may see a ray more or fewer.  With random numbers handed out in sequence,
that one ray moved the noise of every later point and the generated families
differed from machine to machine.  Here a 6 cm patch added to a scene plays
the CPU that sees a few more hits: every other point must stay bit-identical.
"""

from __future__ import annotations

import numpy as np

from pyheracles.synthetic.scanner import (
    Outliers,
    PhotoViews,
    TLSStation,
    ray_ids,
    ray_normal,
    ray_uniform,
    scan,
)
from pyheracles.synthetic.scene import GLASS, Scene

PATCH = np.array([3.0, 0.5, 1.2])


def _room(patch: bool) -> Scene:
    s = Scene()
    s.add_box([0, 0, -0.05], [16, 12, 0.1], instance=1, class_name="floor")
    s.add_quad([[6, -6, 0], [6, 6, 0], [6, 6, 5], [6, -6, 5]], instance=2, class_name="wall")
    s.add_quad(
        [[5, -5, 0.5], [5, -3, 0.5], [5, -3, 2.5], [5, -5, 2.5]],
        instance=3,
        class_name="window",
        material=GLASS,
    )
    s.add_cylinder([2.5, -2.0, 0.0], [0, 0, 1], 4.0, 0.3, instance=4, class_name="column")
    if patch:  # a small plate facing the stations: a few rays more hit, a few less reach the wall
        h = 0.03
        c = PATCH
        s.add_quad(
            [c + [0, -h, -h], c + [0, h, -h], c + [0, h, h], c + [0, -h, h]],
            instance=5,
            class_name="patch",
        )
    return s


def _same_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which rows of ``a`` occur bit for bit in ``b``."""
    keys_b = {r.tobytes() for r in np.ascontiguousarray(b)}
    return np.array([r.tobytes() in keys_b for r in np.ascontiguousarray(a)])


def _stations() -> list[TLSStation]:
    return [
        TLSStation((0.0, 0.0, 1.5), step_deg=0.4, mixed_pixel_share=0.3),
        TLSStation((-3.0, 3.0, 1.6), step_deg=0.4, mixed_pixel_share=0.3),
    ]


def test_a_ray_that_hits_differently_changes_its_own_point_only() -> None:
    without = scan(_room(False), _stations(), rng=4)
    with_patch = scan(_room(True), _stations(), rng=4)
    assert (with_patch.instance == 5).sum() >= 5  # the patch was hit
    same = _same_rows(without.xyz, with_patch.xyz)
    # the rays that changed point at the patch from their station (hits, shadows, mixed pixels)
    changed = without.xyz[~same]
    origin = np.array([s.position for s in _stations()])[without.point_source_id[~same] - 1]
    to_point = changed - origin
    to_patch = PATCH - origin
    cos = np.einsum("ij,ij->i", to_point, to_patch) / (
        np.linalg.norm(to_point, axis=1) * np.linalg.norm(to_patch, axis=1)
    )
    assert len(changed) <= (with_patch.instance == 5).sum() + 10  # its own hits, a few edges
    assert (np.degrees(np.arccos(np.clip(cos, -1, 1))) < 3.0).all()


def test_photogrammetry_points_keep_their_noise_when_another_pixel_changes() -> None:
    cams = np.array([[0.0, -1.0, 1.5], [0.0, 1.0, 1.5]])
    pv = PhotoViews(cams, cams + [6, 0, 0], focal_px=600, width_px=800, height_px=600, pixel_step=4)
    a = scan(_room(False), pv, rng=2)
    b = scan(_room(True), pv, rng=2)
    assert len(a) > 5000
    assert _same_rows(a.xyz, b.xyz).mean() > 0.99


def test_outliers_and_stations_after_a_changed_ray_are_unchanged() -> None:
    """The scan's generator gives each acquisition one key, whatever the hits before."""
    st = _stations()
    a = scan(_room(False), st[::-1], rng=9)
    b = scan(_room(True), st[::-1], rng=9)
    # the second station's points (listed after the first) are bit-identical away from the patch
    second_a = a.xyz[(a.point_source_id == 2) & ~a.outlier]
    second_b = b.xyz[(b.point_source_id == 2) & ~b.outlier]
    assert _same_rows(second_a, second_b).mean() > 0.995
    with_outliers = scan(_room(False), st, outliers=Outliers(share=0.01), rng=9)
    assert with_outliers.outlier.sum() > 0


def test_per_ray_numbers_are_uniform_independent_and_normal() -> None:
    rays = ray_ids(np.repeat(np.arange(400), 500), np.tile(np.arange(500), 400))
    u = ray_uniform(123, rays, 0)
    assert ((u > 0) & (u < 1)).all()
    assert abs(u.mean() - 0.5) < 0.005 and abs(u.std() - np.sqrt(1 / 12)) < 0.003
    # neighbouring rays, and two streams of one ray, are uncorrelated
    assert abs(np.corrcoef(u[:-1], u[1:])[0, 1]) < 0.01
    assert abs(np.corrcoef(u, ray_uniform(123, rays, 1))[0, 1]) < 0.01
    assert abs(np.corrcoef(u, ray_uniform(124, rays, 0))[0, 1]) < 0.01
    hist, _ = np.histogram(u, bins=20, range=(0, 1))
    assert hist.min() > 0.95 * len(u) / 20
    n = ray_normal(123, rays, 2)
    assert abs(n.mean()) < 0.01 and abs(n.std() - 1) < 0.01
    assert abs((np.abs(n) < 1.96).mean() - 0.95) < 0.003
