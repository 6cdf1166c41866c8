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
