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
