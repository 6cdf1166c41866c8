"""The site of a ``church`` draw: furniture inside, uneven ground and gravestones outside.

Pews (seat, back and two ends each) in two blocks either side of the central
aisle, an altar on its step (at the east end of the nave or in the apse),
benches along the side walls; outside, a height grid with mounds, hollows
and a site slope beyond a flat apron along the walls, and gravestones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.interpolate import RegularGridInterpolator
from shapely.geometry import Polygon, box

from pyheracles.synthetic.scene import STONE, TIMBER, Scene

if TYPE_CHECKING:
    from pyheracles.synthetic.families.church import ChurchFamilyParams
    from pyheracles.synthetic.families.church_layout import ChurchPlan

__all__ = ["InstanceCounter", "Terrain", "add_furniture", "add_gravestones", "make_terrain"]

Array = NDArray[np.float64]


@dataclass
class Terrain:
    """The ground outside as a height grid (``z[i, j]`` at ``(x[j], y[i])``)."""

    x: Array
    y: Array
    z: Array

    def height(self, xy: Array) -> Array:
        """Ground height at plan points ``(K, 2)`` (bilinear)."""
        f = RegularGridInterpolator((self.y, self.x), self.z, bounds_error=False, fill_value=None)
        xy = np.asarray(xy, float).reshape(-1, 2)
        return f(xy[:, ::-1])


class InstanceCounter:
    """Instance numbers in creation order."""

    def __init__(self) -> None:
        self.n = 0

    def __call__(self) -> int:
        self.n += 1
        return self.n


# ----------------------------------------------------------------------------- furniture
def _box_object(
    scene: Scene, inst: int, cls: str, centre: Array, size: Array, part: str, material: Any
) -> None:
    scene.add_box(
        centre,
        size,
        instance=inst,
        class_name=cls,
        part=part,
        material=material,
        faces=("-x", "+x", "-y", "+y", "+z"),
    )


def add_furniture(
    scene: Scene,
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    h: dict[str, float],
    inner: list[Polygon],
) -> tuple[list[Polygon], tuple[float, float]]:
    """Pews, altar on its step, benches; returns the free floor and the central aisle."""
    L, W, t = p.nave_length_m, p.nave_width_m, p.wall_thickness_m
    yi = W / 2 - t
    west_free = float(rng.uniform(2.0, 4.0))
    chancel = float(rng.uniform(2.5, 5.0)) if not p.apse else float(rng.uniform(1.0, 2.5))
    x0, x1 = t + west_free, L - t - chancel
    aisle = float(rng.uniform(0.6, 1.0))  # half width of the central aisle
    side = float(rng.uniform(0.5, 0.9))
    free = [box(t + 0.3, -yi + 0.3, x0 - 0.3, yi - 0.3), box(x0, -aisle + 0.2, x1, aisle - 0.2)]
    if p.pews and x1 - x0 > 2.0 and yi - side - aisle > 1.0:
        pitch = float(rng.uniform(0.85, 1.1))
        n_rows = int((x1 - x0) // pitch)
        length = yi - side - aisle
        for r in range(n_rows):  # tens of pews, 4 boxes each
            xb = x0 + r * pitch
            for s in (-1.0, 1.0):
                inst = ids()
                yc = s * (aisle + length / 2)
                _box_object(
                    scene,
                    inst,
                    "pew",
                    np.array([xb + 0.25, yc, 0.45]),
                    np.array([0.42, length, 0.05]),
                    "seat",
                    TIMBER,
                )
                _box_object(
                    scene,
                    inst,
                    "pew",
                    np.array([xb + 0.5, yc, 0.7]),
                    np.array([0.05, length, 0.5]),
                    "back",
                    TIMBER,
                )
                for e in (-1.0, 1.0):
                    _box_object(
                        scene,
                        inst,
                        "pew",
                        np.array([xb + 0.27, yc + e * (length / 2 - 0.025), 0.47]),
                        np.array([0.5, 0.05, 0.94]),
                        "end",
                        TIMBER,
                    )
                scene.objects.append(
                    {
                        "instance": inst,
                        "class": "pew",
                        "box": [xb, yc - length / 2, 0.0, xb + 0.52, yc + length / 2, 0.95],
                    }
                )
    else:
        free.append(box(x0, -yi + 0.3, x1, yi - 0.3))
    # altar on a step, at the east end of the nave or in the apse
    step_h = float(rng.uniform(0.15, 0.3))
    if p.apse:
        ax = L + 0.4 * h["apse_inner_radius"]
        step = box(
            L - 0.5,
            -h["apse_inner_radius"] * 0.8,
            L + h["apse_inner_radius"] * 0.7,
            h["apse_inner_radius"] * 0.8,
        )
    else:
        ax = L - t - 1.2
        step = box(L - t - min(chancel, 2.8), -yi + 0.2, L - t, yi - 0.2)
    inst = ids()
    step = step.intersection(shapely.union_all(inner).buffer(-0.05))
    for poly in getattr(step, "geoms", [step]):
        if isinstance(poly, Polygon) and poly.area > 0.01:
            scene.add_prism(
                poly,
                [0.0, 0.0, 0.0],
                np.eye(3),
                step_h,
                faces="back",
                instance=inst,
                class_name="altar",
                part="step",
                material=STONE,
            )
    aw = float(rng.uniform(1.5, 2.5))
    _box_object(
        scene,
        inst,
        "altar",
        np.array([ax, 0.0, step_h + 0.5]),
        np.array([0.9, aw, 1.0]),
        "table",
        STONE,
    )
    scene.objects.append(
        {
            "instance": inst,
            "class": "altar",
            "box": [ax - 0.45, -aw / 2, step_h, ax + 0.45, aw / 2, step_h + 1.0],
            "step_m": step_h,
        }
    )
    # benches along the side walls at the west end
    for s in (-1.0, 1.0):
        if rng.random() < 0.6 and west_free > 2.5:
            inst = ids()
            bl = float(rng.uniform(1.2, west_free - 0.6))
            c = np.array([t + 0.3 + bl / 2, s * (yi - 0.25), 0.225])
            _box_object(scene, inst, "bench", c, np.array([bl, 0.4, 0.45]), "bench", TIMBER)
            scene.objects.append(
                {
                    "instance": inst,
                    "class": "bench",
                    "box": [c[0] - bl / 2, c[1] - 0.2, 0, c[0] + bl / 2, c[1] + 0.2, 0.45],
                }
            )
    return free, (x0 - west_free / 2, x1 - 0.5)


# ----------------------------------------------------------------------------- ground
def make_terrain(
    p: ChurchFamilyParams, rng: np.random.Generator, footprint: Polygon, margin: float, g0: float
) -> Terrain:
    x0, y0, x1, y1 = footprint.bounds
    x = np.arange(x0 - margin, x1 + margin + 0.6, 0.6)
    y = np.arange(y0 - margin, y1 + margin + 0.6, 0.6)
    X, Y = np.meshgrid(x, y)
    pts = shapely.points(X.ravel(), Y.ravel())
    d = shapely.distance(pts, footprint).reshape(X.shape)
    bumps = np.zeros_like(X)
    for _ in range(int(rng.integers(6, 14))):  # smooth mounds and hollows
        cx, cy = rng.uniform(x[0], x[-1]), rng.uniform(y[0], y[-1])
        s = rng.uniform(2.0, 8.0)
        bumps += (
            rng.uniform(-1, 1)
            * p.ground_relief_m
            * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * s**2))
        )
    az = rng.uniform(0, 2 * np.pi)
    slope = p.ground_slope * ((X - (x0 + x1) / 2) * np.cos(az) + (Y - (y0 + y1) / 2) * np.sin(az))
    w = np.clip((d - 0.3) / 3.0, 0.0, 1.0)  # a flat apron along the walls
    z = g0 + w * (bumps + slope)
    z += w * rng.normal(0, 0.01, X.shape)
    z = np.where(d <= 0.0, g0 - 0.3, z)
    return Terrain(x, y, z)


def add_gravestones(
    scene: Scene,
    plan: ChurchPlan,
    rng: np.random.Generator,
    n: int,
    keep_clear: Array,
    ids: InstanceCounter,
) -> int:
    """Gravestones in the churchyard, clear of ``keep_clear`` plan points (stations, cameras)."""
    t = plan.terrain
    placed = 0
    for _ in range(n * 20):
        if placed >= n:
            break
        xy = np.array([rng.uniform(t.x[1], t.x[-2]), rng.uniform(t.y[1], t.y[-2])])
        dist = plan.footprint.distance(shapely.Point(xy))
        if dist < 2.0 or dist > 18.0:
            continue
        if len(keep_clear) and np.min(np.linalg.norm(keep_clear[:, :2] - xy, axis=1)) < 1.8:
            continue
        z = float(t.height(xy)[0])
        w, th, hh = rng.uniform(0.4, 0.9), rng.uniform(0.08, 0.2), rng.uniform(0.4, 1.2)
        a = np.deg2rad(rng.uniform(-15, 15))
        frame = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1.0]])
        inst = ids()
        scene.add_box(
            [xy[0], xy[1], z + hh / 2 - 0.15],
            [th, w, hh + 0.3],
            frame=frame,
            instance=inst,
            class_name="gravestone",
            part="stone",
            material=STONE,
            faces=("-x", "+x", "-y", "+y", "+z"),
        )
        scene.objects.append(
            {"instance": inst, "class": "gravestone", "centre": [*xy, z], "size_m": [th, w, hh]}
        )
        placed += 1
    return placed
