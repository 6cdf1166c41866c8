"""Distances from points to an IFC element's reopened, triangulated solid (test helper).

The element is triangulated by ifcopenshell in world coordinates, its surface sampled
uniformly by area (seeded), and each point's distance to the nearest sample is
returned; the model's origin is its IfcMapConversion.  Used by the IFC tests;
``benchmarks/bench_ifc.py`` refines the nearest samples to exact triangle distances.
"""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.geom
import numpy as np
from scipy.spatial import cKDTree


def surface_distances(ifc, guid: str, pts_world: np.ndarray, n_samples: int) -> np.ndarray:
    """Distance of each world point to ``n_samples`` area-uniform samples of the element."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    shape = ifcopenshell.geom.create_shape(settings, ifc.by_guid(guid))
    tri = np.asarray(shape.geometry.verts).reshape(-1, 3)[
        np.asarray(shape.geometry.faces).reshape(-1, 3)
    ]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    rng = np.random.default_rng(1)
    k = rng.choice(len(tri), n_samples, p=area / area.sum())
    a, b = rng.random((2, len(k)))
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    s = tri[k, 0] + a[:, None] * (tri[k, 1] - tri[k, 0]) + b[:, None] * (tri[k, 2] - tri[k, 0])
    mc = ifc.by_type("IfcMapConversion")[0]
    d, _ = cKDTree(s).query(pts_world - [mc.Eastings, mc.Northings, mc.OrthogonalHeight])
    return d


def surface_rms(ifc, guid: str, pts_world: np.ndarray, n_samples: int) -> float:
    """RMS of :func:`surface_distances`."""
    return float(np.sqrt(np.mean(surface_distances(ifc, guid, pts_world, n_samples) ** 2)))
