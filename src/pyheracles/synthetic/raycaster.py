"""Nearest-hit ray casting into a generated scene (Embree through ``embreex``).

Why ``embreex`` and not Open3D's ``RaycastingScene``: see the scanner module's
docstring (:mod:`pyheracles.synthetic.scanner`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError
from pyheracles.synthetic.scene import Scene

__all__ = ["RayCaster"]

Array = NDArray[np.float64]


class RayCaster:
    """Nearest-hit ray casting into a scene (Embree), with the hits' references.

    Parameters
    ----------
    scene
        The scene; its triangles are copied into Embree once.
    """

    def __init__(self, scene: Scene) -> None:
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        tris = scene.triangles
        if len(tris) == 0:
            raise InputError("the scene has no surfaces to scan")
        self.scene = scene
        self._embree = rtcs.EmbreeScene()
        self._mesh = TriangleMesh(self._embree, np.ascontiguousarray(tris, np.float32))
        n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        self.normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        self.instance = scene.triangle_instance
        self.class_id = scene.triangle_class
        self.part = scene.triangle_part
        mats = scene.materials
        mid = scene.triangle_material
        self.reflectance = np.array([m.reflectance for m in mats])[mid]
        self.transmittance = np.array([m.transmittance for m in mats])[mid]
        self.porous = np.array([m.porous for m in mats])[mid]
        self.matchable = np.array([m.matchable for m in mats])[mid]
        self.lo, self.hi = scene.bounds()

    def cast(
        self, origins: Array, directions: Array, chunk: int = 2_000_000
    ) -> tuple[Array, NDArray[np.int64]]:
        """Distance to the nearest hit (inf on a miss) and the triangle hit (-1)."""
        n = len(directions)
        t = np.full(n, np.inf)
        prim = np.full(n, -1, np.int64)
        o = np.broadcast_to(np.asarray(origins, np.float32), (n, 3))
        for s in range(0, n, chunk):
            sl = slice(s, min(s + chunk, n))
            res = self._embree.run(
                np.ascontiguousarray(o[sl]),
                np.ascontiguousarray(directions[sl], np.float32),
                output=1,
            )
            hit = res["geomID"] != -1
            tt = res["tfar"].astype(float)
            t[sl] = np.where(hit, tt, np.inf)
            prim[sl] = np.where(hit, res["primID"], -1)
        return t, prim

    def first_solid(
        self, origins: Array, directions: Array, rng: np.random.Generator, max_layers: int = 4
    ) -> tuple[Array, NDArray[np.int64], NDArray[np.bool_]]:
        """Nearest hit that returns, passing through glass by its transmittance.

        Returns the range, the triangle and whether the beam passed through glass
        before (for reflections).  Porous surfaces stop a terrestrial beam.
        """
        n = len(directions)
        o = np.array(np.broadcast_to(origins, (n, 3)), float)
        total = np.zeros(n)
        t, prim = self.cast(o, directions)
        passed = np.zeros(n, bool)
        glass_at = np.full(n, np.inf)
        # only beams still travelling are tested: a beam that did not pass a glass face
        # returns from it and is never re-drawn (else glass would almost never return)
        active = np.ones(n, bool)
        for _ in range(max_layers):
            tr = self.transmittance[np.maximum(prim, 0)]
            on_glass = active & (prim >= 0) & (tr > 0)
            go = on_glass & (rng.random(n) < tr)
            active = go
            if not go.any():
                break
            idx = np.flatnonzero(go)
            glass_at[idx] = np.minimum(glass_at[idx], total[idx] + t[idx])
            step = t[idx] + 1e-4
            total[idx] += step
            o[idx] += step[:, None] * directions[idx]
            t2, p2 = self.cast(o[idx], directions[idx])
            t[idx], prim[idx] = t2, p2
            passed[idx] = True
        return total + t, prim, passed & np.isfinite(glass_at)
