"""Reader of COLMAP text models (``cameras.txt``, ``images.txt``, ``points3D.txt``).

COLMAP conventions: ``x_cam = R(q) X + t`` (world-to-camera, quaternion
``qw qx qy qz``), the camera looks along +z with y down, image coordinates in
pixels from the upper-left corner of the image.  COLMAP has no metric sensor
size: we use a nominal pixel size (``pixel_size_mm``, default 0.005 mm), so
camera constant and principal point are ``f * pixel_size``; results in pixels
do not depend on this choice.

Camera models: SIMPLE_PINHOLE, PINHOLE (fx != fy becomes the affinity
parameter ``as = fy/fx - 1``, lens model 3), SIMPLE_RADIAL, RADIAL, OPENCV.
COLMAP distortion is a forward model; it is converted to the backward Brown
model with DBAT's first-order rule (``K1 = -k1 / f^2``, ...), exact only
without distortion.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.initial import angles_from_rotation
from pyheracles.bundle.project import Project
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


def _lines(path: Path, keep_empty: bool = False) -> list[str]:
    if not path.is_file():
        raise InputError("COLMAP model file not found", path=path)
    lines = [s for s in path.read_text().splitlines() if not s.startswith("#")]
    return lines if keep_empty else [s for s in lines if s.strip()]


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
    """
    folder = Path(folder)
    cams: dict[int, Camera] = {}
    for s in _lines(folder / "cameras.txt"):
        t = s.split()
        try:
            cid, model, w, h = int(t[0]), t[1], int(t[2]), int(t[3])
            par = [float(v) for v in t[4:]]
        except (ValueError, IndexError):
            raise InputError(f"bad camera line '{s}'", path=folder / "cameras.txt") from None
        if model not in _MODELS or len(par) < _MODELS[model]:
            raise InputError(
                f"unsupported camera model {model}",
                path=folder / "cameras.txt",
                hint=f"use one of {sorted(_MODELS)}",
            )
        if model in ("PINHOLE", "OPENCV"):
            fx, fy, cx, cy = par[:4]
        else:
            fx = fy = par[0]
            cx, cy = par[1:3]
        ks = {"SIMPLE_RADIAL": par[3:4], "RADIAL": par[3:5], "OPENCV": par[4:6]}.get(model, [])
        ps = par[6:8] if model == "OPENCV" else [0.0, 0.0]
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
            model=3,
            extra={"colmap_model": model, "colmap_params": par},
        )
    if not cams:
        raise InputError("no camera", path=folder / "cameras.txt")
    # Two lines per image; the second is empty for an image without keypoints.
    lines = _lines(folder / "images.txt", keep_empty=True)
    while lines and not lines[0].strip():
        lines.pop(0)
    img_ids, names, eo, cam_of = [], [], [], []
    obs_img, obs_pid, obs_uv = [], [], []
    for k in range(0, len(lines) - 1, 2):
        t = lines[k].split()
        try:
            iid = int(t[0])
            q = np.array([float(v) for v in t[1:5]])
            tv = np.array([float(v) for v in t[5:8]])
            cid = int(t[8])
        except (ValueError, IndexError):
            raise InputError(f"bad image line '{lines[k]}'", path=folder / "images.txt") from None
        if cid not in cams:
            raise InputError(f"image {iid} uses unknown camera {cid}", path=folder / "images.txt")
        r_w2c = quaternion_to_matrix(q)[0]
        centre = -r_w2c.T @ tv
        r_c2w = r_w2c.T @ np.diag([1.0, -1.0, -1.0])
        img_ids.append(iid)
        names.append(" ".join(t[9:]))
        cam_of.append(cid)
        eo.append(np.concatenate([centre, angles_from_rotation(r_c2w)[0]]))
        pts = np.array([float(v) for v in lines[k + 1].split()]).reshape(-1, 3)
        valid = pts[:, 2] >= 0
        obs_img.append(np.full(int(valid.sum()), len(img_ids) - 1))
        obs_pid.append(pts[valid, 2].astype(int))
        obs_uv.append(pts[valid, :2])
    if not img_ids:
        raise InputError("no image", path=folder / "images.txt")
    pid, xyz = [], []
    for s in _lines(folder / "points3D.txt"):
        t = s.split()
        pid.append(int(t[0]))
        xyz.append([float(v) for v in t[1:4]])
    order = np.argsort(pid)
    point_ids = np.asarray(pid, int)[order]
    xyz_a = np.asarray(xyz, float).reshape(-1, 3)[order]
    oi = np.concatenate(obs_img)
    op = np.concatenate(obs_pid)
    known = np.isin(op, point_ids)
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
