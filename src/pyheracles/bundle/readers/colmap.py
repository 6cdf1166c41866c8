"""Reader of COLMAP text models (``cameras.txt``, ``images.txt``, ``points3D.txt``).

COLMAP conventions: ``x_cam = R(q) X + t`` (world-to-camera, quaternion
``qw qx qy qz``), the camera looks along +z with y down, image coordinates in
pixels from the upper-left corner of the image.  COLMAP has no metric sensor
size: we use a nominal pixel size (``pixel_size_mm``, default 0.005 mm), so
camera constant and principal point are ``f * pixel_size``; results in pixels
do not depend on this choice.

Camera models: SIMPLE_PINHOLE, PINHOLE (fx != fy becomes the affinity
parameter ``as = fy/fx - 1``, lens model 3), SIMPLE_RADIAL, RADIAL, OPENCV.
COLMAP distortion is a forward model (the projected point is distorted): with
fx = fy it maps exactly onto DBAT's forward model -1 (``K_i = -k_i / f^(2i)``,
``P1 = -p2 / f``, ``P2 = p1 / f`` in mm with y up); an OPENCV camera with
fx != fy needs the affinity of the backward model 3, where the same rule is
DBAT's first-order conversion (exact only without distortion; a warning says
so).  Other COLMAP models (fisheye, FOV, FULL_OPENCV, ...) are refused with the
fix: undistort the images (``colmap image_undistorter``) and export the
undistorted, PINHOLE model.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.initial import angles_from_rotation
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.errors import InputError

__all__ = ["quaternion_to_matrix", "read_colmap"]

_MODELS = {"SIMPLE_PINHOLE": 3, "PINHOLE": 4, "SIMPLE_RADIAL": 4, "RADIAL": 5, "OPENCV": 8}


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n,3,3) of unit quaternions (n,4) ``qw, qx, qy, qz``."""
    q = np.atleast_2d(np.asarray(q, float))
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


_FIX_MODEL = (
    "undistort the images (colmap image_undistorter --output_type COLMAP) and give the "
    "undistorted model (PINHOLE), or re-run the reconstruction with one of "
    + ", ".join(sorted(_MODELS))
)
_FIX_TEXT = "re-export the model as text: colmap model_converter --output_type TXT"


def _lines(path: Path) -> list[tuple[int, str]]:
    """(line number, text) of the non-comment lines (empty lines kept)."""
    if not path.is_file():
        raise InputError("COLMAP model file not found", path=path, hint=_FIX_TEXT)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"unreadable COLMAP model file ({exc})", path=path) from None
    return [(k, s) for k, s in enumerate(text.splitlines(), 1) if not s.startswith("#")]


def _read_cameras(path: Path, pixel_size_mm: float) -> dict[int, Camera]:
    cams: dict[int, Camera] = {}
    for ln, s in _lines(path):
        t = s.split()
        if not t:
            continue
        try:
            cid, model, w, h = int(t[0]), t[1], int(t[2]), int(t[3])
            par = [float(v) for v in t[4:]]
        except (ValueError, IndexError):
            raise InputError(
                f"line {ln}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got '{s}'",
                path=path,
                hint=_FIX_TEXT,
            ) from None
        if model not in _MODELS:
            raise InputError(
                f"line {ln}: COLMAP camera model {model} is not supported "
                f"(supported: {', '.join(sorted(_MODELS))})",
                path=path,
                hint=_FIX_MODEL,
            )
        if len(par) != _MODELS[model]:
            raise InputError(
                f"line {ln}: camera model {model} takes {_MODELS[model]} parameters, "
                f"got {len(par)}",
                path=path,
                hint=_FIX_TEXT,
            )
        if cid in cams:
            raise InputError(f"line {ln}: camera id {cid} occurs twice", path=path)
        if model in ("PINHOLE", "OPENCV"):
            fx, fy, cx, cy = par[:4]
        else:
            fx = fy = par[0]
            cx, cy = par[1:3]
        if fx <= 0 or fy <= 0 or w <= 0 or h <= 0:
            raise InputError(f"line {ln}: focal length and image size must be > 0", path=path)
        ks = {"SIMPLE_RADIAL": par[3:4], "RADIAL": par[3:5], "OPENCV": par[4:6]}.get(model, [])
        ps = par[6:8] if model == "OPENCV" else [0.0, 0.0]
        distorted = any(v != 0 for v in (*ks, *ps))
        affine = fx != fy
        if distorted and affine:
            warnings.warn(
                f"{path} line {ln}: camera {cid} has fx != fy and distortion; the "
                "distortion is converted to the backward model to first order only",
                BundleWarning,
                stacklevel=3,
            )
        f_mm = fy * pixel_size_mm
        k = [-kk * f_mm ** (-2 * (i + 1)) for i, kk in enumerate(ks)] + [0.0] * (3 - len(ks))
        cams[cid] = Camera(
            id=cid,
            name=model,
            image_size_px=(w, h),
            sensor_size_mm=(w * pixel_size_mm, h * pixel_size_mm),
            cc_mm=f_mm,
            pp_mm=(cx * pixel_size_mm, cy * pixel_size_mm),
            aspect_diff=fy / fx - 1.0,
            k=tuple(k),
            p=(-ps[1] / f_mm, ps[0] / f_mm),
            model=-1 if distorted and not affine else 3,
            extra={"colmap_model": model, "colmap_params": par},
        )
    if not cams:
        raise InputError("no camera", path=path, hint=_FIX_TEXT)
    return cams


def _read_images(path: Path, cams: dict[int, Camera]):
    """Image poses and keypoints (two lines per image, the second may be empty)."""
    lines = _lines(path)
    while lines and not lines[0][1].strip():
        lines.pop(0)
    while lines and not lines[-1][1].strip() and len(lines) % 2:
        lines.pop()  # a final newline after the last keypoint line
    if len(lines) % 2:
        ln, s = lines[-1]
        raise InputError(
            f"truncated: image line {ln} ('{s[:60]}') has no keypoint line after it",
            path=path,
            hint=_FIX_TEXT,
        )
    img_ids, names, eo, cam_of = [], [], [], []
    obs_img, obs_pid, obs_uv = [], [], []
    for k in range(0, len(lines), 2):
        ln, head = lines[k]
        t = head.split()
        try:
            iid = int(t[0])
            q = np.array([float(v) for v in t[1:5]])
            tv = np.array([float(v) for v in t[5:8]])
            cid = int(t[8])
            if len(t) < 10 or len(q) != 4 or len(tv) != 3:
                raise ValueError
        except (ValueError, IndexError):
            raise InputError(
                f"line {ln}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, "
                f"got '{head[:80]}'",
                path=path,
                hint=_FIX_TEXT,
            ) from None
        if cid not in cams:
            raise InputError(f"line {ln}: image {iid} uses unknown camera {cid}", path=path)
        if iid in img_ids:
            raise InputError(f"line {ln}: image id {iid} occurs twice", path=path)
        ln2, body = lines[k + 1]
        try:
            pts = np.array([float(v) for v in body.split()], float)
            if len(pts) % 3:
                raise ValueError
        except ValueError:
            raise InputError(
                f"line {ln2}: keypoints must be X Y POINT3D_ID triples "
                f"({len(body.split())} values: truncated?)",
                path=path,
                hint=_FIX_TEXT,
            ) from None
        pts = pts.reshape(-1, 3)
        r_w2c = quaternion_to_matrix(q)[0]
        centre = -r_w2c.T @ tv
        r_c2w = r_w2c.T @ np.diag([1.0, -1.0, -1.0])
        img_ids.append(iid)
        names.append(" ".join(t[9:]))
        cam_of.append(cid)
        eo.append(np.concatenate([centre, angles_from_rotation(r_c2w)[0]]))
        valid = pts[:, 2] >= 0
        obs_img.append(np.full(int(valid.sum()), len(img_ids) - 1))
        obs_pid.append(pts[valid, 2].astype(int))
        obs_uv.append(pts[valid, :2])
    if not img_ids:
        raise InputError("no image", path=path, hint=_FIX_TEXT)
    return img_ids, names, eo, cam_of, obs_img, obs_pid, obs_uv


def _read_points(path: Path) -> tuple[np.ndarray, np.ndarray]:
    pid, xyz = [], []
    for ln, s in _lines(path):
        t = s.split()
        if not t:
            continue
        try:
            pid.append(int(t[0]))
            xyz.append([float(v) for v in t[1:4]])
            if len(xyz[-1]) != 3:
                raise ValueError
        except (ValueError, IndexError):
            raise InputError(
                f"line {ln}: expected POINT3D_ID X Y Z R G B ERROR TRACK[], got '{s[:80]}'",
                path=path,
                hint=_FIX_TEXT,
            ) from None
    if len(set(pid)) != len(pid):
        raise InputError("a POINT3D_ID occurs twice", path=path)
    order = np.argsort(pid)
    return np.asarray(pid, int)[order], np.asarray(xyz, float).reshape(-1, 3)[order]


def read_colmap(folder: str | Path, pixel_size_mm: float = 0.005, obs_std_px: float = 1.0):
    """Read a COLMAP text model folder.

    Parameters
    ----------
    folder
        Folder holding ``cameras.txt``, ``images.txt`` and ``points3D.txt``.
    pixel_size_mm
        Nominal pixel size (COLMAP models are not metric in the image).
    obs_std_px
        A priori standard deviation of the keypoint measurements (pixels).

    Returns
    -------
    Project
        No control points: the datum is dependent relative orientation.
        Keypoints of a 3D point missing from ``points3D.txt`` are left out with a
        warning that counts them.
    """
    folder = Path(folder)
    cams = _read_cameras(folder / "cameras.txt", pixel_size_mm)
    img_ids, names, eo, cam_of, obs_img, obs_pid, obs_uv = _read_images(folder / "images.txt", cams)
    point_ids, xyz_a = _read_points(folder / "points3D.txt")
    oi = np.concatenate(obs_img)
    op = np.concatenate(obs_pid)
    known = np.isin(op, point_ids)
    if not known.all():
        warnings.warn(
            f"{folder}: {int((~known).sum())} keypoint(s) of {len(np.unique(op[~known]))} "
            "3D point(s) absent from points3D.txt left out",
            BundleWarning,
            stacklevel=2,
        )
    cam_ids = sorted(cams)
    cam_index = {c: i for i, c in enumerate(cam_ids)}
    n = len(img_ids)
    npts = len(point_ids)
    est = np.zeros((len(cam_ids), len(IO_NAMES)), bool)
    uv = np.concatenate(obs_uv)[known]
    return Project(
        name=folder.name,
        source=str(folder),
        cameras=tuple(cams[c] for c in cam_ids),
        image_ids=np.asarray(img_ids),
        image_names=tuple(names),
        image_camera=np.array([cam_index[c] for c in cam_of]),
        eo=np.asarray(eo),
        eo_std=np.full((n, 6), np.nan),
        point_ids=point_ids,
        point_labels=tuple(str(i) for i in point_ids),
        xyz=xyz_a,
        xyz_std=np.full((npts, 3), np.nan),
        point_role=np.full(npts, "tie"),
        obs_image=oi[known],
        obs_point=np.searchsorted(point_ids, op[known]),
        obs_uv_px=uv,
        obs_std_px=np.full(uv.shape, obs_std_px),
        estimate_io=est,
        estimate_eo=np.ones((n, 6), bool),
        datum="depend",
        meta={"format": "colmap", "pixel_size_mm": pixel_size_mm},
    )
