"""Automatic pane registration of a church family draw and its error (test helper).

Used by ``test_panes_family`` and ``test_panes_deep_reveals``: the draw's two clouds as
``heracles register --auto`` reads them (coordinates rounded to 0.1 mm, as in LAZ),
the pane tie points, the rigid robust similarity, and the RMS distance between the
interior points mapped by the estimate and by the truth.
"""

from __future__ import annotations

import numpy as np

from pyheracles.cloud import PointCloud
from pyheracles.registration.similarity import SimilarityParams, estimate_similarity
from pyheracles.registration.tiepoints import TiePointParams, find_tie_points
from pyheracles.registration.transform import apply_to_points
from pyheracles.synthetic.families import simulate


def register_church(seed: int):
    """(simulation, clouds, tie points, similarity) of church draw ``seed``."""
    sim = simulate("church", seed)
    clouds = {
        k: PointCloud.from_world(np.round(sim.clouds[k].xyz, 4), source=f"{k}.laz")
        for k in ("interior", "exterior")
    }
    sp = SimilarityParams(with_scale=False, estimator="danish")
    tp = find_tie_points(
        clouds["interior"],
        clouds["exterior"],
        TiePointParams(pane_thickness_m=sim.params["pane_thickness_m"]),
        similarity=sp,
    )
    return sim, clouds, tp, estimate_similarity(tp.source.xyz, tp.target.xyz, sp)


def error_at_interior(sim, cloud: PointCloud, T: np.ndarray) -> float:
    """RMS distance (m) of every 5000th interior point mapped by ``T`` and by the truth."""
    T_true = np.linalg.inv(sim.transforms["exterior"]) @ sim.transforms["interior"]
    probe = cloud.world_xyz()[::5000]
    err = apply_to_points(T, probe) - apply_to_points(T_true, probe)
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
