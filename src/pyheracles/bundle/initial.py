"""Initial values: spatial resection of images and forward intersection of points."""

from __future__ import annotations

import numpy as np

from pyheracles.bundle.camera import corrected_points, image_residuals, rotation_matrix
from pyheracles.errors import EstimationError, InputError

__all__ = [
    "angles_from_rotation",
    "essential_pose",
    "forward_intersection",
    "relative_block_orientation",
    "spatial_resection",
]


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


def essential_pose(rays1: np.ndarray, rays2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative pose of two images from corresponding camera-frame rays (8-point method).

    Parameters
    ----------
    rays1, rays2
        (k,3) ray directions (towards the object) in each camera's frame, k >= 8.

    Returns
    -------
    rot_21, t_21
        ``X2 = rot_21 X1 + t_21`` (camera-frame coordinates), ``|t_21| = 1``; the
        candidate of the four decompositions that puts most points in front of both.
    """
    a = rays1 / np.linalg.norm(rays1, axis=1, keepdims=True)
    b = rays2 / np.linalg.norm(rays2, axis=1, keepdims=True)
    rows = np.einsum("ki,kj->kij", b, a).reshape(len(a), 9)  # b^T E a = 0
    _, _, vt = np.linalg.svd(rows)
    e = vt[-1].reshape(3, 3)
    u, _, vt = np.linalg.svd(e)
    if np.linalg.det(u) < 0:
        u = -u
    if np.linalg.det(vt) < 0:
        vt = -vt
    w = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    best, best_n = None, -1
    for rot in (u @ w @ vt, u @ w.T @ vt):
        for t in (u[:, 2], -u[:, 2]):
            # depths l1, l2 with l2 b = rot (l1 a) + t, least squares per point
            ra = a @ rot.T
            m = np.stack([ra, -b], axis=2)  # (k,3,2)
            mtm = np.einsum("kij,kil->kjl", m, m)
            mtb = np.einsum("kij,i->kj", m, -t)
            ok = np.abs(np.linalg.det(mtm)) > 1e-15
            lam = np.zeros((len(a), 2))
            lam[ok] = np.linalg.solve(mtm[ok], mtb[ok][..., None])[..., 0]
            n_front = int(np.sum((lam[:, 0] > 0) & (lam[:, 1] > 0)))
            if n_front > best_n:
                best, best_n = (rot, t / np.linalg.norm(t)), n_front
    return best


def _similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation, translation with dst ~ s R src + t (Umeyama 1991)."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - ms, dst - md
    u, sv, vt = np.linalg.svd(b.T @ a)
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ d @ vt
    s = float(np.sum(sv * np.diag(d)) / np.sum(a**2))
    return s, rot, md - s * rot @ ms


def relative_block_orientation(
    obs_image: np.ndarray,
    obs_point: np.ndarray,
    rays_cam: np.ndarray,
    uv_mm: np.ndarray,
    io_obs: np.ndarray,
    model: int,
    n_images: int,
    n_points: int,
    control_xyz: np.ndarray,
    source: str | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Initial orientations of a block without usable ones, as structure from motion does.

    The image pair sharing the most points (at least 8) is oriented relatively by
    its essential matrix; the points it sees are intersected; then, repeatedly,
    the image seeing most intersected points (at least 6) is resected and new
    points intersected, until every image is oriented.  The block is finally
    moved onto the control points by a similarity transform when at least three
    of them are intersected (else it stays in the frame of the first image, base 1).

    Parameters
    ----------
    obs_image, obs_point, rays_cam, uv_mm, io_obs
        Per observation: image, point, lens-corrected camera-frame ray, the
        measurement (mm) and the interior orientation (m,10).
    control_xyz
        (N,3) known control coordinates, NaN elsewhere.

    Returns
    -------
    eo (n,6), xyz (N,3), info {pair, order, n_control_used, frame}

    Raises
    ------
    DegenerateGeometryError
        No pair with 8 common points, or images that never see 6 oriented points
        (named).
    """
    from pyheracles.errors import DegenerateGeometryError

    inc = np.zeros((n_images, n_points), bool)
    inc[obs_image, obs_point] = True
    common = inc.astype(np.int32) @ inc.T.astype(np.int32)
    np.fill_diagonal(common, 0)
    i0, j0 = np.unravel_index(int(np.argmax(common)), common.shape)
    if common[i0, j0] < 8:
        raise DegenerateGeometryError(
            f"no image pair shares 8 points (best: images {i0 + 1} and {j0 + 1} share "
            f"{int(common[i0, j0])}): the block cannot be oriented relatively",
            path=source,
            hint="measure more tie points between the images or give initial orientations",
        )
    obs_of = {}
    for k, (i, p) in enumerate(zip(obs_image, obs_point, strict=True)):
        obs_of.setdefault((int(i), int(p)), k)
    shared = np.flatnonzero(inc[i0] & inc[j0])
    k1 = np.array([obs_of[(int(i0), int(p))] for p in shared])
    k2 = np.array([obs_of[(int(j0), int(p))] for p in shared])
    rot21, t21 = essential_pose(rays_cam[k1], rays_cam[k2])
    eo = np.full((n_images, 6), np.nan)
    eo[i0] = 0.0
    eo[j0, :3] = -rot21.T @ t21
    eo[j0, 3:] = angles_from_rotation(rot21.T)[0]
    done = np.zeros(n_images, bool)
    done[[i0, j0]] = True
    order = [int(i0), int(j0)]
    xyz = np.full((n_points, 3), np.nan)

    def intersect() -> None:
        sel = done[obs_image]
        n_or = np.bincount(obs_point[sel], minlength=n_points)
        pts = n_or >= 2
        use = sel & pts[obs_point]
        idx = np.cumsum(pts) - 1
        c, r = centre_rotation(eo[obs_image[use]])
        x = forward_intersection(c, r, rays_cam[use], idx[obs_point[use]], int(pts.sum()))
        xyz[pts] = x

    intersect()
    while not done.all():
        known = np.all(np.isfinite(xyz), axis=1)
        seen = (inc & known[None, :]).sum(axis=1)
        seen[done] = -1
        nxt = int(np.argmax(seen))
        if seen[nxt] < 6:
            missing = np.flatnonzero(~done) + 1
            raise DegenerateGeometryError(
                f"image(s) {missing[:10].tolist()} see fewer than 6 points of the oriented block "
                "and cannot be resected (the network is not connected)",
                path=source,
                hint="measure tie points linking these images to the others, or remove them",
            )
        sel = np.flatnonzero((obs_image == nxt) & known[obs_point])
        eo[nxt] = spatial_resection(xyz[obs_point[sel]], uv_mm[sel], io_obs[sel[0]], model)
        done[nxt] = True
        order.append(nxt)
        intersect()
    known = np.all(np.isfinite(xyz), axis=1)
    ctrl = known & np.all(np.isfinite(control_xyz), axis=1)
    info = {"pair": (int(i0), int(j0)), "order": order, "n_control_used": int(ctrl.sum()),
            "frame": "relative"}  # fmt: skip
    if ctrl.sum() >= 3:
        s, rot, t = _similarity(xyz[ctrl], control_xyz[ctrl])
        xyz = s * xyz @ rot.T + t
        eo[:, :3] = s * eo[:, :3] @ rot.T + t
        _, r = centre_rotation(eo)
        eo[:, 3:] = angles_from_rotation(np.einsum("ij,njk->nik", rot, r))
        info["frame"] = "control"
    return eo, xyz, info
