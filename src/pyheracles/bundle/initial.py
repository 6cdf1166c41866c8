"""Initial values: spatial resection of images and forward intersection of points."""

from __future__ import annotations

import numpy as np

from pyheracles.bundle.camera import corrected_points, image_residuals, rotation_matrix
from pyheracles.errors import EstimationError, InputError

__all__ = ["angles_from_rotation", "forward_intersection", "spatial_resection"]


def angles_from_rotation(rot: np.ndarray) -> np.ndarray:
    """omega, phi, kappa (radians) of camera-to-world rotations R1(o) R2(p) R3(k)."""
    rot = np.atleast_3d(rot).reshape(-1, 3, 3)
    phi = np.arcsin(np.clip(rot[:, 0, 2], -1.0, 1.0))
    omega = np.arctan2(-rot[:, 1, 2], rot[:, 2, 2])
    kappa = np.arctan2(-rot[:, 0, 1], rot[:, 0, 0])
    return np.column_stack([omega, phi, kappa])


def ideal_rays(uv_mm: np.ndarray, io: np.ndarray, model: int) -> np.ndarray:
    """Camera-frame ray directions [x, y, -c] of measured points (m,3), lens-corrected."""
    corr, _ = corrected_points(uv_mm, io, model)
    return np.column_stack([corr, -io[:, 0]])


def forward_intersection(
    centers: np.ndarray, rotations: np.ndarray, rays_cam: np.ndarray, point: np.ndarray, n: int
) -> np.ndarray:
    """Least-squares intersection of rays (closest point to all rays of a point).

    Parameters
    ----------
    centers, rotations
        (m,3) projection centre and (m,3,3) camera-to-world rotation of each ray.
    rays_cam
        (m,3) ray directions in the camera frame.
    point
        (m,) index of the point each ray belongs to.
    n
        Number of points.

    Returns
    -------
    (n,3) points; NaN where fewer than two non-parallel rays exist.
    """
    d = np.einsum("mij,mj->mi", rotations, rays_cam)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    proj = np.eye(3)[None] - d[:, :, None] * d[:, None, :]  # I - d d^T
    a = np.zeros((n, 3, 3))
    b = np.zeros((n, 3))
    pb = np.einsum("mij,mj->mi", proj, centers)
    for i in range(3):
        b[:, i] = np.bincount(point, weights=pb[:, i], minlength=n)
        for j in range(3):
            a[:, i, j] = np.bincount(point, weights=proj[:, i, j], minlength=n)
    out = np.full((n, 3), np.nan)
    ok = np.abs(np.linalg.det(a)) > 1e-12
    out[ok] = np.linalg.solve(a[ok], b[ok][..., None])[..., 0]
    return out


def _pose_from_homography(h: np.ndarray, q: np.ndarray, obj2: np.ndarray):
    """Rotation M (world->camera, plane frame) and translation from a plane homography."""
    m1, m2, t = h[:, 0], h[:, 1], h[:, 2]
    s = 2.0 / (np.linalg.norm(m1) + np.linalg.norm(m2))
    m1, m2, t = m1 * s, m2 * s, t * s
    # Points must lie in front: camera-frame z negative.
    z = obj2 @ np.array([m1[2], m2[2]]) + t[2]
    if np.median(z) > 0:
        m1, m2, t = -m1, -m2, -t
    m = np.column_stack([m1, m2, np.cross(m1, m2)])
    u, _, vt = np.linalg.svd(m)
    m = u @ vt
    if np.linalg.det(m) < 0:
        m[:, 2] *= -1
    return m, t


def _dlt(rows: np.ndarray) -> np.ndarray:
    _, _, vt = np.linalg.svd(rows)
    return vt[-1]


def _resect_one(xyz: np.ndarray, rays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Camera-to-world rotation and centre from >= 4 points (planar) or >= 6 points."""
    # Normalised image coordinates with the camera looking down -z: h ~ [x/c, y/c, -1].
    q = rays[:, :2] / -rays[:, 2:3]
    centre = xyz.mean(axis=0)
    x0 = xyz - centre
    _, sv, vt = np.linalg.svd(x0, full_matrices=False)
    planar = sv[2] < 1e-3 * sv[0]
    if planar:
        basis = vt.copy()  # rows: plane axes e1, e2, normal (right-handed)
        if np.linalg.det(basis) < 0:
            basis[2] *= -1
        obj2 = x0 @ basis[:2].T
        # Hartley normalisation of the plane coordinates (conditioning of the DLT).
        k = 1.0 / max(np.sqrt(np.mean(np.sum(obj2**2, axis=1))), 1e-12)
        rows = []
        for (x, y), (u, v) in zip(obj2 * k, q, strict=True):
            # h ~ [u, v, -1] = H [x, y, 1]
            rows.append([x, y, 1, 0, 0, 0, u * x, u * y, u])
            rows.append([0, 0, 0, x, y, 1, v * x, v * y, v])
        hv = _dlt(np.asarray(rows, float))
        h = hv.reshape(3, 3) @ np.diag([k, k, 1.0])  # back to unnormalised plane units
        m_plane, t = _pose_from_homography(h, q, obj2)
        # Plane frame -> world: X = centre + basis^T [x, y, z]
        m = m_plane @ basis  # world->camera
    else:
        rows = []
        for (x, y, z), (u, v) in zip(x0, q, strict=True):
            rows.append([x, y, z, 1, 0, 0, 0, 0, u * x, u * y, u * z, u])
            rows.append([0, 0, 0, 0, x, y, z, 1, v * x, v * y, v * z, v])
        p = _dlt(np.asarray(rows, float)).reshape(3, 4)
        a = p[:, :3]
        s = 1.0 / np.cbrt(np.linalg.det(a)) if np.linalg.det(a) != 0 else 1.0
        p = p * s
        z = x0 @ p[2, :3] + p[2, 3]
        if np.median(z) > 0:
            p = -p
        u, _, vt2 = np.linalg.svd(p[:, :3])
        m = u @ vt2
        t = p[:, 3] / np.mean(np.linalg.svd(p[:, :3], compute_uv=False))
    rot = m.T
    c = centre - rot @ t
    return rot, c


def spatial_resection(
    xyz: np.ndarray,
    uv_mm: np.ndarray,
    io: np.ndarray,
    model: int,
    iterations: int = 20,
) -> np.ndarray:
    """Exterior orientation of one image from known object points.

    A homography (coplanar points, >= 4) or a DLT (>= 6 points) gives a first
    pose, refined by Gauss-Newton on the image residuals with the interior
    orientation fixed.

    Parameters
    ----------
    xyz
        (k,3) known object coordinates.
    uv_mm
        (k,2) measurements in mm, y flipped.
    io
        (10,) interior orientation.
    model
        Lens distortion model.

    Returns
    -------
    (6,) X0, Y0, Z0, omega, phi, kappa.
    """
    k = xyz.shape[0]
    if k < 4:
        raise InputError(
            f"spatial resection needs at least 4 known points in the image, got {k}",
            hint="give prior exterior orientations or more control points",
        )
    ioa = np.broadcast_to(io, (k, io.size)).copy()
    rays = ideal_rays(uv_mm, ioa, model)
    rot, c = _resect_one(xyz, rays)
    eo = np.concatenate([c, angles_from_rotation(rot)[0]])

    def cost(e: np.ndarray) -> float:
        r = image_residuals(ioa, np.broadcast_to(e, (k, 6)), xyz, uv_mm, model)
        return float(np.sum(r**2)) if np.all(np.isfinite(r)) else np.inf

    for _ in range(iterations):
        res, (_, d_eo, _) = image_residuals(
            ioa, np.broadcast_to(eo, (k, 6)), xyz, uv_mm, model, jacobian=True
        )
        jac = d_eo.reshape(-1, 6)
        step, *_ = np.linalg.lstsq(jac, -res.ravel(), rcond=None)
        # Damped (halving) steps: never accept an increase of the residual.
        f0, alpha = float(np.sum(res**2)), 1.0
        while alpha > 1e-6 and cost(eo + alpha * step) > f0:
            alpha /= 2
        if alpha <= 1e-6:
            break
        eo = eo + alpha * step
        if np.linalg.norm(alpha * step) < 1e-12 * (1 + np.linalg.norm(eo)):
            break
    if not np.all(np.isfinite(eo)):
        raise EstimationError("spatial resection failed")
    return eo


def centre_rotation(eo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (n,3) and camera-to-world rotations (n,3,3) of EO rows."""
    return eo[:, :3], rotation_matrix(eo[:, 3:6])
