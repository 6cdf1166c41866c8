"""Reader of PhotoModeler text exports ("Bundle Soln" files) and control point tables.

Layout of the export (one record per line, blocks ended by an empty line):

1. title; tolerance, max iterations, image width and height (pixels); default
   standard deviations; default camera ``c xp yp fw fh K1 K2 K3 P1 P2`` (mm) and
   its standard deviations;
2. per image: ``index path``; ``index X Y Z kappa phi omega`` (m, degrees);
   their standard deviations; an optional covariance line; the image's camera
   and its standard deviations;
3. control points ``id X Y Z sX sY sZ``;
4. object points ``id X Y Z sX sY sZ``;
5. image measurements ``image id x y sx sy`` (pixels, image index from 0).

PhotoModeler stores K and P with the opposite sign convention of the
photogrammetric model used here only internally in DBAT; the exported values
are the ones our :class:`~pyheracles.bundle.camera.Camera` takes.  As DBAT does,
pixels are taken square with the pixel height (sensor height / image height)
and the difference in pixel width becomes the initial aspect parameter.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.project import Project
from pyheracles.errors import InputError

__all__ = ["read_camera_positions", "read_control_points", "read_photomodeler"]


def _nums(line: str) -> list[float]:
    out = []
    for tok in line.split():
        try:
            out.append(float(tok))
        except ValueError:
            break
    return out


def read_photomodeler(path: str | Path, model: int = 1) -> Project:
    """Read a PhotoModeler text export.

    Parameters
    ----------
    path
        The export (``*-pmexport.txt``).
    model
        Lens distortion model to use (DBAT's PhotoModeler import uses 1).

    Returns
    -------
    Project
        Initial values from PhotoModeler's own solution; no interior parameter
        estimated (choose with ``BundleParameters.estimate_io``); control points
        from the export's control block.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise InputError(f"unreadable PhotoModeler export ({exc})", path=path) from None
    if len(lines) < 6:
        raise InputError("too short for a PhotoModeler export", path=path)
    try:
        head = _nums(lines[1])
        defcam = _nums(lines[3])
        if len(head) < 4 or len(defcam) < 10:
            raise ValueError
        iw, ih = int(head[2]), int(head[3])
    except (ValueError, IndexError):
        raise InputError(
            "header is not a PhotoModeler 'Bundle Soln' export (line 2 must hold "
            "tolerance, iterations, image width and height; line 4 the camera)",
            path=path,
        ) from None
    pos = 5
    names, eo_rows = [], []
    while pos < len(lines):
        toks = lines[pos].split(maxsplit=1)
        if len(toks) < 2 or not toks[0].lstrip("-").isdigit():
            break
        names.append(Path(toks[1].strip().replace("\\", "/")).name)
        outer = _nums(lines[pos + 1])[1:]
        if len(outer) < 6:
            raise InputError(f"line {pos + 2}: bad exterior orientation", path=path)
        x, y, z, kappa, phi, omega = outer[:6]
        eo_rows.append([x, y, z, *np.radians([omega, phi, kappa])])
        pos += 6
    if not names:
        raise InputError("no image block found", path=path)

    def block(start: int, ncol: int) -> tuple[np.ndarray, int]:
        rows = []
        p = start
        while p < len(lines) and lines[p].strip():
            vals = _nums(lines[p])
            if len(vals) < ncol:
                raise InputError(f"line {p + 1}: expected {ncol} numbers", path=path)
            rows.append(vals[:ncol])
            p += 1
        return np.asarray(rows, float).reshape(-1, ncol), p + 1

    ctrl, pos = block(pos + 1, 7)
    objs, pos = block(pos, 7)
    marks, pos = block(pos, 6)
    if len(marks) == 0:
        raise InputError("no image measurements", path=path)
    ids = np.unique(np.concatenate([ctrl[:, 0], objs[:, 0]]).astype(int))
    npts = len(ids)
    xyz = np.full((npts, 3), np.nan)
    xyz_std = np.full((npts, 3), np.nan)
    role = np.full(npts, "tie", dtype=object)
    io = np.searchsorted(ids, objs[:, 0].astype(int))
    xyz[io] = objs[:, 1:4]
    ic = np.searchsorted(ids, ctrl[:, 0].astype(int))
    xyz[ic] = ctrl[:, 1:4]
    xyz_std[ic] = ctrl[:, 4:7]
    role[ic] = "control"
    mark_ids = marks[:, 1].astype(int)
    known = np.isin(mark_ids, ids)
    marks = marks[known]
    obs_image = marks[:, 0].astype(int)
    if obs_image.min() < 0 or obs_image.max() >= len(names):
        raise InputError("measurement on an unknown image index", path=path)
    std = marks[:, 4:6].copy()
    if np.any(std == 0):
        std[:] = 1.0  # DBAT: zero and non-zero priors mixed -> unit weights
    fh = defcam[4]
    fw = defcam[3]
    pix = fh / ih
    aspect_diff = 1.0 - (fw / iw) / pix
    cam = Camera(
        id=1,
        name=lines[0].strip(),
        image_size_px=(iw, ih),
        sensor_size_mm=(pix * iw, fh),
        cc_mm=defcam[0],
        pp_mm=(defcam[1], defcam[2]),
        aspect_diff=aspect_diff if model not in (1, 2, -1) else 0.0,
        skew=0.0,
        k=(defcam[5], defcam[6], defcam[7]),
        p=(defcam[8], defcam[9]),
        model=model,
        extra={"format_mm": (fw, fh), "focal_mm": defcam[0]},
    )
    n = len(names)
    return Project(
        name=lines[0].strip(),
        source=str(path),
        cameras=(cam,),
        image_ids=np.arange(1, n + 1),
        image_names=tuple(names),
        image_camera=np.zeros(n, int),
        eo=np.asarray(eo_rows, float),
        eo_std=np.full((n, 6), np.nan),
        point_ids=ids,
        point_labels=tuple(str(i) for i in ids),
        xyz=xyz,
        xyz_std=xyz_std,
        point_role=role.astype(str),
        obs_image=obs_image,
        obs_point=np.searchsorted(ids, marks[:, 1].astype(int)),
        obs_uv_px=marks[:, 2:4].copy(),
        obs_std_px=std,
        estimate_io=np.zeros((1, len(IO_NAMES)), bool),
        estimate_eo=np.ones((n, 6), bool),
        datum="control" if len(ctrl) else None,
        meta={"format": "photomodeler"},
    )


def read_control_points(path: str | Path) -> dict:
    """Read a control point table (CSV or whitespace separated, '#' comments).

    Accepted rows: ``id, X, Y, Z``, ``id, label, X, Y, Z``, optionally followed by
    one standard deviation (all axes) or three (sX, sY, sZ), and optionally a
    role word ``control``/``gcp`` or ``check``/``cp`` anywhere after the id.
    A missing standard deviation means a fixed (error-free) control point.

    Returns
    -------
    dict with ``id`` (k,), ``label`` list, ``xyz`` (k,3), ``std`` (k,3), ``role`` list.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("control point file not found", path=path)
    ids, labels, xyz, std, roles = [], [], [], [], []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            toks = [t for t in s.replace(",", " ").replace(";", " ").split() if t]
            role = "control"
            words = []
            nums: list[float] = []
            for t in toks[1:]:
                low = t.lower()
                if low in ("control", "gcp", "ctrl"):
                    role = "control"
                    continue
                if low in ("check", "cp", "checkpoint"):
                    role = "check"
                    continue
                try:
                    nums.append(float(t))
                except ValueError:
                    if nums:
                        raise InputError(f"line {lineno}: unexpected '{t}'", path=path) from None
                    words.append(t)
            try:
                pid = int(float(toks[0]))
            except ValueError:
                raise InputError(f"line {lineno}: point id must be a number", path=path) from None
            if len(nums) not in (3, 4, 6):
                raise InputError(
                    f"line {lineno}: expected X Y Z [sXYZ | sX sY sZ], got {len(nums)} numbers",
                    path=path,
                )
            ids.append(pid)
            labels.append(words[0] if words else str(pid))
            xyz.append(nums[:3])
            sd = (
                [0.0, 0.0, 0.0]
                if len(nums) == 3
                else (nums[3:] * 3 if len(nums) == 4 else nums[3:])
            )
            std.append(sd)
            roles.append(role)
    if not ids:
        raise InputError("no control point in the file", path=path)
    return {
        "id": np.asarray(ids),
        "label": labels,
        "xyz": np.asarray(xyz, float),
        "std": np.asarray(std, float),
        "role": roles,
        "source": str(path),
    }


def read_camera_positions(path: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Read prior camera positions ``label, X, Y, Z[, s | sX, sY, sZ]`` (CSV, '#' comments).

    Returns a dict image label -> (xyz (3,), std (3,)); a missing accuracy is an
    error (a prior without accuracy has no weight).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("camera position file not found", path=path)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            toks = [t.strip() for t in s.split(",")]
            try:
                vals = [float(t) for t in toks[1:]]
            except ValueError:
                raise InputError(f"line {lineno}: non-numeric value", path=path) from None
            if len(vals) not in (4, 6):
                raise InputError(
                    f"line {lineno}: expected label, X, Y, Z and 1 or 3 accuracies", path=path
                )
            sd = vals[3:] * 3 if len(vals) == 4 else vals[3:]
            out[toks[0]] = (np.asarray(vals[:3]), np.asarray(sd, float))
    if not out:
        raise InputError("no camera position in the file", path=path)
    return out
