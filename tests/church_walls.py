"""Test helper: step 2's walls on a church-family draw (interior + exterior TLS, every
scan in the scene frame) and the draw's true objects."""

from __future__ import annotations

import numpy as np


def church_walls(seed: int):
    """(``segment_walls`` result, the scene's true objects) of church draw ``seed``."""
    from pyheracles.synthetic.families import simulate
    from pyheracles.walls import segment_walls

    sim = simulate("church", seed, exterior_kind="tls")
    xyz = np.vstack([c.xyz @ sim.transforms[k][:3, :3].T + sim.transforms[k][:3, 3]
                     for k, c in sim.clouds.items()])  # fmt: skip
    return segment_walls(xyz), sim.scene.objects


def nearest_opening(result, true_object: dict):
    """(opening, distance m) of ``result``'s walls whose centre is nearest the centre of
    a true window or door (its ``box_corners_m``); (None, inf) when there is none."""
    centre = np.asarray(true_object["box_corners_m"]).mean(axis=0)
    best, dist = None, np.inf
    for w in result.walls:
        for o in w.openings:
            c = w.to_3d([[0.5 * (o.u_min + o.u_max), 0.5 * (o.z_min + o.z_max)]])[0]
            if np.linalg.norm(c - centre) < dist:
                best, dist = o, float(np.linalg.norm(c - centre))
    return best, dist


def wall_crop(seed: int, name: str, noise_draw: int = 0, margin: float = 1.0):
    """Church draw ``seed`` (``noise_draw``) cut to the stretch of its true wall ``name``:
    (points within ``margin`` + 1 m of the wall's faces and within ``margin`` of its
    ends, the true wall, its true windows and doors)."""
    from pyheracles.synthetic.families import simulate

    sim = simulate("church", seed, exterior_kind="tls", noise_draw=noise_draw)
    xyz = np.vstack([c.xyz @ sim.transforms[k][:3, :3].T + sim.transforms[k][:3, 3]
                     for k, c in sim.clouds.items()])  # fmt: skip
    objs = sim.scene.objects
    tw = next(o for o in objs if o["class"] == "wall" and o["name"] == name)
    n, th = np.asarray(tw["outer_plane"]["normal"]), tw["thickness_m"]
    mid = tw["outer_plane"]["d"] - 0.5 * th
    p0, p1 = np.asarray(tw["p0"], dtype=float), np.asarray(tw["p1"], dtype=float)
    length = float(np.linalg.norm(p1 - p0))
    u = (xyz[:, :2] - p0) @ ((p1 - p0) / length)
    keep = (np.abs(xyz @ n - mid) < 0.5 * th + margin + 1.0) & (u > -margin)
    keep &= u < length + margin
    ops = [o for o in objs if o["class"] in ("window", "door") and o["wall"] == name]
    return xyz[keep], tw, ops


def openings_over(wall, ops: list[dict]) -> list[int]:
    """Per true window or door of ``ops``, the openings of ``wall`` (a detected
    :class:`~pyheracles.walls.Wall`) whose centre lies within its width and whose
    heights overlap its."""
    out = []
    for o in ops:
        bc = np.asarray(o["box_corners_m"])
        uc = float((bc.mean(axis=0) - wall.origin) @ wall.u_axis)
        z0, z1 = bc[:, 2].min(), bc[:, 2].max()
        out.append(sum(abs(0.5 * (q.u_min + q.u_max) - uc) < 0.5 * o["width_m"]
                       and q.z_max > z0 and q.z_min < z1 for q in wall.openings))  # fmt: skip
    return out


def faces_along_x(*clouds: np.ndarray) -> tuple[np.ndarray, list]:
    """(points, faces): one ``WallFace`` facing +x per cloud, at its points' mean x, each
    taking the next block of indices of the stacked points."""
    from pyheracles.walls.model import WallFace

    faces, start = [], 0
    n = np.array([1.0, 0.0, 0.0])
    for pts in clouds:
        idx = np.arange(start, start + len(pts))
        faces.append(WallFace(n, float(np.mean(pts @ n)), idx, 0.002))
        start += len(pts)
    return np.vstack(clouds), faces
