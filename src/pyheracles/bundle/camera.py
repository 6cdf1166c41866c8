"""Camera models of the bundle adjustment: Brown backward (photogrammetric) lens models.

Conventions (those of PhotoModeler and DBAT, so results compare line by line):

* camera unit mm, object unit m, angles in radians internally;
* image measurements in pixels, origin at the upper-left corner, y down;
* the principal point ``(px, py)`` is measured in mm from the upper-left corner
  (x right, y down), so the "ideal" image coordinates with y up are
  ``x = u*s - px`` and ``y = py - v*s`` (``s`` = pixel size in mm);
* orientation: camera-to-world rotation ``R = R1(omega) R2(phi) R3(kappa)``
  (rotations in a moving frame), the camera looks along its -z axis, so a point
  projects to ``-c * (X_c / Z_c, Y_c / Z_c)`` with ``X_c = R^T (X - X_0)``;
* backward lens model (Brown 1971): the *measured* point, corrected by the
  distortion, equals the projected point:
  ``D(a) = a (1 + K1 r^2 + K2 r^4 + K3 r^6) + T(a)`` with the decentering term
  ``T_x = P1 (r^2 + 2 a_x^2) + 2 P2 a_x a_y``, ``T_y = P2 (r^2 + 2 a_y^2) + 2 P1 a_x a_y``.

Lens distortion models (DBAT numbering):

1, 2: no affinity (``as``, ``sk`` must stay 0);
3: affinity ``[[1+as, sk], [0, 1]]`` before the distortion (DBAT's default);
4: affinity after the distortion;
5: anisotropic scale ``1+as`` of the raw x coordinate, skew after the distortion;
-1: forward (computer vision) model: the *projected* point p is distorted and
compared with the measured one, ``p - p (K1 r^2 + ...) - T(p) = measured``
(DBAT's sign convention of the forward model), no affinity.

References
----------
Brown, D. C. (1971). Close-range camera calibration. PE 37(8): 855-866.
Börlin, N., Grussenmeyer, P. (2013). Bundle adjustment with and without damping.
The Photogrammetric Record 28(144): 396-415.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "IO_NAMES",
    "Camera",
    "image_residuals",
    "rotation_matrix",
]

#: Order of the interior orientation parameters of one camera.
IO_NAMES: tuple[str, ...] = ("cc", "px", "py", "as", "sk", "K1", "K2", "K3", "P1", "P2")
_IO = {name: i for i, name in enumerate(IO_NAMES)}
BACKWARD_MODELS = (1, 2, 3, 4, 5)
#: DBAT's forward (computer vision) model -1: the projected point is distorted.
FORWARD_MODEL = -1
MODELS = (*BACKWARD_MODELS, FORWARD_MODEL)


@dataclass(frozen=True)
class Camera:
    """One physical camera (interior orientation), PhotoModeler/DBAT conventions.

    Parameters
    ----------
    id
        Camera id in the project.
    name
        Free text.
    image_size_px
        Image width and height in pixels.
    sensor_size_mm
        Sensor (format) width and height in mm.
    cc_mm
        Camera constant (principal distance) in mm.
    pp_mm
        Principal point (x right, y down) from the upper-left corner, mm.
    aspect_diff
        Off-unit aspect parameter ``as`` (1 - aspect ratio), unitless.
    skew
        Skew parameter ``sk``, unitless.
    k
        Radial distortion K1 (mm^-2), K2 (mm^-4), K3 (mm^-6).
    p
        Decentering distortion P1, P2 (mm^-1).
    model
        Lens distortion model (see module docstring); 3 is DBAT's default.
    """

    id: int = 1
    name: str = ""
    image_size_px: tuple[int, int] = (0, 0)
    sensor_size_mm: tuple[float, float] = (0.0, 0.0)
    cc_mm: float = 0.0
    pp_mm: tuple[float, float] = (0.0, 0.0)
    aspect_diff: float = 0.0
    skew: float = 0.0
    k: tuple[float, float, float] = (0.0, 0.0, 0.0)
    p: tuple[float, float] = (0.0, 0.0)
    model: int = 3
    extra: dict = field(default_factory=dict, compare=False, hash=False)

    @property
    def pixel_size_mm(self) -> np.ndarray:
        """Pixel width and height in mm (sensor size / image size)."""
        return np.asarray(self.sensor_size_mm, float) / np.asarray(self.image_size_px, float)

    def io_vector(self) -> np.ndarray:
        """The parameter vector in :data:`IO_NAMES` order."""
        return np.array(
            [self.cc_mm, *self.pp_mm, self.aspect_diff, self.skew, *self.k, *self.p], float
        )

    def with_io(self, io: np.ndarray) -> Camera:
        """A copy carrying the parameters of an :data:`IO_NAMES` vector."""
        io = np.asarray(io, float)
        return Camera(
            id=self.id,
            name=self.name,
            image_size_px=self.image_size_px,
            sensor_size_mm=self.sensor_size_mm,
            cc_mm=float(io[0]),
            pp_mm=(float(io[1]), float(io[2])),
            aspect_diff=float(io[3]),
            skew=float(io[4]),
            k=(float(io[5]), float(io[6]), float(io[7])),
            p=(float(io[8]), float(io[9])),
            model=self.model,
            extra=self.extra,
        )


def _elementary(axis: int, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elementary rotations (n,3,3) about ``axis`` and their derivatives."""
    c, s = np.cos(angle), np.sin(angle)
    n = angle.shape[0]
    r = np.zeros((n, 3, 3))
    d = np.zeros((n, 3, 3))
    i, j = [(1, 2), (0, 2), (0, 1)][axis]
    r[:, axis, axis] = 1.0
    r[:, i, i] = c
    r[:, j, j] = c
    # R1, R3: [[c,-s],[s,c]] on (i,j); R2: [[c,s],[-s,c]] on (0,2).
    sign = -1.0 if axis == 1 else 1.0
    r[:, i, j] = -s * sign
    r[:, j, i] = s * sign
    d[:, i, i] = -s
    d[:, j, j] = -s
    d[:, i, j] = -c * sign
    d[:, j, i] = c * sign
    return r, d


def rotation_matrix(angles: np.ndarray, derivatives: bool = False):
    """Camera-to-world rotations ``R = R1(omega) R2(phi) R3(kappa)``.

    Parameters
    ----------
    angles
        (n,3) omega, phi, kappa in radians.
    derivatives
        Also return the (n,3,3,3) derivatives dR/d(omega, phi, kappa) (last axis).

    Returns
    -------
    R : (n,3,3) array, and optionally dR.
    """
    angles = np.atleast_2d(np.asarray(angles, float))
    r1, d1 = _elementary(0, angles[:, 0])
    r2, d2 = _elementary(1, angles[:, 1])
    r3, d3 = _elementary(2, angles[:, 2])
    r12 = r1 @ r2
    rot = r12 @ r3
    if not derivatives:
        return rot
    drot = np.stack([d1 @ r2 @ r3, r1 @ d2 @ r3, r12 @ d3], axis=-1)
    return rot, drot


def _distortion(a: np.ndarray, k: np.ndarray, p: np.ndarray, derivatives: bool = True):
    """Brown distortion D(a), dD/da (m,2,2), dD/dK (m,2,3), dD/dP (m,2,2).

    Without ``derivatives`` the three derivative arrays are None.
    """
    ax, ay = a[:, 0], a[:, 1]
    r2 = ax * ax + ay * ay
    k1, k2, k3 = k[:, 0], k[:, 1], k[:, 2]
    p1, p2 = p[:, 0], p[:, 1]
    rad = r2 * (k1 + r2 * (k2 + r2 * k3))
    drad = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3)  # d rad / d r2
    txy = 2.0 * ax * ay
    tx = p1 * (r2 + 2.0 * ax * ax) + p2 * txy
    ty = p2 * (r2 + 2.0 * ay * ay) + p1 * txy
    d = np.empty_like(a)
    d[:, 0] = ax * (1.0 + rad) + tx
    d[:, 1] = ay * (1.0 + rad) + ty
    if not derivatives:
        return d, None, None, None
    dda = np.empty((a.shape[0], 2, 2))
    dda[:, 0, 0] = 1.0 + rad + 2.0 * ax * ax * drad + 6.0 * p1 * ax + 2.0 * p2 * ay
    dda[:, 0, 1] = 2.0 * ax * ay * drad + 2.0 * p1 * ay + 2.0 * p2 * ax
    dda[:, 1, 0] = 2.0 * ax * ay * drad + 2.0 * p2 * ax + 2.0 * p1 * ay
    dda[:, 1, 1] = 1.0 + rad + 2.0 * ay * ay * drad + 6.0 * p2 * ay + 2.0 * p1 * ax
    ddk = np.empty((a.shape[0], 2, 3))
    pw = r2
    for j in range(3):
        ddk[:, 0, j] = ax * pw
        ddk[:, 1, j] = ay * pw
        pw = pw * r2
    ddp = np.empty((a.shape[0], 2, 2))
    ddp[:, 0, 0] = r2 + 2.0 * ax * ax
    ddp[:, 1, 0] = txy
    ddp[:, 0, 1] = txy
    ddp[:, 1, 1] = r2 + 2.0 * ay * ay
    return d, dda, ddk, ddp


def corrected_points(
    uv_mm: np.ndarray, io: np.ndarray, model: int, jacobian: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """Measured points corrected for the lens model (backward model), in mm.

    Parameters
    ----------
    uv_mm
        (m,2) measured points scaled to mm with y flipped: ``(u*s, -v*s)``.
    io
        (m,10) interior orientation of each point's camera (:data:`IO_NAMES`).
    model
        Lens distortion model 1-5.
    jacobian
        Also return d(corrected)/d(io) as (m,2,10).
    """
    m = uv_mm.shape[0]
    px, py, asp, sk = io[:, 1], io[:, 2], io[:, 3], io[:, 4]
    k, p = io[:, 5:8], io[:, 8:10]
    jac = np.zeros((m, 2, len(IO_NAMES))) if jacobian else None
    # Stage 1: translate to the principal point (model 5 scales x first).
    a = np.empty_like(uv_mm)
    if model == 5:
        a[:, 0] = (1.0 + asp) * uv_mm[:, 0] - px
        if jacobian:
            jac[:, 0, _IO["as"]] = uv_mm[:, 0]
    else:
        a[:, 0] = uv_mm[:, 0] - px
    a[:, 1] = uv_mm[:, 1] + py
    if jacobian:
        jac[:, 0, _IO["px"]] = -1.0
        jac[:, 1, _IO["py"]] = 1.0
    # Stage 2: affinity before the distortion.
    if model == 3:
        x, y = a[:, 0].copy(), a[:, 1]
        a[:, 0] = (1.0 + asp) * x + sk * y
        if jacobian:
            # Only px, py, as, sk (columns 1-4) are non-zero at this stage.
            j0 = jac[:, 0, 1:5].copy()
            jac[:, 0, 1:5] = (1.0 + asp)[:, None] * j0 + sk[:, None] * jac[:, 1, 1:5]
            jac[:, 0, _IO["as"]] += x
            jac[:, 0, _IO["sk"]] += y
    # Stage 3: Brown distortion.
    d, dda, ddk, ddp = _distortion(a, k, p, derivatives=jacobian)
    if jacobian:
        # Only px, py, as, sk (columns 1-4) are non-zero before the distortion.
        pre = jac[:, :, 1:5].copy()
        for row in (0, 1):
            jac[:, row, 1:5] = dda[:, row, 0:1] * pre[:, 0, :] + dda[:, row, 1:2] * pre[:, 1, :]
        jac[:, :, 5:8] += ddk
        jac[:, :, 8:10] += ddp
    # Stage 4: affinity (model 4) or skew (model 5) after the distortion.
    if model in (4, 5):
        x, y = d[:, 0].copy(), d[:, 1]
        scale = (1.0 + asp) if model == 4 else np.ones(m)
        d[:, 0] = scale * x + sk * y
        if jacobian:
            jac[:, 0, :] = scale[:, None] * jac[:, 0, :] + sk[:, None] * jac[:, 1, :]
            if model == 4:
                jac[:, 0, _IO["as"]] += x
            jac[:, 0, _IO["sk"]] += y
    return d, jac


def image_residuals(
    io: np.ndarray,
    eo: np.ndarray,
    xyz: np.ndarray,
    uv_mm: np.ndarray,
    model: int,
    jacobian: bool = False,
    obs_image: np.ndarray | None = None,
):
    """Image residuals ``projected - corrected`` (mm) of each observation.

    Parameters
    ----------
    io
        (m,10) interior orientation of each observation's camera.
    eo
        (m,6) exterior orientation (X0, Y0, Z0 in object units; omega, phi, kappa
        in radians) of each observation's image.
    xyz
        (m,3) object point of each observation.
    uv_mm
        (m,2) measured points in mm, y flipped (see :func:`corrected_points`).
    model
        Lens distortion model 1-5.
    jacobian
        Also return the derivatives with respect to the object point (m,2,3),
        the exterior orientation (m,2,6) and the interior orientation (m,2,10).
    obs_image
        When given, ``eo`` holds one row per image and ``obs_image`` (m,) says
        which image each observation belongs to (rotations computed once per image).

    Returns
    -------
    residual : (m,2); and ``(d_xyz, d_eo, d_io)`` when ``jacobian``.
    """
    xc, jx, ja = _camera_frame(eo, xyz, obs_image, jacobian)
    z = xc[:, 2]
    proj = xc[:, :2] / z[:, None]
    cc = io[:, 0]
    if model == FORWARD_MODEL:
        return _forward_residuals(io, proj, xc, jx, ja, uv_mm, jacobian)
    corr, dcorr = corrected_points(uv_mm, io, model, jacobian)
    res = -cc[:, None] * proj - corr
    if not jacobian:
        return res
    m = xyz.shape[0]
    # d(-cc * xc[:2]/z) / d xc = f [[1, 0, -x/z], [0, 1, -y/z]], f = -cc/z, chained with
    # d xc / d X (= R^T) and d xc / d angles (written out: dp is sparse).
    f = (-cc / z)[:, None]
    d_xyz = np.empty((m, 2, 3))
    d_eo = np.empty((m, 2, 6))
    for row in (0, 1):
        d_xyz[:, row, :] = f * (jx[:, row, :] - proj[:, row : row + 1] * jx[:, 2, :])
        d_eo[:, row, 3:6] = f * (ja[:, row, :] - proj[:, row : row + 1] * ja[:, 2, :])
    d_eo[:, :, :3] = -d_xyz
    d_io = -dcorr
    d_io[:, :, 0] += -proj
    return res, (d_xyz, d_eo, d_io)


def _camera_frame(eo: np.ndarray, xyz: np.ndarray, obs_image: np.ndarray | None,
                  jacobian: bool):  # fmt: skip
    """Camera coordinates ``xc = R^T (X - X0)`` of every observation.

    Returns xc (m,3) and, with ``jacobian``, d xc / d X (m,3,3) and
    d xc / d (omega, phi, kappa) (m,3,3) (None otherwise).  With ``obs_image``
    the rotations are per image and the products are done image by image
    (one small matrix product per image instead of per-observation gathers).
    """
    if jacobian:
        rot, drot = rotation_matrix(eo[:, 3:6], derivatives=True)
    else:
        rot, drot = rotation_matrix(eo[:, 3:6]), None
    if obs_image is None:
        diff = xyz - eo[:, :3]
        xc = np.einsum("mji,mj->mi", rot, diff)
        if not jacobian:
            return xc, None, None
        return xc, rot.transpose(0, 2, 1), np.einsum("mjik,mj->mik", drot, diff)
    m = xyz.shape[0]
    n_img = eo.shape[0]
    in_order = bool(np.all(obs_image[1:] >= obs_image[:-1]))
    order = None if in_order else np.argsort(obs_image, kind="stable")
    bounds = np.searchsorted(obs_image if in_order else obs_image[order], np.arange(n_img + 1))
    xc = np.empty((m, 3))
    jx = np.empty((m, 3, 3)) if jacobian else None
    ja = np.empty((m, 3, 3)) if jacobian else None
    for i in range(n_img):
        if bounds[i] == bounds[i + 1]:
            continue
        sel = slice(bounds[i], bounds[i + 1]) if in_order else order[bounds[i] : bounds[i + 1]]
        dif = xyz[sel] - eo[i, :3]
        xc[sel] = dif @ rot[i]
        if jacobian:
            jx[sel] = rot[i].T
            ja[sel] = (dif @ drot[i].reshape(3, 9)).reshape(-1, 3, 3)
    return xc, jx, ja


def _forward_residuals(io, proj, xc, jx, ja, uv_mm, jacobian):
    """Residuals of the forward model: distort the projected point, subtract the measured one."""
    cc = io[:, 0]
    p_mm = -cc[:, None] * proj
    x = np.column_stack([uv_mm[:, 0] - io[:, 1], uv_mm[:, 1] + io[:, 2]])
    d, dda, ddk, ddp = _distortion(p_mm, -io[:, 5:8], -io[:, 8:10], derivatives=jacobian)
    res = d - x
    if not jacobian:
        return res
    m = p_mm.shape[0]
    z = xc[:, 2]
    dp = np.zeros((m, 2, 3))
    f = -cc / z
    dp[:, 0, 0] = f
    dp[:, 1, 1] = f
    dp[:, 0, 2] = -f * proj[:, 0]
    dp[:, 1, 2] = -f * proj[:, 1]
    dp = np.einsum("mij,mjk->mik", dda, dp)  # chain through the distortion
    d_xyz = np.einsum("mik,mkj->mij", dp, jx)
    d_eo = np.empty((m, 2, 6))
    d_eo[:, :, :3] = -d_xyz
    d_eo[:, :, 3:6] = np.einsum("mij,mjk->mik", dp, ja)
    d_io = np.zeros((m, 2, len(IO_NAMES)))
    d_io[:, :, 0] = np.einsum("mij,mj->mi", dda, -proj)
    d_io[:, 0, 1] = 1.0
    d_io[:, 1, 2] = -1.0
    d_io[:, :, 5:8] = -ddk
    d_io[:, :, 8:10] = -ddp
    return res, (d_xyz, d_eo, d_io)
