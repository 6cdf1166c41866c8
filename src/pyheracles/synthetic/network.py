"""Synthetic photogrammetric networks with known truth (facade survey geometry).

A wall with relief is photographed from a grid of stations in front of it (a
typical heritage facade block, cf. the St-Paul project of the thesis); object
points are spread over the wall, projected into every image whose frame they
fall in, distorted with a Brown backward camera and perturbed by Gaussian noise.
The result is a :class:`~pyheracles.bundle.project.Project` with perturbed
initial values plus the true parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera, corrected_points, rotation_matrix
from pyheracles.bundle.project import Project

__all__ = ["NetworkParameters", "make_network"]


@dataclass(frozen=True)
class NetworkParameters:
    """Geometry of a synthetic facade network.

    Parameters
    ----------
    n_images
        Number of images (a grid of stations, rows x columns, two tilted views
        per station when ``convergent``).
    n_points
        Number of object points on the wall.
    wall_height_m
        Height of the wall (the width follows from the grid).
    distance_m
        Camera-to-wall distance.
    relief_m
        Amplitude of the wall relief (depth variation helps self-calibration).
    image_size_px, sensor_height_mm
        Image format (width x height pixels; square pixels).
    camera
        True interior orientation (:data:`IO_NAMES` order); None = a 24 mm lens
        on a full-frame sensor with typical radial and decentering distortion.
    noise_px
        Standard deviation of the image measurement noise.
    n_control
        Number of control points (chosen spread over the wall).
    control_std_m
        Standard deviation of the control coordinates (0 = fixed).
    perturb_eo_m, perturb_angle_rad, perturb_xyz_m
        Perturbation of the initial values.
    """

    n_images: int = 60
    n_points: int = 20000
    wall_height_m: float = 12.0
    distance_m: float = 8.0
    relief_m: float = 0.8
    image_size_px: tuple[int, int] = (6000, 4000)
    sensor_height_mm: float = 24.0
    camera: tuple[float, ...] | None = None
    noise_px: float = 0.5
    n_control: int = 8
    control_std_m: float = 0.005
    perturb_eo_m: float = 0.05
    perturb_angle_rad: float = 0.005
    perturb_xyz_m: float = 0.05
    convergent: bool = True


def _wall(x: np.ndarray, z: np.ndarray, relief: float) -> np.ndarray:
    return relief * np.sin(x / 3.0) * np.cos(z / 2.5)


def make_network(
    params: NetworkParameters | None = None, rng: np.random.Generator | int | None = 0
) -> tuple[Project, dict]:
    """Generate a facade network.

    Returns
    -------
    project
        Observations with noise, perturbed initial values, control points.
    truth
        ``io`` (10,), ``eo`` (n,6), ``xyz`` (N,3) true values.
    """
    p = params or NetworkParameters()
    rng = np.random.default_rng(rng)
    iw, ih = p.image_size_px
    pix = p.sensor_height_mm / ih
    sw = pix * iw
    io = np.array(
        p.camera
        if p.camera is not None
        else [
            24.3,
            sw / 2 + 0.05,
            p.sensor_height_mm / 2 - 0.04,
            0,
            0,
            2.2e-4,
            -1.9e-7,
            0,
            1e-5,
            -8e-6,
        ]
    )
    # Stations: rows x cols grid; each station has 1 or 2 (convergent) views.
    views = 2 if p.convergent else 1
    n_st = int(np.ceil(p.n_images / views))
    # Footprint of one image on the wall; 40 % side lap, 30 % strip overlap: each
    # point is seen by about 4-6 images (a typical close-range block).
    foot_w = p.distance_m * sw / io[0]
    foot_h = p.distance_m * p.sensor_height_mm / io[0]
    step_x = 0.6 * foot_w
    step_z = 0.7 * foot_h
    rows = max(1, min(round(float(np.sqrt(n_st / 4.0))), int(p.wall_height_m / step_z) + 1))
    cols = int(np.ceil(n_st / rows))
    width = step_x * (cols - 1) + foot_w
    xs = np.arange(cols) * step_x + foot_w / 2
    zs = np.arange(rows) * step_z + foot_h / 2
    gx, gz = np.meshgrid(xs, zs)
    st = np.column_stack([gx.ravel(), np.full(gx.size, -p.distance_m), gz.ravel()])[:n_st]
    eo = []
    for k, c in enumerate(st):
        for v in range(views):
            yaw = (0.25 if v == 0 else -0.25) if views == 2 else 0.0
            tilt = 0.08 * ((k % 3) - 1)
            ang = np.array([np.pi / 2 + tilt, yaw, 0.02 * ((k % 5) - 2)])
            shift = np.array([(0.3 if v == 0 else -0.3) * step_x * (views == 2), 0.0, 0.0])
            eo.append(np.concatenate([c + shift + rng.normal(0, 0.1, 3), ang]))
    eo = np.asarray(eo)[: p.n_images]
    n = len(eo)
    # Object points on the wall (with relief).
    # Oversample: points seen by fewer than two images are dropped below, and the
    # first n_points of the rest are kept, so the network has exactly n_points.
    n_cand = int(p.n_points * 1.15) + 10
    px_ = rng.uniform(0, width, n_cand)
    pz_ = rng.uniform(0, zs.max() + foot_h / 2, n_cand)
    xyz = np.column_stack([px_, _wall(px_, pz_, p.relief_m), pz_])
    # Project every point into every image (chunked over images).
    rot = rotation_matrix(eo[:, 3:6])
    obs_i, obs_p, obs_uv = [], [], []
    half = np.array([sw, p.sensor_height_mm]) / 2
    order = np.argsort(xyz[:, 0])
    xs_sorted = xyz[order, 0]
    reach = 2.0 * foot_w + p.distance_m
    for i in range(n):
        lo, hi = np.searchsorted(xs_sorted, [eo[i, 0] - reach, eo[i, 0] + reach])
        cand = order[lo:hi]
        xc = (xyz[cand] - eo[i, :3]) @ rot[i]
        front = xc[:, 2] < -0.5
        proj = -io[0] * xc[:, :2] / xc[:, 2:3]
        inside = front & np.all(np.abs(proj - [io[1] - half[0], half[1] - io[2]]) < half * 0.95, 1)
        idx = cand[inside]
        proj = -io[0] * xc[inside, :2] / xc[inside, 2:3]
        order_i = np.argsort(idx)
        idx = idx[order_i]
        proj = proj[order_i]
        obs_i.append(np.full(len(idx), i))
        obs_p.append(idx)
        obs_uv.append(proj)
    obs_image = np.concatenate(obs_i)
    obs_point = np.concatenate(obs_p)
    ideal = np.concatenate(obs_uv)
    # Invert the backward lens model by fixed-point iteration: find m with D(m) = ideal.
    io_m = np.broadcast_to(io, (len(ideal), io.size))
    m = ideal.copy()
    for _ in range(8):
        uv_mm = np.column_stack([m[:, 0] + io[1], m[:, 1] - io[2]])
        corr, _ = corrected_points(uv_mm, io_m, 3)
        m = m - (corr - ideal)
    uv_mm = np.column_stack([m[:, 0] + io[1], m[:, 1] - io[2]])
    uv_px = np.column_stack([uv_mm[:, 0] / pix, -uv_mm[:, 1] / pix])
    uv_px += rng.normal(0, p.noise_px, uv_px.shape)
    rays = np.bincount(obs_point, minlength=n_cand)
    keep_pt = rays >= 2
    keep_pt &= np.cumsum(keep_pt) <= p.n_points
    # Drop points seen once (they carry no information) and re-index.
    new = np.cumsum(keep_pt) - 1
    sel = keep_pt[obs_point]
    obs_image, obs_point, uv_px = obs_image[sel], new[obs_point[sel]], uv_px[sel]
    xyz = xyz[keep_pt]
    npts = len(xyz)
    # Control points: the best-observed points nearest to a spread of targets.
    role = np.full(npts, "tie", dtype=object)
    xyz_std = np.full((npts, 3), np.nan)
    if p.n_control:
        targets = np.column_stack(
            [
                rng.uniform(0.1, 0.9, p.n_control) * width,
                rng.uniform(0.1, 0.9, p.n_control) * (zs.max() + foot_h / 2),
            ]
        )
        rays = np.bincount(obs_point, minlength=npts)
        good = np.flatnonzero(rays >= 3)
        d = np.linalg.norm(xyz[good][:, [0, 2]][None] - targets[:, None], axis=2)
        ctrl = np.unique(good[np.argmin(d, axis=1)])
        role[ctrl] = "control"
        xyz_std[ctrl] = p.control_std_m
    init_xyz = xyz + rng.normal(0, p.perturb_xyz_m, xyz.shape)
    init_xyz[role == "control"] = xyz[role == "control"] + (
        rng.normal(0, p.control_std_m, (int((role == "control").sum()), 3))
        if p.control_std_m > 0
        else 0.0
    )
    init_eo = eo.copy()
    init_eo[:, :3] += rng.normal(0, p.perturb_eo_m, (n, 3))
    init_eo[:, 3:] += rng.normal(0, p.perturb_angle_rad, (n, 3))
    cam = Camera(
        id=1,
        name="synthetic",
        image_size_px=(iw, ih),
        sensor_size_mm=(sw, p.sensor_height_mm),
        cc_mm=float(io[0]),
        pp_mm=(sw / 2, p.sensor_height_mm / 2),
        k=(0.0, 0.0, 0.0),
        p=(0.0, 0.0),
        model=3,
    )
    cam = cam.with_io(np.concatenate([[io[0] * 1.01, sw / 2, p.sensor_height_mm / 2], np.zeros(7)]))
    est = np.zeros((1, len(IO_NAMES)), bool)
    for name in ("cc", "px", "py", "K1", "K2", "P1", "P2"):
        est[0, IO_NAMES.index(name)] = True
    project = Project(
        name="synthetic facade network",
        source="<synthetic>",
        cameras=(cam,),
        image_ids=np.arange(1, n + 1),
        image_names=tuple(f"IMG_{i:04d}.JPG" for i in range(1, n + 1)),
        image_camera=np.zeros(n, int),
        eo=init_eo,
        eo_std=np.full((n, 6), np.nan),
        point_ids=np.arange(1, npts + 1),
        point_labels=tuple(str(i) for i in range(1, npts + 1)),
        xyz=np.where((role == "control")[:, None], init_xyz, np.nan),
        xyz_std=xyz_std,
        point_role=role.astype(str),
        obs_image=obs_image,
        obs_point=obs_point,
        obs_uv_px=uv_px,
        obs_std_px=np.full(uv_px.shape, p.noise_px),
        estimate_io=est,
        estimate_eo=np.ones((n, 6), bool),
        datum="control",
        meta={"format": "synthetic"},
    )
    return project, {"io": io, "eo": eo, "xyz": xyz, "initial_xyz": init_xyz}
