"""Reader of DBAT XML script projects (``dbat_script_version`` 1.0).

A script names an image list, image measurements, cameras, optional control
points and prior exterior orientation, then lists operations: which initial
values to use, which parameters to estimate, the datum, resection and
intersection.  We read the data and translate the operations into
:class:`~pyheracles.bundle.project.Project` fields (estimate flags, datum,
initial values); the adjustment itself is :func:`pyheracles.bundle.bundle_adjust`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.project import Project
from pyheracles.errors import InputError

__all__ = ["read_camera_xml", "read_dbat_script"]


def _text(el: ET.Element | None, default: str | None = None) -> str | None:
    if el is None or el.text is None:
        return default
    return el.text.strip()


def _read_table(path: Path, fmt: str) -> dict[str, list[str]]:
    """Comma-separated table with '#' comments; columns named by ``fmt``."""
    if not path.is_file():
        raise InputError("file not found", path=path, hint="check the path in the script")
    names = [s.strip() for s in fmt.split(",")]
    cols: dict[str, list[str]] = {n: [] for n in names}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            parts = [p.strip() for p in s.split(",")]
            if len(parts) < len(names):
                raise InputError(
                    f"line {lineno}: expected {len(names)} values ({fmt}), got {len(parts)}",
                    path=path,
                )
            for n, p in zip(names, parts, strict=False):
                cols[n].append(p)
    return cols


def _floats(values: list[str], path: Path, what: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in values], float)
    except ValueError as exc:
        raise InputError(f"non-numeric {what}: {exc}", path=path) from None


def _resolve(base: Path, text: str, here: Path) -> Path:
    text = text.replace("$HERE", str(here.resolve()))
    p = Path(text)
    return p if p.is_absolute() else base / p


def _camera_from_xml(el: ET.Element, path: Path) -> Camera:
    def num(tag: str, default: float | None = None) -> float | None:
        t = _text(el.find(tag))
        if t is None:
            return default
        try:
            return float(t)
        except ValueError:
            return default

    def vec(tag: str, n: int) -> list[float]:
        t = _text(el.find(tag))
        if t is None or t in ("", "default"):
            return [0.0] * n
        vals = [float(v) for v in t.split(",") if v.strip()]
        return (vals + [0.0] * n)[:n]

    image = _text(el.find("image"))
    sensor = _text(el.find("sensor"))
    if image is None or sensor is None:
        raise InputError("camera without <image> or <sensor> size", path=path)
    iw, ih = (int(float(v)) for v in image.split(","))
    sw_txt, sh_txt = (v.strip() for v in sensor.split(","))
    aspect_txt = _text(el.find("aspect"), "1")
    aspect = 1.0 if aspect_txt == "auto" else float(aspect_txt)
    sh = float(sh_txt)
    # 'auto' width: square pixels scaled by the aspect ratio (DBAT convention).
    sw = aspect * sh * iw / ih if sw_txt == "auto" else float(sw_txt)
    focal = num("focal", 0.0)
    cc_txt = _text(el.find("cc"))
    cc = focal if cc_txt in (None, "focal") else float(cc_txt.split(",")[0])
    pp_txt = _text(el.find("pp"))
    pp = (sw / 2, sh / 2) if pp_txt in (None, "default") else tuple(vec("pp", 2))
    model = int(num("model", 3))
    cam = Camera(
        id=int(num("id", 1)),
        name=_text(el.find("name"), "") or "",
        image_size_px=(iw, ih),
        sensor_size_mm=(sw, sh),
        cc_mm=float(cc),
        pp_mm=(float(pp[0]), float(pp[1])),
        aspect_diff=1.0 - aspect,
        skew=float(num("skew", 0.0)),
        k=tuple(vec("K", 3)),
        p=tuple(vec("P", 2)),
        model=model,
        extra={"focal_mm": focal},
    )
    if _text(el.find("all")) == "default":
        cam = cam.with_io(_default_io(cam))
    return cam


def _default_io(cam: Camera) -> np.ndarray:
    """DBAT 'default' interior orientation: cc = focal, centred pp, no distortion."""
    io = np.zeros(len(IO_NAMES))
    io[0] = cam.extra.get("focal_mm", cam.cc_mm)
    io[1:3] = np.asarray(cam.sensor_size_mm) / 2
    return io


def read_camera_xml(path: str | Path) -> list[Camera]:
    """Cameras of a DBAT camera XML file (``dbat_camera_version`` 1.0)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise InputError(f"unreadable camera XML ({exc})", path=path) from None
    cams = [_camera_from_xml(el, path) for el in root.iter("camera")]
    if not cams:
        raise InputError("no <camera> element", path=path)
    return cams


def _apply_io_initial(cams: list[Camera], el: ET.Element) -> list[Camera]:
    out = []
    for cam in cams:
        io = cam.io_vector()
        for child in el:
            val = (child.text or "").strip()
            tag = child.tag
            if tag == "all" and val == "default":
                io = _default_io(cam)
            elif tag == "aspect" and val not in ("loaded", "default"):
                io[3] = 1.0 - float(val)
            elif tag == "aspect" and val == "default":
                io[3] = 0.0
            elif tag == "skew" and val not in ("loaded",):
                io[4] = 0.0 if val == "default" else float(val)
            elif tag == "cc" and val in ("focal", "default"):
                io[0] = cam.extra.get("focal_mm", io[0])
            elif tag == "pp" and val == "default":
                io[1:3] = np.asarray(cam.sensor_size_mm) / 2
            elif tag == "K" and val == "default":
                io[5:8] = 0.0
            elif tag == "P" and val == "default":
                io[8:10] = 0.0
        out.append(cam.with_io(io))
    return out


def _estimate_io_flags(el: ET.Element, ncam: int) -> np.ndarray:
    est = np.zeros((ncam, len(IO_NAMES)), bool)
    alias = {"aspect": ["as"], "skew": ["sk"], "pp": ["px", "py"], "K": ["K1", "K2", "K3"]}
    alias["P"] = ["P1", "P2"]
    alias["all"] = list(IO_NAMES)
    text = _text(el)
    items = [("all", text)] if text in ("true", "false") else [(c.tag, _text(c)) for c in el]
    for tag, val in items:
        names = alias.get(tag, [tag])
        for n in names:
            if n not in IO_NAMES:
                raise InputError(f"unknown IO parameter '{tag}' in set_bundle_estimate_params")
            est[:, IO_NAMES.index(n)] = val == "true"
    return est


def read_dbat_script(path: str | Path) -> Project:
    """Read a DBAT XML script project.

    Parameters
    ----------
    path
        The script (e.g. ``script/romabundledemo/romabundledemo.xml``).

    Returns
    -------
    Project
        With the initial values, estimate flags and datum that the script's
        operations ask for.

    Raises
    ------
    InputError
        Unreadable XML, missing files, unknown operations.
    """
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise InputError(f"unreadable DBAT script ({exc})", path=path) from None
    if root.tag != "document" or "dbat_script_version" not in root.attrib:
        raise InputError("not a DBAT script (no dbat_script_version)", path=path)
    here = path.parent
    inp = root.find("input")
    if inp is None:
        raise InputError("no <input> section", path=path)
    base = _resolve(here, inp.attrib.get("base_dir", "$HERE"), here)
    name = _text(root.find("meta/name"), path.stem) or path.stem

    # Cameras (inline or in files).
    cams: list[Camera] = []
    cam_el = inp.find("cameras")
    if cam_el is None:
        raise InputError("no <cameras> in <input>", path=path)
    for child in cam_el:
        if child.tag == "file":
            cams.extend(read_camera_xml(_resolve(base, _text(child), here)))
        elif child.tag == "camera":
            cams.append(_camera_from_xml(child, path))
    if not cams:
        raise InputError("no camera defined", path=path)

    # Images.
    im_file = inp.find("images/file")
    if im_file is None:
        raise InputError("no <images><file>", path=path)
    im_path = _resolve(base, _text(im_file), here)
    tab = _read_table(im_path, im_file.attrib.get("format", "id,path"))
    image_ids = np.array([int(v) for v in tab["id"]])
    image_names = tuple(Path(p.replace("\\", "/")).name for p in tab["path"])
    n = len(image_ids)
    if n == 0:
        raise InputError("empty image list", path=im_path)
    image_camera = np.zeros(n, int)

    # Image measurements.
    obs_im, obs_id, uv, std = [], [], [], []
    for f in inp.findall("image_pts/file"):
        p = _resolve(base, _text(f), here)
        fmt = f.attrib.get("format", "im,id,x,y")
        t = _read_table(p, fmt)
        m = len(t["im"])
        obs_im.append(np.array([int(v) for v in t["im"]]))
        obs_id.append(np.array([int(v) for v in t["id"]]))
        uv.append(np.column_stack([_floats(t["x"], p, "x"), _floats(t["y"], p, "y")]))
        s = np.ones((m, 2))
        if "sxy" in t:
            s[:] = _floats(t["sxy"], p, "sxy")[:, None]
        if "sx" in t:
            s[:, 0] = _floats(t["sx"], p, "sx")
        if "sy" in t:
            s[:, 1] = _floats(t["sy"], p, "sy")
        for key, col in (("sxy", slice(0, 2)), ("sx", 0), ("sy", 1)):
            if key in f.attrib:
                s[:, col] = float(f.attrib[key])
        std.append(s)
    if not obs_im:
        raise InputError("no <image_pts><file>", path=path)
    obs_im_a = np.concatenate(obs_im)
    obs_id_a = np.concatenate(obs_id)

    # Control and check points.
    ctrl: dict[int, tuple[str, np.ndarray, np.ndarray, str]] = {}
    for tag, role in (("ctrl_pts", "control"), ("check_pts", "check")):
        f = inp.find(f"{tag}/file")
        if f is None:
            continue
        p = _resolve(base, _text(f), here)
        t = _read_table(p, f.attrib.get("format", "id,label,x,y,z"))
        xyz = np.column_stack([_floats(t[c], p, c) for c in ("x", "y", "z")])
        sd = np.zeros_like(xyz)
        if "sxyz" in t:
            sd[:] = _floats(t["sxyz"], p, "sxyz")[:, None]
        for c, j in (("sx", 0), ("sy", 1), ("sz", 2)):
            if c in t:
                sd[:, j] = _floats(t[c], p, c)
        labels = t.get("label", t["id"])
        for i, pid in enumerate(t["id"]):
            ctrl[int(pid)] = (labels[i], xyz[i], sd[i], role)

    point_ids = np.unique(np.concatenate([obs_id_a, np.array(list(ctrl), int)]))
    npts = len(point_ids)
    xyz = np.full((npts, 3), np.nan)
    xyz_std = np.full((npts, 3), np.nan)
    role = np.full(npts, "tie", dtype=object)
    labels = [str(i) for i in point_ids]
    for pid, (lab, c, sd, r) in ctrl.items():
        i = int(np.searchsorted(point_ids, pid))
        xyz[i], labels[i], role[i] = c, lab, r
        if r == "control":
            xyz_std[i] = sd
    img_index = {int(v): i for i, v in enumerate(image_ids)}
    bad = sorted({int(v) for v in np.unique(obs_im_a)} - set(img_index))
    if bad:
        raise InputError(f"measurements on unknown image id(s) {bad[:10]}", path=path)
    obs_image = np.array([img_index[int(v)] for v in obs_im_a])
    obs_point = np.searchsorted(point_ids, obs_id_a)

    # Prior EO.
    eo = np.full((n, 6), np.nan)
    eo_std = np.full((n, 6), np.nan)
    f = inp.find("prior_eo/file")
    if f is not None:
        p = _resolve(base, _text(f), here)
        t = _read_table(p, f.attrib.get("format", "id,x,y,z,omega,phi,kappa"))
        unit = f.attrib.get("units", "radians")
        scale = {"degrees": np.pi / 180, "gon": np.pi / 200}.get(unit, 1.0)
        for j, c in enumerate(("x", "y", "z", "omega", "phi", "kappa")):
            if c in t:
                vals = _floats(t[c], p, c) * (scale if j >= 3 else 1.0)
                for pid, v in zip(t["id"], vals, strict=True):
                    if int(pid) in img_index:
                        eo[img_index[int(pid)], j] = v

    est_io = np.zeros((len(cams), len(IO_NAMES)), bool)
    est_eo = np.ones((n, 6), bool)
    datum = None
    ref_image = 0
    resect = False
    eo_loaded = f is not None
    for op in root.findall("operations/operation"):
        text = _text(op)
        if text in ("check_ray_count", "forward_intersection", "bundle_adjustment"):
            continue
        if text == "spatial_resection":
            resect = True
            continue
        init = op.find("set_initial_values")
        if init is not None:
            io_el = init.find("io")
            if io_el is not None:
                cams = _apply_io_initial(cams, io_el)
            eo_el = init.find("eo")
            if eo_el is not None and _text(eo_el.find("all")) not in ("loaded", None):
                eo[:] = np.nan
            continue
        est = op.find("set_bundle_estimate_params")
        if est is not None:
            io_el = est.find("io")
            if io_el is not None:
                est_io = _estimate_io_flags(io_el, len(cams))
            eo_el = est.find("eo")
            if eo_el is not None:
                est_eo[:] = (_text(eo_el.find("all")) or _text(eo_el)) == "true"
            continue
        dat = op.find("set_datum")
        if dat is not None:
            datum = _text(dat)
            if datum != "depend":
                raise InputError(f"unsupported datum '{datum}'", path=path)
            ref_id = int(dat.attrib.get("ref_cam", image_ids[0]))
            ref_image = img_index.get(ref_id, 0)
            if dat.attrib.get("ref_base", "longest") != "longest":
                raise InputError("only ref_base='longest' is supported", path=path)
            continue
        if text is not None or len(op):
            tag = text if text else op[0].tag
            raise InputError(f"unknown DBAT script operation '{tag}'", path=path)
    if not eo_loaded and not resect:
        resect = True
    return Project(
        name=name,
        source=str(path),
        cameras=tuple(cams),
        image_ids=image_ids,
        image_names=image_names,
        image_camera=image_camera,
        eo=eo,
        eo_std=eo_std,
        point_ids=point_ids,
        point_labels=tuple(labels),
        xyz=xyz,
        xyz_std=xyz_std,
        point_role=role.astype(str),
        obs_image=obs_image,
        obs_point=obs_point,
        obs_uv_px=np.concatenate(uv),
        obs_std_px=np.concatenate(std),
        estimate_io=est_io,
        estimate_eo=est_eo,
        datum="control" if datum is None and ctrl else datum,
        ref_image=ref_image,
        needs_resection=resect,
        meta={"format": "dbat-script", "image_list": str(im_path)},
    )
