"""The survey of a ``supports`` building: a surveyor's station plan and camera network.

Stations stand on free floor inside (away from supports, walls and clutter)
and on the ground outside, few or many, either spread out (a planned survey:
farthest-point choice among candidates) or where the surveyor happened to
put them.  Each terrestrial station scans a full dome at one angular step; an
optional detail station scans a window round one support at the fine step of
the issue (5-15 mm at 10 m); exterior stations may scan only the sector of the
building (``outside_window``).  Photogrammetry adds a ring or a walk of camera
positions looking at the supports.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.synthetic.families.supports_layouts import Plan
from pyheracles.synthetic.scanner import PhotoViews, TLSStation

__all__ = ["DOME", "Survey", "plan_survey"]

Array = NDArray[np.float64]

#: Camera positions matched together (two views each); the matching cost of a block
#: grows with the square of its views.
PHOTO_BLOCK_POSITIONS = 2

#: Field of a full-dome station: azimuth span x elevation span, degrees.
DOME = (360.0, 150.0)


@dataclass(frozen=True)
class Survey:
    """Acquisitions and a JSON-able description of them."""

    acquisitions: list[Any]
    stations: list[dict[str, Any]]


def _candidates(region: shapely.Geometry, n: int, rng: np.random.Generator) -> Array:
    """Up to ``n`` random points inside ``region``."""
    if region.is_empty or region.area < 1e-3:
        return np.empty((0, 2))
    x0, y0, x1, y1 = region.bounds
    pts = np.c_[rng.uniform(x0, x1, 8 * n), rng.uniform(y0, y1, 8 * n)]
    inside = shapely.contains_xy(region, pts[:, 0], pts[:, 1])
    return pts[inside][:n]


def _choose(cand: Array, k: int, planned: bool, rng: np.random.Generator) -> Array:
    """``k`` stations among candidates: farthest-point (planned) or at random."""
    if k <= 0 or len(cand) == 0:
        return np.empty((0, 2))
    if not planned:
        return cand[rng.choice(len(cand), min(k, len(cand)), replace=False)]
    chosen = [int(rng.integers(len(cand)))]
    d = np.hypot(*(cand - cand[chosen[0]]).T)
    while len(chosen) < min(k, len(cand)):
        i = int(np.argmax(d))
        chosen.append(i)
        d = np.minimum(d, np.hypot(*(cand - cand[i]).T))
    return cand[chosen]


def _regions(
    plan: Plan, solids: list[shapely.Geometry], bounds: tuple[float, ...], reach_m: float
) -> tuple[shapely.Geometry, shapely.Geometry]:
    """Free floor inside, free ground outside (within ``reach_m`` of the building)."""
    blocked = shapely.union_all([g.buffer(0.5) for g in solids]) if solids else shapely.Polygon()
    inside = (plan.inside or shapely.box(*plan.rect)).buffer(-0.3).difference(blocked)
    x0, y0, x1, y1 = bounds
    body = shapely.box(x0, y0, x1, y1)
    ring = body.buffer(reach_m, join_style="mitre").difference(body.buffer(1.5))
    if plan.attic is not None:  # stations under the eaves are fine; not on the platform edge
        ring = ring.difference(shapely.box(*plan.rect).buffer(0.5))
    return inside, ring.difference(blocked)


def plan_survey(
    p: Any,
    plan: Plan,
    solids: list[shapely.Geometry],
    bounds: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> Survey:
    """Stations (and cameras) for the drawn survey parameters ``p``.

    ``bounds`` is the footprint of the building (supports, walls and attic).
    """
    z_floor = plan.platform_m
    inside, outside = _regions(plan, solids, bounds, p.outside_reach_m)
    planned = p.station_plan == "planned"
    pin = _choose(_candidates(inside, 400, rng), p.n_stations_inside, planned, rng)
    pout = _choose(_candidates(outside, 400, rng), p.n_stations_outside, planned, rng)
    if len(pin) + len(pout) == 0:  # nowhere planned: one station outside the footprint
        c = _candidates(outside, 50, rng)
        pout = c[:1] if len(c) else np.array([[bounds[0] - 3.0, bounds[1] - 3.0]])
    acqs: list[Any] = []
    desc: list[dict[str, Any]] = []
    tls = p.survey in ("tls", "tls+photo")
    for xy, where in [*((q, "inside") for q in pin), *((q, "outside") for q in pout)]:
        z = (z_floor if where == "inside" else 0.0) + p.tripod_height_m
        pos = (float(xy[0]), float(xy[1]), float(z))
        window = (0.0, 360.0)
        if where == "outside" and p.outside_window:
            window = _sector(xy, bounds)
        if tls:
            acqs.append(
                TLSStation(
                    pos,
                    step_deg=p.tls_step_deg,
                    azimuth_deg=window,
                    noise_m=p.noise_m,
                    noise_per_m=p.noise_per_m,
                )
            )
        desc.append(
            {
                "kind": "tls" if tls else "camera",
                "where": where,
                "position": pos,
                "azimuth_deg": list(window),
                "step_deg": p.tls_step_deg if tls else None,
                "spacing_at_10m_m": 10 * np.deg2rad(p.tls_step_deg) if tls else None,
            }
        )
    if tls and p.detail_scan and plan.supports:
        det = _detail_station(p, plan, inside if len(pin) else outside, z_floor, rng)
        if det is not None:
            acqs.append(det[0])
            desc.append(det[1])
    if p.survey in ("photo", "tls+photo"):
        cams = _camera_positions(p, inside, outside, z_floor, rng)
        for block in _photo(p, plan, cams, z_floor, rng):
            acqs.append(block)
            desc.append(
                {
                    "kind": "photogrammetry",
                    "views": len(block.positions),
                    "positions": np.asarray(block.positions).tolist(),
                    "pixel_step": p.photo_pixel_step,
                }
            )
    return Survey(acqs, desc)


def _sector(xy: Array, bounds: tuple[float, float, float, float]) -> tuple[float, float]:
    """Azimuth window (degrees) of an exterior station onto the building, 10 deg margin."""
    x0, y0, x1, y1 = bounds
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) - np.asarray(xy)[:2]
    ang = np.degrees(np.arctan2(corners[:, 1], corners[:, 0]))
    mid = float(np.degrees(np.arctan2(*(corners.mean(axis=0)[::-1]))))
    rel = (ang - mid + 180.0) % 360.0 - 180.0  # corner angles about the building's middle
    lo, hi = mid + rel.min() - 10.0, mid + rel.max() + 10.0
    if hi - lo >= 360.0:
        return (0.0, 360.0)
    return (float(lo), float(hi))


def _camera_positions(
    p: Any,
    inside: shapely.Geometry,
    outside: shapely.Geometry,
    z_floor: float,
    rng: np.random.Generator,
) -> Array:
    """Camera positions (hand-held height) spread over the free floor and ground."""
    n = p.n_photo_positions
    share_in = p.n_stations_inside / max(1, p.n_stations_inside + p.n_stations_outside)
    k_in = round(n * share_in)
    pin = _choose(_candidates(inside, 300, rng), k_in, True, rng)
    pout = _choose(_candidates(outside, 300, rng), n - len(pin), True, rng)
    pos = [[x, y, z_floor + 1.6] for x, y in pin] + [[x, y, 1.6] for x, y in pout]
    return np.asarray(pos, float).reshape(-1, 3)


def _detail_station(
    p: Any, plan: Plan, region: shapely.Geometry, z_floor: float, rng: np.random.Generator
) -> tuple[TLSStation, dict[str, Any]] | None:
    """A window scan of one support at the fine step (at most ~0.5 M rays)."""
    s = plan.supports[int(rng.integers(len(plan.supports)))]
    ring = shapely.Point(s.x, s.y).buffer(6.0).difference(shapely.Point(s.x, s.y).buffer(2.0))
    cand = _candidates(region.intersection(ring), 50, rng)
    if len(cand) == 0:
        return None
    xy = cand[0]
    step = p.detail_step_deg
    rays = 5.0e5
    el_span = float(min(80.0, np.sqrt(rays * step**2 * 2.0)))
    az_span = float(min(60.0, rays * step**2 / el_span))
    az = float(np.degrees(np.arctan2(s.y - xy[1], s.x - xy[0]))) % 360.0
    pos = (float(xy[0]), float(xy[1]), float(z_floor + p.tripod_height_m))
    st = TLSStation(
        pos,
        step_deg=step,
        elevation_deg=(-el_span * 0.4, el_span * 0.6),
        azimuth_deg=(az - az_span / 2, az + az_span / 2),
        noise_m=p.noise_m,
        noise_per_m=p.noise_per_m,
    )
    return st, {
        "kind": "detail",
        "where": "inside",
        "position": pos,
        "step_deg": step,
        "spacing_at_10m_m": 10 * np.deg2rad(step),
        "azimuth_deg": list(st.azimuth_deg),
        "elevation_deg": list(st.elevation_deg),
    }


def _photo(
    p: Any, plan: Plan, stations: Array, z_floor: float, rng: np.random.Generator
) -> list[PhotoViews]:
    """Two views per position (one low, one raised on a pole) aimed between the nearest
    supports and the middle, in blocks of PHOTO_BLOCK_POSITIONS neighbouring positions (chunks
    matched apart and merged, as in practice; the matching cost grows with the square
    of the views of a block)."""
    targets_xy = (
        np.array([[s.x, s.y] for s in plan.supports])
        if plan.supports
        else np.array([[(plan.rect[0] + plan.rect[2]) / 2, (plan.rect[1] + plan.rect[3]) / 2]])
    )
    centre = targets_xy.mean(axis=0)
    order = np.argsort(np.arctan2(stations[:, 1] - centre[1], stations[:, 0] - centre[0]))
    stations = stations[order]
    blocks = []
    per = PHOTO_BLOCK_POSITIONS
    for b in range(0, len(stations), per):
        pos, tgt = [], []
        for c in stations[b : b + per]:
            d = np.hypot(*(targets_xy - c[:2]).T)
            near = np.argsort(d)
            t = targets_xy[near[min(int(rng.integers(0, 3)), len(near) - 1)]]
            t = 0.5 * (t + centre)  # between the nearest supports and the middle: overlap
            for lift in (0.0, rng.uniform(1.0, 3.0)):
                pos.append([c[0], c[1], c[2] + lift])
                tgt.append([t[0], t[1], z_floor + 0.5 * plan.z_top])
        blocks.append(
            PhotoViews(
                np.asarray(pos),
                np.asarray(tgt),
                focal_px=2400.0,
                width_px=4000,
                height_px=3000,
                pixel_step=p.photo_pixel_step,
                sigma_m=p.photo_sigma_m,
            )
        )
    return blocks
