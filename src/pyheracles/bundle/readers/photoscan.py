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

import warnings
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.bundle.initial import angles_from_rotation
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.errors import InputError

__all__ = ["project_from_chunk", "read_photoscan"]

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
    return project_from_chunk(chunk, path, read_member=zf.read, fmt="photoscan")


def _sensor_camera(sensor: ET.Element, cid: int, path: Path) -> Camera:
    """A :class:`Camera` from a ``<sensor>`` (its adjusted calibration, else the initial)."""
    res = sensor.find("resolution")
    if res is None:
        raise InputError(f"sensor {sensor.get('id')} has no <resolution>", path=path)
    iw, ih = int(res.get("width")), int(res.get("height"))
    props = {p.get("name"): p.get("value") for p in sensor.findall("property")}
    pw = float(props.get("pixel_width") or 0.0)
    ph = float(props.get("pixel_height") or 0.0) or pw
    cals = sensor.findall("calibration")
    cal = next((c for c in cals if c.get("class") == "adjusted"), cals[0] if cals else None)
    if cal is None:
        raise InputError(
            f"sensor {sensor.get('id')} has no <calibration>",
            path=path,
            hint="export the cameras after the alignment (Tools > Camera Calibration)",
        )
    if pw <= 0:
        # No metric pixel size: a nominal one (results in pixels do not depend on it).
        pw = ph = 0.005
        warnings.warn(
            f"{path}: sensor {sensor.get('id')} has no pixel size; using a nominal 0.005 mm",
            BundleWarning,
            stacklevel=3,
        )

    def cnum(tag: str, default: float = 0.0) -> float:
        el = cal.find(tag)
        return float(el.text) if el is not None and el.text else default

    b1, b2 = cnum("b1"), cnum("b2")
    if cal.find("fx") is not None:  # PhotoScan 1.x: fx, fy, cx, cy from the corner
        fx, fy = cnum("fx"), cnum("fy", cnum("fx"))
        cx, cy = cnum("cx"), cnum("cy")
    else:  # Metashape: f, b1 (fx = f + b1), b2 (skew), cx, cy from the image centre
        fy = cnum("f")
        fx = fy + b1
        cx, cy = cnum("cx") + iw / 2, cnum("cy") + ih / 2
    if fx <= 0 or fy <= 0:
        raise InputError(f"sensor {sensor.get('id')}: focal length must be > 0", path=path)
    focal = fy * ph
    k = [-cnum(f"k{i}") * focal ** (-2 * i) for i in (1, 2, 3)]
    p1, p2 = cnum("p1") / focal, cnum("p2") / focal
    affine = abs(fx / fy - 1) > 1e-12 or b2 != 0
    return Camera(
        id=cid,
        name=sensor.get("label", ""),
        image_size_px=(iw, ih),
        sensor_size_mm=(iw * pw, ih * ph),
        cc_mm=focal,
        pp_mm=(cx * pw, cy * ph),
        # x_corr = (1 + as) x + sk y reproduces u = cx + (f + b1) x' + b2 y' (model 3).
        aspect_diff=fy / fx - 1.0 if affine else 0.0,
        skew=b2 / fx if affine else 0.0,
        k=tuple(k),
        p=(-p2, p1),
        model=3 if affine else 1,
        extra={"forward_calibration": {"fx": fx, "fy": fy, "cx": cx, "cy": cy}},
    )


def _similarity(el: ET.Element | None) -> np.ndarray:
    """4x4 matrix of a ``<transform>`` with ``rotation``/``translation``/``scale``
    children (identity when absent)."""
    m = np.eye(4)
    if el is None:
        return m
    if el.find("rotation") is not None:
        m[:3, :3] = _floats(el.findtext("rotation")).reshape(3, 3)
    if el.find("scale") is not None:
        m[:3, :3] *= float(el.findtext("scale"))
    if el.find("translation") is not None:
        m[:3, 3] = _floats(el.findtext("translation"))
    return m


def _marker_locations(chunk: ET.Element) -> list[tuple[int, ET.Element]]:
    """(marker id, <location>) pairs: in the first frame (projects, exports) or in
    the markers themselves."""
    out = []
    frame = chunk.find("frames/frame")
    if frame is not None:
        for mk in frame.findall("markers/marker"):
            out.extend((int(mk.get("marker_id")), loc) for loc in mk.findall("location"))
    for mk in chunk.findall("markers/marker"):
        out.extend((int(mk.get("id")), loc) for loc in mk.findall("location"))
    return out


def project_from_chunk(
    chunk: ET.Element,
    path: Path,
    read_member: Callable[[str], bytes] | None = None,
    fmt: str = "photoscan",
) -> Project:
    """A :class:`Project` from an Agisoft ``<chunk>`` (project ``doc.xml`` or camera export).

    Parameters
    ----------
    chunk
        The chunk element: sensors, components, cameras, markers, frames.
    path
        The file it came from (for messages).
    read_member
        Reads a member of the project archive (tie point PLY files); None for a
        camera export, which has no tie points.
    fmt
        Format name recorded in ``Project.meta``.
    """
    sensors = chunk.findall("sensors/sensor")
    if not sensors:
        raise InputError("no sensor in the chunk", path=path)
    sensor_index = {int(s.get("id", k)): k for k, s in enumerate(sensors)}
    cams = tuple(_sensor_camera(s, k + 1, path) for k, s in enumerate(sensors))
    # Chunk-to-world similarity and component-to-chunk transforms (Metashape >= 1.6).
    chunk_t = _similarity(chunk.find("transform"))
    s_w = (
        float(np.cbrt(np.linalg.det(chunk_t[:3, :3])))
        if chunk.find("transform") is not None
        else 1.0
    )
    rot_w = chunk_t[:3, :3] / s_w
    comps = {int(c.get("id")): _similarity(c.find("transform"))
             for c in chunk.findall("components/component")}  # fmt: skip

    def to_world(x: np.ndarray) -> np.ndarray:
        return x @ chunk_t[:3, :3].T + chunk_t[:3, 3]

    cam_ids, names, eo, cam_of, skipped = [], [], [], [], []
    for c in chunk.findall("cameras/camera"):
        t = c.findtext("transform")
        if c.get("enabled", "true") == "false" or not t:
            skipped.append(c.get("label", c.get("id")))
            continue
        m = _floats(t).reshape(4, 4)
        if c.get("component_id") is not None and int(c.get("component_id")) in comps:
            m = comps[int(c.get("component_id"))] @ m
        sid = int(c.get("sensor_id", sensors[0].get("id", 0)))
        if sid not in sensor_index:
            raise InputError(f"camera {c.get('id')} uses unknown sensor {sid}", path=path)
        centre = to_world(m[:3, 3][None])[0]
        # Agisoft cameras look along +z with y down; ours along -z with y up.
        r = rot_w @ m[:3, :3] @ np.diag([1.0, -1.0, -1.0])
        u, _, vt = np.linalg.svd(r)
        r = u @ vt
        cam_ids.append(int(c.get("id")))
        names.append(c.get("label", c.get("id")))
        cam_of.append(sensor_index[sid])
        eo.append(np.concatenate([centre, angles_from_rotation(r)[0]]))
    if not cam_ids:
        raise InputError(
            "no oriented camera in the project",
            path=path,
            hint="align the photos before exporting",
        )
    if skipped:
        warnings.warn(
            f"{path}: {len(skipped)} camera(s) disabled or not aligned, left out: {skipped[:10]}",
            BundleWarning,
            stacklevel=2,
        )
    cam_index = {cid: i for i, cid in enumerate(cam_ids)}
    settings = {p.get("name"): float(p.get("value")) for p in chunk.findall("settings/property")
                if _is_number(p.get("value"))}  # fmt: skip
    std_marker = settings.get("accuracy_projections", 0.1)
    std_tie = settings.get("accuracy_tiepoints", 1.0)

    # Markers: references and image locations.
    ref: dict[int, tuple[str, np.ndarray, np.ndarray, bool]] = {}
    labels_of: dict[int, str] = {}
    for mk in chunk.findall("markers/marker"):
        labels_of[int(mk.get("id"))] = mk.get("label", mk.get("id"))
        r_el = mk.find("reference")
        if r_el is None or r_el.get("x") is None:
            continue
        xyz = np.array([float(r_el.get(a)) for a in "xyz"])
        default = settings.get("accuracy_markers", 0.005)
        sxy = float(r_el.get("sxy", default))
        sd = np.array([float(r_el.get("sx", sxy)), float(r_el.get("sy", sxy)),
                       float(r_el.get("sz", sxy))])  # fmt: skip
        enabled = r_el.get("enabled", "true") != "false"
        ref[int(mk.get("id"))] = (labels_of[int(mk.get("id"))], xyz, sd, enabled)
    obs_i, obs_id, obs_uv, obs_sd = [], [], [], []
    for mid, loc in _marker_locations(chunk):
        cid = int(loc.get("camera_id"))
        if cid in cam_index and loc.get("pinned", "true") != "false":
            obs_i.append(cam_index[cid])
            obs_id.append(mid)
            obs_uv.append([float(loc.get("x")), float(loc.get("y"))])
            obs_sd.append(std_marker)
    # Tie points (project archives only).
    frame = chunk.find("frames/frame")
    pc = frame.find("point_cloud") if frame is not None else None
    tie_xyz: dict[int, np.ndarray] = {}
    offset = (max(ref) + 1) if ref else 0
    offset = int(10 ** np.ceil(np.log10(offset + 1)))
    if pc is not None and read_member is not None:
        pts_el = pc.find("points")
        if pts_el is not None:
            v = _read_ply_vertices(read_member(pts_el.get("path")), pts_el.get("path"))
            xyz_l = np.column_stack([v["x"], v["y"], v["z"]]).astype(float)
            for pid, x in zip(v["id"].astype(int), to_world(xyz_l), strict=True):
                tie_xyz[int(pid) + offset] = x
        for pr in pc.findall("projections"):
            cid = int(pr.get("camera_id"))
            if cid not in cam_index:
                continue
            v = _read_ply_vertices(read_member(pr.get("path")), pr.get("path"))
            ids = v["id"].astype(int) + offset
            keep = np.isin(ids, list(tie_xyz))
            obs_i.extend([cam_index[cid]] * int(keep.sum()))
            obs_id.extend(ids[keep].tolist())
            obs_uv.extend(np.column_stack([v["x"], v["y"]])[keep].astype(float).tolist())
            obs_sd.extend([std_tie] * int(keep.sum()))
    if not obs_i:
        raise InputError(
            "no image measurements (markers or tie points)",
            path=path,
            hint="export the cameras with their markers' projections, or give the .psz project",
        )
    point_ids = np.unique(np.array(obs_id))
    n_pts = len(point_ids)
    xyz = np.full((n_pts, 3), np.nan)
    xyz_std = np.full((n_pts, 3), np.nan)
    role = np.full(n_pts, "tie", dtype=object)
    labels = [labels_of.get(int(i), str(i)) for i in point_ids]
    unseen = [lab for mid, (lab, *_r) in ref.items() if mid not in set(point_ids.tolist())]
    if unseen:
        warnings.warn(
            f"{path}: {len(unseen)} marker(s) with a reference but no image measurement, "
            f"left out: {unseen[:10]}",
            BundleWarning,
            stacklevel=2,
        )
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
        cameras=cams,
        image_ids=np.asarray(cam_ids) + 1,
        image_names=tuple(names),
        image_camera=np.asarray(cam_of, int),
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
        estimate_io=np.zeros((len(cams), len(IO_NAMES)), bool),
        estimate_eo=np.ones((n, 6), bool),
        datum="control" if ref else None,
        meta={"format": fmt, "tie_id_offset": offset},
    )


def _is_number(v: str | None) -> bool:
    try:
        float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    return True
