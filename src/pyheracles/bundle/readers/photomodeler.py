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

import warnings
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.errors import InputError

__all__ = ["CONTROL_GRAMMAR", "read_camera_positions", "read_control_points", "read_photomodeler"]


def _nums(line: str) -> list[float]:
    out = []
    for tok in line.split():
        try:
            out.append(float(tok))
        except ValueError:
            break
    return out


def _refuse_duplicates(ids: np.ndarray, start: int, what: str, path: Path) -> None:
    """InputError naming the lines of the first id given twice in a block."""
    uniq, counts = np.unique(ids, return_counts=True)
    if np.any(counts > 1):
        pid = int(uniq[counts > 1][0])
        rows = np.flatnonzero(ids == pid) + start + 1
        raise InputError(
            f"{what} point id {pid} is given twice in the {what} block (lines "
            f"{', '.join(str(r) for r in rows[:3])}); "
            f"{int((counts > 1).sum())} duplicated id(s) in all",
            path=path,
            hint="each point id appears once per block; renumber or remove the duplicates",
        )


def read_photomodeler(
    path: str | Path, model: int = 1, image_size_px: tuple[int, int] | None = None
) -> Project:
    """Read a PhotoModeler text export.

    Parameters
    ----------
    path
        The export (``*-pmexport.txt``).
    model
        Lens distortion model to use (DBAT's PhotoModeler import uses 1).
    image_size_px
        Image width and height in pixels, for exports whose line 2 holds only the
        tolerance and the iteration count (the camera block gives the format in mm
        only); when line 2 has a size too, both must agree.

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
    head = _nums(lines[1])
    defcam = _nums(lines[3])
    if len(head) < 2 or len(defcam) < 10:
        raise InputError(
            "header is not a PhotoModeler 'Bundle Soln' export (line 2 must hold the "
            "tolerance and the iteration count, optionally the image width and height; "
            "line 4 the camera: c xp yp fw fh K1 K2 K3 P1 P2)",
            path=path,
        )
    if len(head) >= 4:
        iw, ih = int(head[2]), int(head[3])
        if image_size_px is not None and (iw, ih) != tuple(int(v) for v in image_size_px):
            raise InputError(
                f"line 2 gives the image size {iw}x{ih} px, the option "
                f"{image_size_px[0]}x{image_size_px[1]}",
                path=path,
                hint="drop the image size option or correct it",
            )
    elif image_size_px is not None:
        iw, ih = (int(v) for v in image_size_px)
    else:
        raise InputError(
            "line 2 gives no image size (PhotoModeler writes 'tolerance iterations width "
            "height'; this export has only the first two) and the camera block gives the "
            f"format in mm only ({defcam[3]:g} x {defcam[4]:g} mm)",
            path=path,
            hint="give the image size in pixels: --image-size WIDTHxHEIGHT "
            "(in Python: read_photomodeler(..., image_size_px=(w, h)))",
        )
    if iw <= 0 or ih <= 0:
        raise InputError(f"image size {iw}x{ih} px is not positive", path=path)
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

    ctrl_start = pos + 1
    ctrl, pos = block(ctrl_start, 7)
    obj_start = pos
    objs, pos = block(obj_start, 7)
    mark_start = pos
    marks, pos = block(mark_start, 6)
    if len(marks) == 0:
        raise InputError("no image measurements", path=path)
    for rows, start, what in ((ctrl, ctrl_start, "control"), (objs, obj_start, "object")):
        _refuse_duplicates(rows[:, 0].astype(int), start, what, path)
    if len(set(names)) < len(names):
        dup = sorted({nm for nm in names if names.count(nm) > 1})
        warnings.warn(
            f"{path}: image file(s) {dup[:5]} appear more than once in the image block",
            BundleWarning,
            stacklevel=2,
        )
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
    if not np.all(known):
        warnings.warn(
            f"{path}: {int((~known).sum())} image measurement(s) of point id(s) "
            f"{np.unique(mark_ids[~known])[:10].tolist()} that neither the control nor the "
            "object block defines: ignored",
            BundleWarning,
            stacklevel=2,
        )
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


_ROLE_WORDS = {"control": "control", "gcp": "control", "ctrl": "control",
               "check": "check", "cp": "check", "checkpoint": "check"}  # fmt: skip
_HEADER_NAMES = {
    "id": "id", "pid": "id", "point": "id", "point_id": "id",
    "label": "label", "name": "label",
    "x": "X", "y": "Y", "z": "Z", "e": "X", "n": "Y", "h": "Z",
    "s": "s", "sxyz": "s", "sigma": "s", "std": "s",
    "sx": "sX", "sy": "sY", "sz": "sZ", "sigmax": "sX", "sigmay": "sY", "sigmaz": "sZ",
    "role": "role", "type": "role",
}  # fmt: skip

CONTROL_GRAMMAR = """\
Control point file grammar (CSV or whitespace separated; '#' starts a comment):
  optional header  a first line of column names: id, label|name, X, Y, Z, s | sX sY sZ, role
  row (no header)  id [label] X Y Z [s | sX sY sZ] [role]
  id     positive integer: the project's point id (0 and negative ids are refused)
  label  a word that is not a number; a numeric label needs a header (or 5/7 numbers after id)
  s      standard deviation(s) in object units; none = fixed point
  role   control|gcp|ctrl (default) or check|cp|checkpoint
  Ambiguous rows are refused: 4 numbers after the id can be 'X Y Z s' or 'label X Y Z'."""


def _split(line: str) -> list[str]:
    return [t for t in line.replace(",", " ").replace(";", " ").split() if t]


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _parse_header(toks: list[str], lineno: int, path: Path) -> list[str]:
    cols = []
    for t in toks:
        name = _HEADER_NAMES.get(t.lower().strip('"'))
        if name is None:
            raise InputError(
                f"line {lineno}: unknown column '{t}' in the header; known columns: id, label, "
                "X, Y, Z, s, sX, sY, sZ, role",
                path=path,
            )
        cols.append(name)
    for need in ("id", "X", "Y", "Z"):
        if need not in cols:
            raise InputError(f"line {lineno}: the header has no '{need}' column", path=path)
    if len(set(cols)) != len(cols):
        raise InputError(f"line {lineno}: a column is named twice in the header", path=path)
    if "s" in cols and {"sX", "sY", "sZ"} & set(cols):
        raise InputError(f"line {lineno}: give either s or sX sY sZ, not both", path=path)
    if bool({"sX", "sY", "sZ"} & set(cols)) and not {"sX", "sY", "sZ"} <= set(cols):
        raise InputError(f"line {lineno}: give all three of sX sY sZ", path=path)
    return cols


def _positional_layout(toks: list[str], lineno: int, path: Path) -> list[str]:
    """Column names of a header-less row (see :data:`CONTROL_GRAMMAR`)."""
    rest = toks[1:]
    roles = [k for k, t in enumerate(rest) if t.lower() in _ROLE_WORDS]
    if len(roles) > 1:
        raise InputError(f"line {lineno}: more than one role word", path=path)
    body = [t for k, t in enumerate(rest) if k not in roles]
    cols = ["id"]
    if body and not _is_number(body[0]):
        cols.append("label")
        body = body[1:]
        numeric_label = False
    else:
        numeric_label = len(body) in (5, 7)
        if numeric_label:
            cols.append("label")
            body = body[1:]
    bad = [t for t in body if not _is_number(t)]
    if bad:
        raise InputError(
            f"line {lineno}: '{bad[0]}' is not a number (layout: id, label, X, Y, Z, then "
            "s or sX sY sZ, then the role)",
            path=path,
        )
    n = len(body)
    if n == 4 and "label" not in cols:
        raise InputError(
            f"line {lineno}: 4 numbers after the id are ambiguous (X Y Z s, or a numeric "
            "label then X Y Z)",
            path=path,
            hint="add a header line naming the columns, e.g. 'id,X,Y,Z,s' or 'id,label,X,Y,Z'",
        )
    std = {3: [], 4: ["s"], 6: ["sX", "sY", "sZ"]}.get(n)
    if std is None:
        raise InputError(
            f"line {lineno}: {n} numbers after the id{' and label' if 'label' in cols else ''}; "
            "expected X Y Z, optionally followed by s or by sX sY sZ",
            path=path,
            hint="see the control file grammar in the README (QC-1) or add a header line",
        )
    cols += ["X", "Y", "Z", *std]
    if roles:
        cols.insert(roles[0] + 1, "role")
    return cols


def read_control_points(path: str | Path, columns: str | list[str] | None = None) -> dict:
    """Read a control point table by the explicit grammar of :data:`CONTROL_GRAMMAR`.

    Parameters
    ----------
    path
        The table (CSV or whitespace separated, '#' comments).
    columns
        Column names (``"id,label,X,Y,Z,sX,sY,sZ"``), overriding a header and the
        positional grammar; needed for files without header whose rows are ambiguous.

    Returns
    -------
    dict with ``id`` (k,), ``label`` list, ``xyz`` (k,3), ``std`` (k,3) (0 = fixed),
    ``role`` list, ``source``, ``layout`` (the column names of the first row) and
    ``echo`` (the header and first rows as read, with line numbers, for the report).

    Raises
    ------
    InputError
        Naming the line: an unknown or ambiguous layout, a non-numeric value, an id
        that is not a positive integer, a duplicate id, a negative standard deviation.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("control point file not found", path=path)
    fixed_cols = None
    if columns is not None:
        toks = _split(columns) if isinstance(columns, str) else list(columns)
        fixed_cols = _parse_header(toks, 0, path)
    ids, labels, xyz, std, roles = [], [], [], [], []
    echo: list[str] = []
    first_line: dict[int, int] = {}
    layout = None
    header = fixed_cols
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.split("#", 1)[0].strip()
            if not s:
                continue
            toks = _split(s)
            if header is None and not ids and not _is_number(toks[0]):
                if all(not _is_number(t) for t in toks):
                    header = _parse_header(toks, lineno, path)
                    echo.append(f"line {lineno}: {line.rstrip()}")
                    continue
            if len(echo) < 4:
                echo.append(f"line {lineno}: {line.rstrip()}")
            cols = header if header is not None else None
            if cols is None:
                if not _is_number(toks[0]):
                    raise InputError(
                        f"line {lineno}: the first column must be the numeric point id, got "
                        f"'{toks[0]}'",
                        path=path,
                        hint="put the point id first and the name second: id, label, X, Y, Z",
                    )
                cols = _positional_layout(toks, lineno, path)
            elif len(toks) != len(cols):
                raise InputError(
                    f"line {lineno}: {len(toks)} values for the {len(cols)} columns "
                    f"{', '.join(cols)}",
                    path=path,
                )
            row = dict(zip(cols, toks, strict=True))
            layout = layout or cols
            try:
                fid = float(row["id"])
            except ValueError:
                raise InputError(
                    f"line {lineno}: point id '{row['id']}' is not a number", path=path
                ) from None
            if fid != int(fid) or fid < 1:
                raise InputError(
                    f"line {lineno}: point id {row['id']} is not a positive integer",
                    path=path,
                    hint="ids are the project's point ids (1, 2, ...); 0 is not a valid id",
                )
            pid = int(fid)
            if pid in first_line:
                raise InputError(
                    f"line {lineno}: point id {pid} already given on line {first_line[pid]}",
                    path=path,
                    hint="every control or check point appears once",
                )
            try:
                vals = {
                    k: float(row[k]) for k in ("X", "Y", "Z", "s", "sX", "sY", "sZ") if k in row
                }
            except ValueError as exc:
                raise InputError(f"line {lineno}: {exc}", path=path) from None
            if not all(np.isfinite(v) for v in vals.values()):
                raise InputError(f"line {lineno}: NaN or infinite value", path=path)
            sd = [vals["s"]] * 3 if "s" in vals else [vals.get(k, 0.0) for k in ("sX", "sY", "sZ")]
            if min(sd) < 0:
                raise InputError(f"line {lineno}: negative standard deviation", path=path)
            role = "control"
            if "role" in row:
                role = _ROLE_WORDS.get(row["role"].lower())
                if role is None:
                    raise InputError(
                        f"line {lineno}: unknown role '{row['role']}' (control or check)",
                        path=path,
                    )
            first_line[pid] = lineno
            ids.append(pid)
            labels.append(row.get("label", str(pid)))
            xyz.append([vals["X"], vals["Y"], vals["Z"]])
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
        "layout": layout,
        "header": header is not None,
        "echo": echo,
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
