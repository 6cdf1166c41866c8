"""Reader of Agisoft PhotoScan / Metashape projects (``.psz``: a zip of ``doc.xml`` + PLY).

What we take from the archive (first chunk, first frame):

* the sensor (``resolution``, ``pixel_width``/``pixel_height``, the adjusted or
  initial calibration ``fx``, ``cx``, ``cy``, ``k1..k3``, ``p1``, ``p2``);
* the cameras' ``transform`` (camera-to-chunk 4x4) and the chunk's
  ``transform`` (rotation, translation, scale: chunk-to-world), giving initial
  exterior orientations in world coordinates;
* the markers (control points with ``reference`` coordinates and accuracies)
  and their image ``location`` s;
* the tie points (``points*.ply``: chunk coordinates and track id) and their
  projections per camera (``projections*.ply``: x, y in pixels, track id).

Image measurements get the project's accuracies: ``accuracy_projections`` for
markers and ``accuracy_tiepoints`` for tie points (pixels), as DBAT does.

The PhotoScan lens model is a forward (computer-vision) model; projects with
distortion are converted to the backward model by DBAT's first-order rule
(K_i = -k_i / f^(2i), P from p1, p2 swapped and scaled), which is exact only
without distortion (as in the shipped Strasbourg project).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.initial import angles_from_rotation
from pyheracles.bundle.project import Project
from pyheracles.errors import InputError

__all__ = ["read_photoscan"]

_PLY_TYPES = {
    "char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
    "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
    "int32": "i4", "uint32": "u4", "float32": "f4", "float64": "f8",
}  # fmt: skip


def _read_ply_vertices(data: bytes, name: str) -> dict[str, np.ndarray]:
    """Vertex properties of a small PLY (ascii or binary little endian)."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise InputError(f"{name} is not a PLY file")
    header = data[:end].decode("ascii", "replace").splitlines()
    body = data[data.index(b"\n", end) + 1 :]
    fmt = next((h.split()[1] for h in header if h.startswith("format")), "ascii")
    count, props, in_vertex = 0, [], False
    for h in header:
        t = h.split()
        if t[:2] == ["element", "vertex"]:
            count, in_vertex = int(t[2]), True
        elif t and t[0] == "element":
            in_vertex = False
        elif in_vertex and t[0] == "property" and t[1] != "list":
            props.append((t[2], _PLY_TYPES[t[1]]))
    if fmt == "binary_little_endian":
        arr = np.frombuffer(body, dtype=np.dtype([(n, "<" + d) for n, d in props]), count=count)
        return {n: np.asarray(arr[n]) for n, _ in props}
    if fmt == "ascii":
        vals = np.loadtxt(body.decode().splitlines()[:count], ndmin=2)
        return {n: vals[:, i] for i, (n, _) in enumerate(props)}
    raise InputError(f"{name}: unsupported PLY format {fmt}")


def _floats(text: str | None) -> np.ndarray:
    return np.array([float(v) for v in (text or "").split()], float)


def read_photoscan(path: str | Path) -> Project:
    """Read a PhotoScan/Metashape ``.psz`` project.

    Returns
    -------
    Project
        World (georeferenced) coordinates; camera fixed (no interior parameter
        estimated), markers with references as weighted control points (fixed
        when their accuracy is 0), tie points as unknowns, lens model 1.
    """
    path = Path(path)
    try:
        zf = zipfile.ZipFile(path)
        doc = ET.fromstring(zf.read("doc.xml"))
    except (zipfile.BadZipFile, KeyError, OSError, ET.ParseError) as exc:
        raise InputError(
            f"unreadable PhotoScan project ({exc})", path=path, hint="give a .psz archive"
        ) from None
    chunk = doc.find("chunks/chunk")
    if chunk is None:
        chunk = doc.find("chunk")
    if chunk is None:
        raise InputError("no chunk in doc.xml", path=path)
    sensor = chunk.find("sensors/sensor")
    if sensor is None:
        raise InputError("no sensor in doc.xml", path=path)
    res = sensor.find("resolution")
    iw, ih = int(res.get("width")), int(res.get("height"))
    props = {p.get("name"): p.get("value") for p in sensor.findall("property")}
    pw = float(props.get("pixel_width", 1.0))
    ph = float(props.get("pixel_height", pw))
    cals = sensor.findall("calibration")
    cal = next((c for c in cals if c.get("class") == "adjusted"), cals[0] if cals else None)
    if cal is None:
        raise InputError("sensor without calibration", path=path)

    def cnum(tag: str, default: float = 0.0) -> float:
        el = cal.find(tag)
        return float(el.text) if el is not None and el.text else default

    if cal.find("fx") is not None:
        fx, cx, cy = cnum("fx"), cnum("cx"), cnum("cy")
    else:  # newer format: f, and cx, cy relative to the image centre
        fx = cnum("f") + cnum("b1")
        cx, cy = cnum("cx") + iw / 2, cnum("cy") + ih / 2
    focal = fx * pw
    k = [-cnum(f"k{i}") * focal ** (-2 * i) for i in (1, 2, 3)]
    p1, p2 = cnum("p1") / focal, cnum("p2") / focal
    cam = Camera(
        id=1,
        name=sensor.get("label", ""),
        image_size_px=(iw, ih),
        sensor_size_mm=(iw * pw, ih * ph),
        cc_mm=focal,
        pp_mm=(cx * pw, cy * ph),
        k=tuple(k),
        p=(-p2, p1),
        model=1,
        extra={"forward_calibration": {"fx": fx, "cx": cx, "cy": cy}},
    )

    # Chunk-to-world similarity.
    tr = chunk.find("transform")
    rot_w = np.eye(3)
    t_w = np.zeros(3)
    s_w = 1.0
    if tr is not None:
        if tr.find("rotation") is not None:
            rot_w = _floats(tr.findtext("rotation")).reshape(3, 3)
        if tr.find("translation") is not None:
            t_w = _floats(tr.findtext("translation"))
        if tr.find("scale") is not None:
            s_w = float(tr.findtext("scale"))

    def to_world(x: np.ndarray) -> np.ndarray:
        return s_w * x @ rot_w.T + t_w

    # Cameras (enabled and oriented).
    cam_ids, names, eo = [], [], []
    for c in chunk.findall("cameras/camera"):
        t = c.findtext("transform")
        if c.get("enabled", "true") == "false" or not t:
            continue
        m = _floats(t).reshape(4, 4)
        centre = to_world(m[:3, 3][None])[0]
        # PhotoScan cameras look along +z with y down; ours along -z with y up.
        r = rot_w @ m[:3, :3] @ np.diag([1.0, -1.0, -1.0])
        u, _, vt = np.linalg.svd(r)
        r = u @ vt
        cam_ids.append(int(c.get("id")))
        names.append(c.get("label", c.get("id")))
        eo.append(np.concatenate([centre, angles_from_rotation(r)[0]]))
    if not cam_ids:
        raise InputError("no oriented camera in the project", path=path)
    cam_index = {cid: i for i, cid in enumerate(cam_ids)}
    settings = {p.get("name"): float(p.get("value")) for p in chunk.findall("settings/property")}
    std_marker = settings.get("accuracy_projections", 0.1)
    std_tie = settings.get("accuracy_tiepoints", 1.0)

    # Markers: references and image locations.
    ref: dict[int, tuple[str, np.ndarray, np.ndarray, bool]] = {}
    for mk in chunk.findall("markers/marker"):
        r_el = mk.find("reference")
        if r_el is None or r_el.get("x") is None:
            continue
        xyz = np.array([float(r_el.get(a)) for a in "xyz"])
        sxy = float(r_el.get("sxy", settings.get("accuracy_markers", 0.005)))
        sz = float(r_el.get("sz", sxy))
        enabled = r_el.get("enabled", "true") != "false"
        ref[int(mk.get("id"))] = (mk.get("label", mk.get("id")), xyz, np.array([sxy, sxy, sz]),
                                  enabled)  # fmt: skip
    frame = chunk.find("frames/frame")
    if frame is None:
        raise InputError("no frame with measurements in the project", path=path)
    obs_i, obs_id, obs_uv, obs_sd = [], [], [], []
    for mk in frame.findall("markers/marker"):
        mid = int(mk.get("marker_id"))
        for loc in mk.findall("location"):
            cid = int(loc.get("camera_id"))
            if cid in cam_index and loc.get("pinned", "true") != "false":
                obs_i.append(cam_index[cid])
                obs_id.append(mid)
                obs_uv.append([float(loc.get("x")), float(loc.get("y"))])
                obs_sd.append(std_marker)
    # Tie points.
    pc = frame.find("point_cloud")
    tie_xyz: dict[int, np.ndarray] = {}
    offset = (max(ref) + 1) if ref else 0
    offset = int(10 ** np.ceil(np.log10(offset + 1)))
    if pc is not None:
        pts_el = pc.find("points")
        if pts_el is not None:
            v = _read_ply_vertices(zf.read(pts_el.get("path")), pts_el.get("path"))
            xyz_l = np.column_stack([v["x"], v["y"], v["z"]]).astype(float)
            for pid, x in zip(v["id"].astype(int), to_world(xyz_l), strict=True):
                tie_xyz[int(pid) + offset] = x
        for pr in pc.findall("projections"):
            cid = int(pr.get("camera_id"))
            if cid not in cam_index:
                continue
            v = _read_ply_vertices(zf.read(pr.get("path")), pr.get("path"))
            ids = v["id"].astype(int) + offset
            keep = np.isin(ids, list(tie_xyz))
            obs_i.extend([cam_index[cid]] * int(keep.sum()))
            obs_id.extend(ids[keep].tolist())
            obs_uv.extend(np.column_stack([v["x"], v["y"]])[keep].astype(float).tolist())
            obs_sd.extend([std_tie] * int(keep.sum()))
    if not obs_i:
        raise InputError("no image measurements (markers or tie points)", path=path)
    point_ids = np.unique(np.array(obs_id))
    n_pts = len(point_ids)
    xyz = np.full((n_pts, 3), np.nan)
    xyz_std = np.full((n_pts, 3), np.nan)
    role = np.full(n_pts, "tie", dtype=object)
    labels = [str(i) for i in point_ids]
    for mid, (lab, x, sd, enabled) in ref.items():
        j = int(np.searchsorted(point_ids, mid))
        if j < n_pts and point_ids[j] == mid:
            xyz[j], labels[j] = x, lab
            role[j] = "control" if enabled else "check"
            if enabled:
                xyz_std[j] = sd
    for pid, x in tie_xyz.items():
        j = int(np.searchsorted(point_ids, pid))
        if j < n_pts and point_ids[j] == pid:
            xyz[j] = x
    n = len(cam_ids)
    sd = np.asarray(obs_sd, float)
    return Project(
        name=chunk.get("label", path.stem),
        source=str(path),
        cameras=(cam,),
        image_ids=np.asarray(cam_ids) + 1,
        image_names=tuple(names),
        image_camera=np.zeros(n, int),
        eo=np.asarray(eo),
        eo_std=np.full((n, 6), np.nan),
        point_ids=point_ids,
        point_labels=tuple(labels),
        xyz=xyz,
        xyz_std=xyz_std,
        point_role=role.astype(str),
        obs_image=np.asarray(obs_i),
        obs_point=np.searchsorted(point_ids, np.asarray(obs_id)),
        obs_uv_px=np.asarray(obs_uv, float),
        obs_std_px=np.column_stack([sd, sd]),
        estimate_io=np.zeros((1, len(IO_NAMES)), bool),
        estimate_eo=np.ones((n, 6), bool),
        datum="control" if ref else None,
        meta={"format": "photoscan", "tie_id_offset": offset},
    )
