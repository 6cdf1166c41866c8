"""Station plans and acquisitions of a ``church`` draw (interior TLS, exterior TLS or photos).

* Interior: TLS stations along the central aisle of the nave (and in the
  aisles), a full dome each at a step kept within :data:`RAY_BUDGET`.
* Exterior: TLS stations on rings 4-12 m around the building, or
  photogrammetry: stereo pairs of photographs on a terrestrial ring and a
  higher (pole / UAV) ring, each pair matched on its own.
* Target fine scans (TLS) or close-up photographs of every target a station
  sees, as surveyors do for sphere targets.
* Optional window detail scans: a finer region scan (TLS) or a close-up
  stereo pair (photogrammetry) of each window a station sees, at a spacing
  kept within :data:`DETAIL_BUDGET` per cloud.

Each acquisition block keeps its station's number as ``point_source_id``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from pyheracles.synthetic.families.church_layout import ChurchPlan
from pyheracles.synthetic.scanner import PhotoViews, RayCaster, ScanResult, TLSStation

if TYPE_CHECKING:
    from pyheracles.synthetic.families.church import ChurchFamilyParams

__all__ = [
    "DETAIL_BUDGET",
    "PHOTO_BUDGET",
    "RAY_BUDGET",
    "RAY_BUDGET_EXTERIOR",
    "exterior_stations",
    "interior_stations",
    "photo_acquisitions",
    "sources_by_station",
    "tls_acquisitions",
    "to_cloud_frame",
]

Array = NDArray[np.float64]

#: Rays of the interior main scans per cloud (about 1 s per million).
RAY_BUDGET = 1.2e6
#: Rays of the exterior TLS stations (about half of them go to the sky).
RAY_BUDGET_EXTERIOR = 1.6e6
#: Casts of the photogrammetric block (each pixel of a stereo pair is cast about four times).
PHOTO_BUDGET = 3.0e6
#: Rays of the window detail scans per cloud.
DETAIL_BUDGET = 0.5e6


def tls_step(
    drawn: float, n_stations: int, elevation_span: float, budget: float = RAY_BUDGET
) -> float:
    """The drawn TLS step, coarsened so that the stations stay within ``budget`` rays."""
    return float(max(drawn, np.sqrt(n_stations * 360.0 * elevation_span / budget)))


def interior_stations(p: ChurchFamilyParams, plan: ChurchPlan, rng: np.random.Generator) -> Array:
    """Station positions inside: evenly along the central aisle, one in each side aisle."""
    x0, x1 = plan.aisle_line
    n = p.n_interior_stations
    n_aisle = 2 if p.aisles and n >= 3 else 0
    n_nave = n - n_aisle
    xs = np.linspace(x0, x1, n_nave + 2)[1:-1] if n_nave > 1 else np.array([(x0 + x1) / 2])
    spots = [[x + rng.uniform(-0.4, 0.4), rng.uniform(-0.25, 0.25)] for x in xs]
    for s in (-1.0, 1.0)[:n_aisle]:
        y = s * (p.nave_width_m / 2 + (p.aisle_width_m - p.wall_thickness_m) / 2)
        spots.append([rng.uniform(x0, x1), y])
    xy = np.array(spots)
    return np.column_stack([xy, rng.uniform(1.4, 1.8, len(xy))])


def ring_points(plan: ChurchPlan, distance: float, n: int, rng: np.random.Generator) -> Array:
    """``n`` plan points evenly along the outline grown by ``distance`` (with jitter)."""
    ring = plan.footprint.buffer(distance).exterior
    s = (np.arange(n) + rng.uniform(-0.2, 0.2, n) + rng.uniform()) / n * ring.length
    return np.array([np.asarray(ring.interpolate(v).coords)[0] for v in s % ring.length])


def exterior_stations(p: ChurchFamilyParams, plan: ChurchPlan, rng: np.random.Generator) -> Array:
    """TLS stations around the building, each on its own ring 4-12 m out."""
    d = rng.uniform(4.0, 12.0, p.n_exterior_stations)
    s0 = rng.uniform()
    xy = []
    for k, dk in enumerate(d):
        ring = plan.footprint.buffer(float(dk)).exterior
        s = (s0 + (k + rng.uniform(-0.2, 0.2)) / len(d)) % 1.0 * ring.length
        xy.append(np.asarray(ring.interpolate(s).coords)[0])
    xy = np.array(xy)
    return np.column_stack([xy, plan.terrain.height(xy) + rng.uniform(1.4, 1.8, len(xy))])


def _region(station: TLSStation, points: Array, step_deg: float) -> TLSStation:
    """The station restricted to the angular window around ``points``."""
    o = np.asarray(station.position)
    d = points - o
    r = np.linalg.norm(d, axis=1)
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    az0 = az[0]
    az = az0 + (az - az0 + 180.0) % 360.0 - 180.0  # unwrapped around the first point
    el = np.degrees(np.arcsin(np.clip(d[:, 2] / r, -1, 1)))
    return replace(
        station,
        step_deg=float(step_deg),
        azimuth_deg=(float(az.min()), float(az.max())),
        elevation_deg=(float(max(el.min(), -89.9)), float(min(el.max(), 89.9))),
    )


def _target_fine_scans(station: TLSStation, targets: Array, radius: float) -> list[TLSStation]:
    """A fine scan (4 mm at the sphere) of each target within 30 m of the station."""
    out = []
    o = np.asarray(station.position)
    for c in targets:  # up to tens
        r = float(np.linalg.norm(c - o))
        if not 1.0 < r < 30.0:
            continue
        h = radius + 0.05
        box = c + np.array([[-h, -h, -h], [h, h, h], [-h, h, -h], [h, -h, h]])
        out.append(_region(station, box, np.degrees(0.004 / r)))
    return out


def _sees(caster: RayCaster, origin: Array, point: Array, instance: int) -> bool:
    """The ray from ``origin`` reaches ``point`` or first hits ``instance`` just before it."""
    d = point - origin
    dist = float(np.linalg.norm(d))
    t, prim = caster.cast(origin[None, :], (d / dist)[None, :])
    if prim[0] < 0:
        return False
    return bool(t[0] >= dist - 0.3 or caster.instance[prim[0]] == instance)


def _windows(plan: ChurchPlan) -> list[dict[str, Any]]:
    return [o for o in plan.scene.objects if o.get("class") == "window"]


def _detail_scans(
    stations: list[TLSStation],
    plan: ChurchPlan,
    caster: RayCaster,
    spacing_m: float,
    reach_m: float = 25.0,
) -> list[tuple[int, TLSStation]]:
    """Window region scans at ``spacing_m`` (coarsened to :data:`DETAIL_BUDGET`)."""
    jobs = []
    for k, st in enumerate(stations):
        o = np.asarray(st.position)
        for w in _windows(plan):  # tens of windows per station
            ring = np.asarray(w["outline_m"])
            c = np.asarray(w["plane"]["point"])
            r = float(np.linalg.norm(c - o))
            if r > reach_m or not _sees(caster, o, c, w["instance"]):
                continue
            n = np.asarray(w["plane"]["normal"])
            # 0.3 m of wall and reveal all round, on both faces of the wall
            spread = ring - c
            size = np.linalg.norm(spread, axis=1, keepdims=True)
            grown = c + spread * (1 + 0.3 / np.maximum(size, 1e-6))
            pts = np.vstack([grown + 0.6 * n, grown - 0.6 * n])
            jobs.append((k, st, pts, r))
    if not jobs:
        return []

    def n_rays(spacing: float) -> float:
        total = 0.0
        for _, st, pts, r in jobs:
            reg = _region(st, pts, np.degrees(spacing / r))
            total += np.ptp(reg.azimuth_deg) * np.ptp(reg.elevation_deg) / reg.step_deg**2
        return total

    s = spacing_m
    while n_rays(s) > DETAIL_BUDGET:
        s *= 1.25
    return [(k, _region(st, pts, np.degrees(s / r))) for k, st, pts, r in jobs]


def tls_acquisitions(
    positions: Array,
    step_deg: float,
    elevation_deg: tuple[float, float],
    targets: Array,
    radius: float,
    plan: ChurchPlan,
    detail_spacing_m: float | None,
    caster: RayCaster,
) -> tuple[list[TLSStation], list[int]]:
    """Main scans, target fine scans and window detail scans; the station of each."""
    mains = [
        TLSStation(tuple(map(float, s)), step_deg=step_deg, elevation_deg=elevation_deg)
        for s in positions
    ]
    acq, owner = [], []
    for k, st in enumerate(mains, start=1):
        fine = _target_fine_scans(st, targets, radius)
        acq += [st, *fine]
        owner += [k] * (1 + len(fine))
    if detail_spacing_m is not None:
        for k, st in _detail_scans(mains, plan, caster, detail_spacing_m):
            acq.append(st)
            owner.append(k + 1)
    return acq, owner


def photo_acquisitions(
    p: ChurchFamilyParams,
    plan: ChurchPlan,
    rng: np.random.Generator,
    targets: Array,
    detail_spacing_m: float | None,
    caster: RayCaster,
) -> list[PhotoViews]:
    """Stereo pairs around the building (low and high ring), target and window close-ups.

    Photographs come in pairs (base = a quarter of the distance, as in a
    terrestrial block with 60-80 % overlap); each pair is matched on its own
    (a :class:`PhotoViews` of two views; the pairs overlap along the ring).
    The pixel step keeps the block within :data:`PHOTO_BUDGET` casts.
    """
    n_pairs = max(p.n_cameras // 2, 4)
    n_low = int(np.ceil(n_pairs * 0.65))
    n_high = n_pairs - n_low
    d = p.camera_distance_m
    ridge, eaves = plan.heights["ridge"], plan.heights["eaves"]
    step = int(np.clip(np.sqrt(4000 * 3000 * 4 * n_pairs / PHOTO_BUDGET), 8, 40))
    sigma = float(rng.uniform(0.005, 0.01))
    edge = plan.footprint.exterior
    views = []
    for n, z_cam, z_aim in ((n_low, 1.6, 0.45 * eaves), (n_high, None, eaves)):
        if n == 0:
            continue
        ring = plan.footprint.buffer(d).exterior
        s0 = rng.uniform() * ring.length
        for k in range(n):  # one stereo pair per stop along the ring
            pos, look = [], []
            for db in (-0.125 * d, 0.125 * d):
                s = (s0 + (k + rng.uniform(-0.15, 0.15)) / n * ring.length + db) % ring.length
                q = np.asarray(ring.interpolate(s).coords)[0]
                near = edge.interpolate(edge.project(shapely.Point(q)))
                g = float(plan.terrain.height(q)[0])
                z = g + 1.6 if z_cam is not None else ridge + float(rng.uniform(2.0, 6.0))
                pos.append([q[0], q[1], z])
                look.append([near.x, near.y, z_aim])
            views.append(PhotoViews(np.array(pos), np.array(look), pixel_step=step, sigma_m=sigma))
    cx, cy = plan.footprint.centroid.x, plan.footprint.centroid.y
    for c in targets:  # close-ups: three photographs 3 m away, small frame
        a0 = np.arctan2(c[1] - cy, c[0] - cx)
        cams = [
            [c[0] + 3.0 * np.cos(a0 + da), c[1] + 3.0 * np.sin(a0 + da), c[2] + 0.3]
            for da in (-0.35, 0.0, 0.35)
        ]
        views.append(
            PhotoViews(
                np.array(cams),
                np.tile(c, (3, 1)),
                width_px=400,
                height_px=300,
                pixel_step=3,
                sigma_m=0.003,
                sigma_clip_m=(0.001, 0.004),
            )
        )
    if detail_spacing_m is not None:
        views += _window_pairs(plan, rng, detail_spacing_m, sigma, caster)
    return views


def _window_pairs(
    plan: ChurchPlan,
    rng: np.random.Generator,
    spacing_m: float,
    sigma: float,
    caster: RayCaster,
) -> list[PhotoViews]:
    """Close-up stereo pairs of each window from outside, 35 deg to its left and right.

    Oblique views see the side reveals (a view along the normal meets them at
    grazing incidence and the glass gives no match); 4-6 m away, 1 m base.
    """
    jobs = []
    for w in _windows(plan):
        ring = np.asarray(w["outline_m"])
        c = np.asarray(w["plane"]["point"])
        n = np.asarray(w["plane"]["normal"])
        side = np.cross([0.0, 0.0, 1.0], n)
        side /= max(np.linalg.norm(side), 1e-9)
        ext_h = float(np.max(np.abs((ring - c) @ side))) + 0.3
        ext_v = float(np.max(np.abs(ring[:, 2] - c[2]))) + 0.3
        for a in np.deg2rad([-35.0, 35.0]):
            view = np.cos(a) * n + np.sin(a) * side
            cam = c + float(rng.uniform(4.0, 6.0)) * view
            cam[2] = max(c[2] - 1.0, float(plan.terrain.height(cam[:2])[0]) + 1.6)
            if not _sees(caster, cam, c, w["instance"]):
                continue
            base = np.cross([0.0, 0.0, 1.0], view)
            base /= max(np.linalg.norm(base), 1e-9)
            jobs.append((c, cam, base, ext_h, ext_v, float(np.linalg.norm(c - cam))))
    if not jobs:
        return []
    focal = 3000.0

    def pixels(spacing: float) -> float:
        return sum(4 * (2 * eh / spacing) * (2 * ev / spacing) for *_, eh, ev, _ in jobs)

    s = spacing_m
    while pixels(s) > DETAIL_BUDGET:
        s *= 1.25
    views = []
    for c, cam, base, ext_h, ext_v, r in jobs:
        step = max(round(s / r * focal), 1)
        pos = np.array([cam - 0.5 * base, cam + 0.5 * base])
        views.append(
            PhotoViews(
                pos,
                np.tile(c, (2, 1)),
                focal_px=focal,
                width_px=int(2 * ext_h / r * focal),
                height_px=int(2 * ext_v / r * focal),
                pixel_step=step,
                sigma_m=sigma,
            )
        )
    return views


def to_cloud_frame(res: ScanResult, frame: tuple[float, ...]) -> tuple[ScanResult, Array]:
    """The scan in its own frame, and ``T_scene_cloud`` from ``(tx, ty, tz, omega, phi, kappa)``."""
    tx, ty, tz, om, ph, ka = frame
    R = Rotation.from_euler("ZYX", [ka, ph, om], degrees=True).as_matrix()
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [tx, ty, tz]
    local = np.einsum("ij,jk->ik", res.xyz - T[:3, 3], R)
    return replace(res, xyz=local), T


def sources_by_station(res: ScanResult, owner: list[int]) -> ScanResult:
    """Point source ids of the fine and detail scans replaced by their station's number."""
    lut = np.asarray([0, *owner], dtype=np.uint16)
    return replace(res, point_source_id=lut[res.point_source_id])
