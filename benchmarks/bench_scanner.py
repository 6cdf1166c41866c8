"""Scan simulator speed: output points per second of one TLS station, vs Open3D ray casting.

Run: ``python benchmarks/bench_scanner.py`` (``pip install -e ".[bench]"`` for the Open3D peer).

The scene is a hall: floor, four walls, a vaulted-like ceiling of quads, 24 columns
(96 segments each) and pews; one station at 1.6 m with a 0.08 deg step.  Reported:
rays cast, output points, seconds, points/s, and Open3D ``RaycastingScene.cast_rays``
on the same rays in the same run (ray casting only; our figure includes everything
a scanner does: noise, drop-out, mixed pixels, glass, outliers).  Target: >= 1 M
output points/s on 2 cores.
"""

from __future__ import annotations

import argparse

from _common import emit, interruptible, timer

import numpy as np

from pyheracles.synthetic.scanner import Outliers, RayCaster, TLSStation, scan
from pyheracles.synthetic.scene import Scene


def hall() -> Scene:
    s = Scene()
    s.add_box([0, 0, -0.1], [40, 20, 0.2], class_name="floor", part="floor")
    for x in (-20.25, 20.25):
        s.add_box([x, 0, 5], [0.5, 20, 10], class_name="wall", part="wall")
    for y in (-10.25, 10.25):
        s.add_box([0, y, 5], [40, 0.5, 10], class_name="wall", part="wall")
    s.add_box([0, 0, 10.1], [40, 20, 0.2], class_name="ceiling", part="ceiling")
    k = 1
    for x in np.linspace(-15, 15, 6):
        for y in (-6.0, -2.0, 2.0, 6.0):
            s.add_cylinder(
                [x, y, 0], [0, 0, 1], 9.9, 0.35, instance=k, class_name="column", part="shaft"
            )
            k += 1
    for x in np.arange(-12, 12, 1.2):
        s.add_box([x, 8.5, 0.45], [0.4, 2.5, 0.9], class_name="clutter", part="pew")
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--step", type=float, default=0.08, help="angular step, degrees")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    s = hall()
    st = TLSStation((1.0, 0.5, 1.6), step_deg=args.step)
    best = np.inf
    n = 0
    for _ in range(args.repeat):
        with timer() as t:
            res = scan(s, st, outliers=Outliers(0.002), rng=0)
        best = min(best, t.s)
        n = len(res)
    step = np.deg2rad(args.step)
    n_rays = int(np.ceil(2 * np.pi / step) * np.ceil(np.deg2rad(150) / step))
    record = {
        "dataset": "hall, 1 TLS station",
        "metric": "scan_points_per_s",
        "points": n,
        "rays": n_rays,
        "time_s": round(best, 3),
        "value": round(n / best),
        "target": 1_000_000,
        "pass": n / best >= 1e6,
    }
    try:
        import open3d as o3d
    except ImportError:
        emit(**record, peer=None, note="open3d not installed (pip install -e '.[bench]')")
        return
    caster = RayCaster(s)
    sc = o3d.t.geometry.RaycastingScene()
    tris = s.triangles.reshape(-1, 3).astype(np.float32)
    sc.add_triangles(tris, np.arange(len(tris), dtype=np.uint32).reshape(-1, 3))
    az = np.arange(0, 2 * np.pi, step)
    el = np.arange(np.deg2rad(-60), np.deg2rad(90), step)
    A, E = np.meshgrid(az, el, indexing="ij")
    d = np.column_stack(
        [
            np.cos(E).ravel() * np.cos(A).ravel(),
            np.cos(E).ravel() * np.sin(A).ravel(),
            np.sin(E).ravel(),
        ]
    )
    rays = np.hstack([np.broadcast_to(np.float32(st.position), d.shape), d]).astype(np.float32)
    o3d_best = ours_best = np.inf
    for _ in range(args.repeat):
        with timer() as t:
            sc.cast_rays(o3d.core.Tensor(rays))
        o3d_best = min(o3d_best, t.s)
        with timer() as t:
            caster.cast(np.asarray(st.position), d)
        ours_best = min(ours_best, t.s)
    emit(
        **record,
        peer="open3d RaycastingScene.cast_rays (same rays)",
        peer_cast_s=round(o3d_best, 3),
        our_cast_s=round(ours_best, 3),
        cast_ratio_ours_over_peer=round(ours_best / o3d_best, 2),
    )


if __name__ == "__main__":
    interruptible(main)
