"""The scan simulator: what a laser scanner, a camera network or an aircraft sees of a scene.

One simulator serves every generated scene (demo, tests, sweeps, training
data).  It casts rays into a :class:`~pyheracles.synthetic.scene.Scene` with
Embree and turns the hits into points the way real instruments do:

* :class:`TLSStation` - a terrestrial laser scanner: a spherical angular grid
  (spacing ``r * step`` on a surface facing the station), nearest-hit
  visibility (shadows behind columns, beams, furniture), detection falling
  with range, incidence and reflectance, no return below a grazing limit,
  range noise growing with range, mixed pixels at depth edges, intensity, a
  blind cone under the tripod.  Glass gives weak returns and mostly lets the
  beam through.
* :class:`PhotoViews` - photogrammetry / UAV dense matching: a point exists
  where at least two views see a surface, taken from the best view, sparser
  at grazing angles, noise 5-15 mm growing with depth.
* :class:`AirborneSurvey` - airborne LiDAR: parallel overlapping strips, a
  zig-zag scanner, several returns per pulse through foliage
  (``return_number`` / ``number_of_returns``).
* :class:`Outliers` - isolated points above and below the floor, small
  clusters, and reflections behind glass, as a set share of the points.

Points come in acquisition order (station by station, scan line by scan
line), never sorted by label.  Every point carries its reference
(``instance``, ``class_id``, ``part``, ``outlier``).

Why Embree through ``embreex`` and not Open3D's ``RaycastingScene``: both are
the same engine, but Open3D is a 0.9 GB wheel that also needs ``libusb``
from the system, which would break the one-command install of the demo on a
fresh machine; ``embreex`` ships Embree 4 in a 45 MB wheel that needs only
numpy.  ``tests/test_scanner.py`` checks the two give the same hits when
Open3D is installed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError
from pyheracles.synthetic.ray_noise import acquisition_key, ray_ids, ray_normal, ray_uniform
from pyheracles.synthetic.raycaster import RayCaster
from pyheracles.synthetic.scene import Scene
from pyheracles.synthetic.surveys import (
    Acquisition,
    AirborneSurvey,
    Outliers,
    PhotoViews,
    SurfaceSampling,
    TLSStation,
)

__all__ = [
    "AirborneSurvey",
    "Outliers",
    "PhotoViews",
    "RayCaster",
    "ScanResult",
    "SurfaceSampling",
    "TLSStation",
    "acquisition_key",
    "ray_ids",
    "ray_normal",
    "ray_uniform",
    "scan",
]

Array = NDArray[np.float64]

#: Part names given to simulated artefacts (their points have ``outlier`` True).
ARTEFACT_PARTS = ("mixed_pixel", "outlier_isolated", "outlier_cluster", "reflection")


# ---------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ScanResult:
    """Points of one or several acquisitions, in acquisition order, with their reference.

    Attributes
    ----------
    xyz
        ``(N, 3)`` coordinates, metres, in the scene frame.
    intensity, point_source_id, return_number, number_of_returns, scan_angle_deg,
    gps_time, scan_direction_flag, edge_of_flight_line
        Per-point scanner attributes as in LAS (``point_source_id`` = station
        or strip index, from 1).
    instance, class_id, part, outlier
        Reference per point: object id (0 = none), class and part codes of
        the scene, and True for simulated gross errors and mixed pixels.
    acquisitions
        One dict per acquisition: kind, parameters, number of points.
    """

    xyz: Array
    intensity: NDArray[np.uint16]
    point_source_id: NDArray[np.uint16]
    return_number: NDArray[np.uint8]
    number_of_returns: NDArray[np.uint8]
    scan_angle_deg: NDArray[np.float32]
    gps_time: Array
    scan_direction_flag: NDArray[np.uint8]
    edge_of_flight_line: NDArray[np.uint8]
    instance: NDArray[np.int32]
    class_id: NDArray[np.int32]
    part: NDArray[np.int32]
    outlier: NDArray[np.bool_]
    acquisitions: list[dict[str, Any]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.xyz)

    def subset(self, mask: NDArray[np.bool_]) -> ScanResult:
        """The points where ``mask`` is True, in the same order."""
        kw = {k: getattr(self, k)[mask] for k in _POINT_FIELDS}
        return ScanResult(**kw, acquisitions=self.acquisitions)


_POINT_FIELDS = (
    "xyz",
    "intensity",
    "point_source_id",
    "return_number",
    "number_of_returns",
    "scan_angle_deg",
    "gps_time",
    "scan_direction_flag",
    "edge_of_flight_line",
    "instance",
    "class_id",
    "part",
    "outlier",
)


# ---------------------------------------------------------------------------
# acquisitions -> points
# ---------------------------------------------------------------------------
# the draws of one ray (streams of ray_uniform)
_DETECT_STREAM, _NOISE_STREAM, _GLASS_STREAM, _MIXED_STREAM = 0, 1, 2, 10
_MATCH_STREAM, _PHOTO_NOISE_STREAM = 20, 21


def _tls(caster: RayCaster, st: TLSStation, rng: np.random.Generator) -> dict[str, Any]:
    st.validate()
    key = acquisition_key(rng)  # every later draw is the ray's own (see ray_uniform)
    step = np.deg2rad(st.step_deg)
    az = np.arange(np.deg2rad(st.azimuth_deg[0]), np.deg2rad(st.azimuth_deg[1]) - 1e-12, step)
    el = np.arange(np.deg2rad(st.elevation_deg[0]), np.deg2rad(st.elevation_deg[1]) + 1e-12, step)
    origin = np.asarray(st.position, float)
    na, ne = len(az), len(el)
    ca, sa = np.cos(az).astype(np.float32), np.sin(az).astype(np.float32)
    ce, se = np.cos(el).astype(np.float32), np.sin(el).astype(np.float32)
    # acquisition order: the head turns in azimuth; each column is one vertical profile.
    # Rays are cast in blocks of columns; only the hits are kept as full arrays.
    R = np.full((na, ne), np.inf, np.float32)
    P = np.full((na, ne), -1, np.int32)
    cols = max(1, 2_000_000 // ne)
    o32 = np.broadcast_to(origin.astype(np.float32), (cols * ne, 3))
    for a0 in range(0, na, cols):
        a1 = min(a0 + cols, na)
        d = np.empty((a1 - a0, ne, 3), np.float32)
        d[..., 0] = ca[a0:a1, None] * ce[None, :]
        d[..., 1] = sa[a0:a1, None] * ce[None, :]
        d[..., 2] = se[None, :]
        d = d.reshape(-1, 3)
        res = caster._embree.run(np.ascontiguousarray(o32[: len(d)]), d, output=1)
        hit = res["geomID"] != -1
        R[a0:a1] = np.where(hit, res["tfar"], np.inf).reshape(a1 - a0, ne)
        P[a0:a1] = np.where(hit, res["primID"], -1).reshape(a1 - a0, ne)
    flat = np.flatnonzero(P.ravel() >= 0)
    ia, ie = np.divmod(flat, ne)
    d = np.column_stack([ca[ia] * ce[ie], sa[ia] * ce[ie], se[ie]]).astype(float)
    prim = P.ravel()[flat].astype(np.int64)
    r = R.ravel()[flat].astype(float)
    # glass: most beams pass through and return from what lies behind
    through = np.zeros(len(flat), bool)
    # only the beams that passed the previous glass face are tested at the next one: a
    # beam that did not pass returns from that face (it is not re-drawn)
    active = np.ones(len(flat), bool)
    rays = ray_ids(ia, ie)
    for layer in range(4):
        tr = caster.transmittance[prim]
        on_glass = np.flatnonzero(active & (tr > 0))  # only these beams draw a number
        u = ray_uniform(key, rays[on_glass], _GLASS_STREAM + layer)
        go = on_glass[u < tr[on_glass]]
        active = np.zeros(len(prim), bool)
        active[go] = True
        if len(go) == 0:
            break
        o2 = origin + (r[go] + 1e-4)[:, None] * d[go]
        t2, p2 = caster.cast(o2, d[go])
        r[go] = r[go] + 1e-4 + t2
        prim[go] = p2
        through[go] = True
        sel = prim >= 0  # beams that went through and met nothing are lost
        Rf, Pf = R.reshape(-1), P.reshape(-1)
        Rf[flat[~sel]] = np.inf
        Pf[flat[~sel]] = -1
        flat, ia, ie, d, prim, r, through, active, rays = (
            x[sel] for x in (flat, ia, ie, d, prim, r, through, active, rays)
        )
        Rf[flat] = r
        Pf[flat] = prim
    cosi = np.abs(np.einsum("ij,ij->i", caster.normals[prim], d))
    ok = (r >= st.range_m[0]) & (r <= st.range_m[1])
    ok &= cosi >= np.sin(np.deg2rad(st.grazing_limit_deg))
    signal = caster.reflectance[prim] * cosi * (10.0 / np.maximum(r, 0.1)) ** 2
    ok &= ray_uniform(key, rays, _DETECT_STREAM) < 1 - np.exp(-signal / st.detection)
    # mixed pixels: a beam at a depth edge between two different surfaces of the grid;
    # only the few candidate edges (a range jump or sky beside) are examined further
    mixed = np.zeros(len(flat), bool)
    r_mix = r.copy()
    Rf, Pf = R.reshape(-1), P.reshape(-1)
    for side, (nb_flat, valid) in enumerate(
        (
            (flat + ne, ia + 1 < na),  # next column (azimuth)
            (flat + 1, ie + 1 < ne),  # next row (elevation)
        )
    ):
        cand = np.flatnonzero(valid & ~mixed)
        nbf = nb_flat[cand]
        pn = Pf[nbf]
        rn = Rf[nbf].astype(float)
        sky = pn < 0
        jump = sky | (np.abs(rn - r[cand]) > st.edge_jump_m)
        cand, pn, rn, sky = cand[jump], pn[jump], rn[jump], sky[jump]
        other = ~sky & (pn != prim[cand])
        other[other] &= (
            np.einsum("ij,ij->i", caster.normals[pn[other]], caster.normals[prim[cand[other]]])
            < 0.95
        )
        stream = _MIXED_STREAM + 3 * side
        u = ray_uniform(key, rays[cand], stream)
        keep = (sky | other) & (u < st.mixed_pixel_share / 2)
        cand, rn, sky = cand[keep], rn[keep], sky[keep]
        beyond = 0.2 + 1.8 * ray_uniform(key, rays[cand], stream + 1)
        far = np.where(sky, r[cand] + beyond, rn)
        r_mix[cand] = r[cand] + ray_uniform(key, rays[cand], stream + 2) * (far - r[cand])
        mixed[cand] = True
    mixed &= ok
    idx = np.flatnonzero(ok)
    r_out = r_mix[idx]
    glass = caster.transmittance[prim[idx]] > 0
    sigma = st.noise_m + st.noise_per_m * r_out
    sigma = np.where(glass, sigma * 3, sigma)  # weak returns are noisier
    r_out = r_out + ray_normal(key, rays[idx], _NOISE_STREAM) * sigma
    dd = d[idx]
    xyz = origin + r_out[:, None] * dd
    inten = np.clip(np.sqrt(signal[idx]) * 20000, 1, 65535).astype(np.uint16)
    return {
        "xyz": xyz,
        "prim": prim[idx],
        "mixed": mixed[idx],
        "intensity": inten,
        "scan_angle_deg": np.rad2deg(el[ie[idx]]).astype(np.float32),
        "gps_time": flat[idx] * 1e-6,
        "glass": glass | through[idx],
        "dirs": dd,
        "ranges": r[idx],
        "n_rays": na * ne,
    }


def _look_at(position: Array, target: Array) -> Array:
    """Rows: camera x (right), y (down), z (forward) in world coordinates."""
    z = target - position
    z /= np.linalg.norm(z)
    up = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.vstack([x, y, z])


def _photo(caster: RayCaster, pv: PhotoViews, rng: np.random.Generator) -> dict[str, Any]:
    pv.validate()
    C = np.asarray(pv.positions, float).reshape(-1, 3)
    T = np.asarray(pv.targets, float).reshape(-1, 3)
    Rs = [_look_at(c, t) for c, t in zip(C, T, strict=True)]
    u = np.arange(pv.pixel_step / 2, pv.width_px, pv.pixel_step)
    v = np.arange(pv.pixel_step / 2, pv.height_px, pv.pixel_step)
    U, V = np.meshgrid(u, v)
    cam_dirs = np.column_stack(
        [
            (U.ravel() - pv.width_px / 2) / pv.focal_px,
            (V.ravel() - pv.height_px / 2) / pv.focal_px,
            np.ones(U.size),
        ]
    )
    cam_dirs /= np.linalg.norm(cam_dirs, axis=1, keepdims=True)
    cos_max = np.cos(np.deg2rad(pv.max_incidence_deg))
    out_xyz, out_prim, out_view, out_int = [], [], [], []
    key = acquisition_key(rng)  # every later draw is the pixel's own (see ray_uniform)
    for ci, (c, R) in enumerate(zip(C, Rs, strict=True)):
        d = cam_dirs @ R
        t, prim = caster.cast(c, d)
        hit = (prim >= 0) & np.isfinite(t)
        hit &= caster.matchable[np.maximum(prim, 0)]
        idx = np.flatnonzero(hit)
        if len(idx) == 0:
            continue
        p = prim[idx]
        X = c + t[idx, None] * d[idx]
        n = caster.normals[p]
        cos_c = np.abs(np.einsum("ij,ij->i", n, d[idx]))
        score_c = t[idx] / np.maximum(cos_c, 1e-3)
        ok = cos_c >= cos_max
        seen = ok.astype(int)
        best = ok.copy()
        for ck, (c2, R2) in enumerate(zip(C, Rs, strict=True)):
            if ck == ci:
                continue
            rel = X - c2
            z = rel @ R2[2]
            dist = np.linalg.norm(rel, axis=1)
            uu = (rel @ R2[0]) / np.maximum(z, 1e-9) * pv.focal_px + pv.width_px / 2
            vv = (rel @ R2[1]) / np.maximum(z, 1e-9) * pv.focal_px + pv.height_px / 2
            inside = (z > 0) & (uu >= 0) & (uu < pv.width_px) & (vv >= 0) & (vv < pv.height_px)
            dirk = rel / np.maximum(dist, 1e-9)[:, None]
            cos_k = np.abs(np.einsum("ij,ij->i", n, dirk))
            cand = np.flatnonzero(ok & inside & (cos_k >= cos_max))
            if len(cand) == 0:
                continue
            tk, _ = caster.cast(c2, dirk[cand])
            vis = tk >= dist[cand] - np.maximum(0.002 * dist[cand], 0.005)
            vc = cand[vis]
            seen[vc] += 1
            # the point is taken from the best view only (no duplicates)
            better = dist[vc] / np.maximum(cos_k[vc], 1e-3) < score_c[vc]
            best[vc[better]] = False
        keep = best & (seen >= pv.min_views)
        # sparser on faces seen at grazing angles: matching fails more often there
        pixels = ray_ids(np.full(len(idx), ci), idx)
        keep &= ray_uniform(key, pixels, _MATCH_STREAM) < np.clip(cos_c / 0.5, 0.0, 1.0)
        k = np.flatnonzero(keep)
        sig = np.clip(pv.sigma_m * t[idx[k]] / pv.reference_range_m, *pv.sigma_clip_m)
        # mostly along the viewing ray (depth), a third of it across
        depth, *across = (ray_normal(key, pixels[k], _PHOTO_NOISE_STREAM + j) for j in range(4))
        noise = (d[idx[k]] * depth[:, None] + np.column_stack(across) / 3) * sig[:, None]
        out_xyz.append(X[k] + noise)
        out_prim.append(p[k])
        out_view.append(np.full(len(k), ci))
        out_int.append(np.clip(caster.reflectance[p[k]] * 65535, 1, 65535).astype(np.uint16))
    if not out_xyz:
        out_xyz, out_prim, out_view, out_int = (
            [np.empty((0, 3))],
            [np.empty(0, int)],
            [np.empty(0, int)],
            [np.empty(0, np.uint16)],
        )
    xyz = np.concatenate(out_xyz)
    return {
        "xyz": xyz,
        "prim": np.concatenate(out_prim),
        "mixed": np.zeros(len(xyz), bool),
        "intensity": np.concatenate(out_int),
        "scan_angle_deg": np.zeros(len(xyz), np.float32),
        "gps_time": np.concatenate(out_view).astype(float),
        "glass": np.zeros(len(xyz), bool),
        "n_rays": len(C) * len(cam_dirs),
    }


def _airborne(
    caster: RayCaster, sv: AirborneSurvey, rng: np.random.Generator
) -> list[dict[str, Any]]:
    sv.validate()
    x0, y0, x1, y1 = sv.bounds
    h = np.deg2rad(sv.heading_deg)
    along = np.array([np.cos(h), np.sin(h)])
    across = np.array([-np.sin(h), np.cos(h)])
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    a_rng = corners @ along
    c_rng = corners @ across
    swath = 2 * sv.altitude_m * np.tan(np.deg2rad(sv.half_fov_deg))
    spacing = swath * (1 - sv.overlap)
    n_strips = max(1, int(np.ceil((c_rng.max() - c_rng.min() + swath * 0.2) / spacing)))
    c0 = (c_rng.min() + c_rng.max()) / 2 - (n_strips - 1) * spacing / 2
    length = a_rng.max() - a_rng.min() + swath * 0.2
    pulses_per_line = max(4, int(sv.density_per_m2 * swath * sv.speed_mps / sv.scan_rate_hz))
    n_lines = max(2, int(length / sv.speed_mps * sv.scan_rate_hz))
    out = []
    for s in range(n_strips):
        line = np.repeat(np.arange(n_lines), pulses_per_line)
        k = np.tile(np.arange(pulses_per_line), n_lines)
        # the mirror's phase drifts from line to line: without it every line would fire at
        # the same across-track angles and a flight parallel to a wall could miss its face
        phase = rng.uniform(0.0, 1.0, n_lines)[line]
        frac = np.clip((k + phase) / pulses_per_line, 0.0, 1.0)
        forward = line % 2 == 0
        theta = np.deg2rad(sv.half_fov_deg) * np.where(forward, 2 * frac - 1, 1 - 2 * frac)
        t_time = (line + frac) / sv.scan_rate_hz
        pos2 = (a_rng.min() - swath * 0.1 + t_time * sv.speed_mps)[:, None] * along + (
            c0 + s * spacing
        ) * across
        o = np.column_stack([pos2, np.full(len(pos2), sv.altitude_m)])
        d = np.column_stack([np.sin(theta)[:, None] * across, -np.cos(theta)])
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        inside = pos2[:, 0] + d[:, 0] / -d[:, 2] * sv.altitude_m >= x0 - 1
        inside &= pos2[:, 0] + d[:, 0] / -d[:, 2] * sv.altitude_m <= x1 + 1
        inside &= pos2[:, 1] + d[:, 1] / -d[:, 2] * sv.altitude_m >= y0 - 1
        inside &= pos2[:, 1] + d[:, 1] / -d[:, 2] * sv.altitude_m <= y1 + 1
        idx_p = np.flatnonzero(inside)
        o, d, theta, t_time = o[idx_p], d[idx_p], theta[idx_p], t_time[idx_p]
        edge = (
            np.abs(np.abs(theta) - np.deg2rad(sv.half_fov_deg))
            < np.deg2rad(sv.half_fov_deg) / pulses_per_line * 1.5
        )
        direction = forward[idx_p]
        pts, prims, pulse, ret = [], [], [], []
        active = np.arange(len(d))
        org = o.copy()
        travelled = np.zeros(len(d))
        for r_no in range(1, sv.max_returns + 1):
            if len(active) == 0:
                break
            t, prim = caster.cast(org[active], d[active])
            hit = prim >= 0
            a = active[hit]
            p = prim[hit]
            th = t[hit]
            cosi = np.abs(np.einsum("ij,ij->i", caster.normals[p], d[a]))
            signal = caster.reflectance[p] * np.maximum(cosi, 0.05)
            detected = rng.random(len(a)) < 1 - np.exp(-signal / 0.01)
            rng_tot = travelled[a] + th
            pts.append(o[a[detected]] + rng_tot[detected, None] * d[a[detected]])
            prims.append(p[detected])
            pulse.append(a[detected])
            ret.append(np.full(detected.sum(), r_no))
            # foliage lets the rest of the pulse through; a solid surface stops it, whether
            # its echo was strong enough to be recorded or not
            go = caster.porous[p]
            nxt = a[go]
            travelled[nxt] = (
                travelled[nxt]
                + th[go]
                + np.where(caster.porous[p[go]] & detected[go], sv.min_separation_m, 1e-3)
            )
            org[nxt] = o[nxt] + travelled[nxt, None] * d[nxt]
            active = nxt
        xyz = np.concatenate(pts) if pts else np.empty((0, 3))
        pulse_i = np.concatenate(pulse) if pulse else np.empty(0, int)
        ret_i = np.concatenate(ret) if ret else np.empty(0, int)
        prim_i = np.concatenate(prims) if prims else np.empty(0, int)
        order = np.lexsort((ret_i, pulse_i))  # acquisition order: pulse by pulse
        xyz, pulse_i, ret_i, prim_i = xyz[order], pulse_i[order], ret_i[order], prim_i[order]
        # renumber the returns that were detected, and count them per pulse
        first = np.r_[True, pulse_i[1:] != pulse_i[:-1]]
        grp = np.cumsum(first) - 1
        start = np.flatnonzero(first)
        rn = np.arange(len(pulse_i)) - start[grp] + 1
        nr = np.diff(np.r_[start, len(pulse_i)])[grp]
        xyz = xyz + d[pulse_i] * rng.normal(0, sv.noise_m, len(xyz))[:, None]
        inten = np.clip(caster.reflectance[prim_i] * 40000 / nr, 1, 65535).astype(np.uint16)
        out.append(
            {
                "xyz": xyz,
                "prim": prim_i,
                "mixed": np.zeros(len(xyz), bool),
                "intensity": inten,
                "scan_angle_deg": np.rad2deg(theta[pulse_i]).astype(np.float32),
                "gps_time": t_time[pulse_i] + s * 1000.0,
                "return_number": rn.astype(np.uint8),
                "number_of_returns": nr.astype(np.uint8),
                "scan_direction_flag": direction[pulse_i].astype(np.uint8),
                "edge_of_flight_line": edge[pulse_i].astype(np.uint8),
                "glass": np.zeros(len(xyz), bool),
                "n_rays": len(d),
            }
        )
    return out


def _sampling(caster: RayCaster, ss: SurfaceSampling, rng: np.random.Generator) -> dict[str, Any]:
    ss.validate()
    tris = caster.scene.triangles
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    if ss.parts is not None:
        codes = [caster.scene.part_code(p) for p in ss.parts]
        area = np.where(np.isin(caster.part, codes), area, 0.0)
    n = rng.poisson(area / ss.spacing_m**2)
    prim = np.repeat(np.arange(len(tris)), n)
    u, v = rng.random(len(prim)), rng.random(len(prim))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tris[prim]
    xyz = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    xyz += rng.normal(0, ss.noise_m, xyz.shape)
    order = rng.permutation(len(xyz))  # a merged union has no label order
    return {
        "xyz": xyz[order],
        "prim": prim[order],
        "mixed": np.zeros(len(xyz), bool),
        "intensity": np.clip(caster.reflectance[prim[order]] * 65535, 1, 65535).astype(np.uint16),
        "scan_angle_deg": np.zeros(len(xyz), np.float32),
        "gps_time": np.zeros(len(xyz)),
        "glass": np.zeros(len(xyz), bool),
        "n_rays": 0,
    }


def _outliers(
    block: dict[str, Any],
    spec: Outliers,
    lo: Array,
    hi: Array,
    rng: np.random.Generator,
    codes: dict[str, int],
) -> dict[str, Any]:
    """Points to add to one acquisition block so that they are ``spec.share`` of it."""
    n_good = len(block["xyz"])
    n = round(spec.share * n_good / (1 - spec.share))
    w = np.array([spec.isolated, spec.clusters, spec.reflections], float)
    if n == 0 or w.sum() == 0:
        return {"xyz": np.empty((0, 3)), "part": np.empty(0, int)}
    glass_idx = np.flatnonzero(block.get("glass", np.zeros(n_good, bool)))
    if len(glass_idx) == 0 or "dirs" not in block:
        w[0] += w[2]
        w[2] = 0
    n_kind = np.floor(n * w / w.sum()).astype(int)
    n_kind[0] += n - n_kind.sum()
    parts = []
    span = hi - lo
    # isolated: half in the air over the scene, half under real surface points (multipath)
    k = n_kind[0]
    iso = lo + rng.random((k, 3)) * span
    below = rng.random(k) < 0.5
    nb = int(below.sum())
    if nb and n_good:
        under = block["xyz"][rng.integers(0, n_good, nb)]
        iso[below] = under - np.outer(rng.uniform(0.2, spec.below_m, nb), [0.0, 0.0, 1.0])
    iso[~below, 2] = lo[2] + rng.uniform(0, span[2] + 2.0, (~below).sum())
    parts.append((iso, codes["outlier_isolated"]))
    # clusters
    k = n_kind[1]
    cl = []
    while k > 0:
        m = min(k, int(rng.integers(spec.cluster_size[0], spec.cluster_size[1] + 1)))
        c = lo + rng.random(3) * span
        c[2] = lo[2] + rng.uniform(0.3, span[2] + 1.0)
        cl.append(c + rng.normal(0, rng.uniform(0.02, 0.08), (m, 3)))
        k -= m
    parts.append((np.concatenate(cl) if cl else np.empty((0, 3)), codes["outlier_cluster"]))
    # reflections: virtual points behind the glass along the beam
    k = n_kind[2]
    if k:
        g = rng.choice(glass_idx, k)
        behind = block["ranges"][g] + rng.uniform(0.5, 4.0, k)
        xyz = block["origin"] + behind[:, None] * block["dirs"][g]
        parts.append((xyz, codes["reflection"]))
    xyz = np.concatenate([p[0] for p in parts])
    part = np.concatenate([np.full(len(p[0]), p[1]) for p in parts])
    return {"xyz": xyz, "part": part}


def scan(
    scene: Scene,
    acquisitions: Acquisition | Sequence[Acquisition],
    *,
    outliers: Outliers | None = None,
    rng: np.random.Generator | int | None = 0,
) -> ScanResult:
    """Scan a scene with one or several acquisitions (a registered union).

    Parameters
    ----------
    scene
        Labelled surfaces.
    acquisitions
        TLS stations, photogrammetric blocks and airborne surveys; each gets
        its own ``point_source_id`` (airborne: one per strip), from 1.
    outliers
        Gross errors to add (none by default).
    rng
        Seed or generator (deterministic for a given seed).

    Returns
    -------
    ScanResult
        Points in acquisition order with their reference.

    Examples
    --------
    >>> from pyheracles.synthetic.scene import Scene
    >>> s = Scene()
    >>> s.add_box([0, 0, -0.05], [20, 20, 0.1], instance=0, class_name="floor")
    >>> res = scan(s, TLSStation((0, 0, 1.5), step_deg=1.0), rng=0)
    >>> bool((abs(res.xyz[~res.outlier, 2]) < 0.06).all())  # mixed pixels are outliers
    True
    """
    gen = np.random.default_rng(rng)
    single = TLSStation | PhotoViews | AirborneSurvey | SurfaceSampling
    acqs = [acquisitions] if isinstance(acquisitions, single) else list(acquisitions)
    if not acqs:
        raise InputError("no acquisition given: add at least one station, view set or survey")
    if outliers is not None:
        outliers.validate()
    caster = RayCaster(scene)
    codes = {name: scene.part_code(name) for name in ARTEFACT_PARTS}
    blocks: list[dict[str, Any]] = []
    meta: list[dict[str, Any]] = []
    for acq in acqs:
        if isinstance(acq, TLSStation):
            b = _tls(caster, acq, gen)
            b["origin"] = np.asarray(acq.position, float)
            got = [b]
        elif isinstance(acq, PhotoViews):
            got = [_photo(caster, acq, gen)]
        elif isinstance(acq, AirborneSurvey):
            got = _airborne(caster, acq, gen)
        elif isinstance(acq, SurfaceSampling):
            got = [_sampling(caster, acq, gen)]
        else:
            raise InputError(f"unknown acquisition {type(acq).__name__}")
        for b in got:
            b["kind"] = type(acq).__name__
            blocks.append(b)
        meta.append(
            {
                "kind": type(acq).__name__,
                "params": _jsonable(acq.__dict__),
                "sources": len(got),
                "points": int(sum(len(b["xyz"]) for b in got)),
            }
        )
    lo, hi = caster.lo, caster.hi
    cols: dict[str, list[Any]] = {k: [] for k in _POINT_FIELDS}
    for sid, b in enumerate(blocks, start=1):
        n = len(b["xyz"])
        prim = b["prim"]
        mixed = b["mixed"]
        inst = np.where(mixed, 0, caster.instance[prim]).astype(np.int32)
        cls = np.where(mixed, 0, caster.class_id[prim]).astype(np.int32)
        part = np.where(mixed, codes["mixed_pixel"], caster.part[prim]).astype(np.int32)
        rec = {
            "xyz": b["xyz"],
            "intensity": b["intensity"],
            "point_source_id": np.full(n, sid, np.uint16),
            "return_number": b.get("return_number", np.ones(n, np.uint8)),
            "number_of_returns": b.get("number_of_returns", np.ones(n, np.uint8)),
            "scan_angle_deg": b["scan_angle_deg"],
            "gps_time": b["gps_time"],
            "scan_direction_flag": b.get("scan_direction_flag", np.zeros(n, np.uint8)),
            "edge_of_flight_line": b.get("edge_of_flight_line", np.zeros(n, np.uint8)),
            "instance": inst,
            "class_id": cls,
            "part": part,
            "outlier": mixed.copy(),
        }
        if outliers is not None and outliers.share > 0 and n:
            extra = _outliers(b, outliers, lo, hi, gen, codes)
            m = len(extra["xyz"])
            if m:
                # outliers arrive during the acquisition: spread through its stream
                pos = np.sort(gen.integers(0, n + 1, m))
                ins = {
                    "xyz": extra["xyz"],
                    "intensity": np.full(m, 200, np.uint16),
                    "point_source_id": np.full(m, sid, np.uint16),
                    "return_number": np.ones(m, np.uint8),
                    "number_of_returns": np.ones(m, np.uint8),
                    "scan_angle_deg": np.zeros(m, np.float32),
                    "gps_time": b["gps_time"][np.minimum(pos, n - 1)],
                    "scan_direction_flag": np.zeros(m, np.uint8),
                    "edge_of_flight_line": np.zeros(m, np.uint8),
                    "instance": np.zeros(m, np.int32),
                    "class_id": np.zeros(m, np.int32),
                    "part": extra["part"].astype(np.int32),
                    "outlier": np.ones(m, bool),
                }
                rec = {k: np.insert(rec[k], pos, ins[k], axis=0) for k in _POINT_FIELDS}
        for k in _POINT_FIELDS:
            cols[k].append(rec[k])
    out = {k: np.concatenate(v) if v else np.empty(0) for k, v in cols.items()}
    out["xyz"] = out["xyz"].reshape(-1, 3).astype(float)
    return ScanResult(**out, acquisitions=meta)


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in d.items():
        if isinstance(v, np.ndarray):
            out[k] = v.tolist()
        elif isinstance(v, tuple):
            out[k] = [x.tolist() if isinstance(x, np.ndarray) else x for x in v]
        else:
            out[k] = v
    return out
