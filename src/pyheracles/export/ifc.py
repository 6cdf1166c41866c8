"""IFC 4 export of step-2 results (supports, beams, walls) with ifcopenshell (extra ``bim``).

:func:`export_ifc` reads an output folder of ``heracles supports``, ``heracles beams``
or ``heracles walls`` (its objects table, ``segmented.laz`` and ``walls.json``) and
writes one IFC 4 model:

* IfcProject > IfcSite > IfcBuilding (one per step-1 object with its GIS attributes
  in the property set ``Heracles_GIS`` when a step-1 folder is given, else one);
  the site is georeferenced with IfcMapConversion + IfcProjectedCRS from the
  cloud's CRS (the model's origin is the cloud's offset; no CRS: a local model and
  a note).
* Columns: IfcColumn (COLUMN) with an extruded circle along the fitted axis, or,
  when the radius measured along the axis changes (taper, entasis), a solid of
  revolution of the measured radii (:func:`radius_profile`); a fluted shaft as a
  closed face set of its measured flutes (:mod:`pyheracles.export.flutes`: their
  number and depth in the property set) on those radii; the plinth / base and
  capital / abacus bands of the objects table (``base_top_m``, ``capital_bottom_m``)
  as further body items, slabs of the outline their points reach per layer
  (:func:`part_slabs`), on piers too;
  engaged columns: IfcColumn PILASTER; piers: IfcColumn with an extruded rectangle
  (orientation from the pier's points).
* Beams: IfcBeam (within 10 deg of horizontal) or IfcMember (BRACE when inclined,
  POST when within 10 deg of vertical) with an extruded rectangle along the fitted
  axis, the section turned as the beam's points.
* Walls: IfcWall with its outline on its plane extruded over its thickness (a wall
  seen on one face gets ``assumed_thickness_m``, said in its property set), its
  windows and doors as IfcOpeningElement voids.

Every element carries ``Heracles_Provenance``: instance id, point count, fit RMS,
faces seen, tilt (or inclination) in degrees, and what its dimensions are.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pyheracles.errors import InputError
from pyheracles.export.element_shapes import (
    axis_base,
    part_slabs,
    radius_profile,
    section_roll,
)
from pyheracles.export.flutes import Flutes, fluted_shaft_mesh, measure_flutes

__all__ = ["IfcReport", "export_ifc", "export_ifc_folders", "read_result_folder"]

#: IFC 4 class and predefined type per member role of the frame analysis
#: (:data:`pyheracles.beams.roles.ROLES`); loose timber is kept, as a plain member.
ROLE_TO_IFC = {
    "tie": ("IfcBeam", "BEAM"),
    "ridge": ("IfcBeam", "BEAM"),
    "rafter": ("IfcMember", "RAFTER"),
    "common_rafter": ("IfcMember", "RAFTER"),
    "post": ("IfcMember", "POST"),
    "strut": ("IfcMember", "STRUT"),
    "collar": ("IfcMember", "COLLAR"),
    "purlin": ("IfcMember", "PURLIN"),
    "plate": ("IfcMember", "PLATE"),
    "brace": ("IfcMember", "BRACE"),
    "loose": ("IfcMember", "MEMBER"),
}
#: Objects-table columns of the frame analysis copied into a member's property set.
FRAME_FIELDS = ("role", "in_frame", "component", "n_joints", "deflection_mm", "twist_deg",
                "height_measured")  # fmt: skip

#: Objects-table columns of a support copied into its property set (inclination, parts).
PART_FIELDS = ("lean_m", "lean_azimuth_deg", "radius_bottom_m", "radius_top_m",
               "radius_height_m", "base_top_m", "capital_bottom_m")  # fmt: skip

Array = np.ndarray


@dataclass
class IfcReport:
    """What :func:`export_ifc` wrote: elements per IFC class, notes."""

    path: Path
    elements: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    guids: dict[int, str] = field(default_factory=dict)


def _require_ifcopenshell() -> Any:
    try:
        import ifcopenshell
    except ImportError as exc:  # pragma: no cover - extra missing
        raise InputError(
            "IFC export needs ifcopenshell",
            hint="pip install 'pyheracles[bim]' (or pip install ifcopenshell)",
        ) from exc
    return ifcopenshell


def read_result_folder(folder: str | Path) -> tuple[str, pd.DataFrame, Any]:
    """(step, objects table, cloud) of a step-2 output folder."""
    from pyheracles.io import read_cloud

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("not a result folder", path=folder, hint="give an output folder")
    run = folder / "run.json"
    step = ""
    if run.exists():
        step = str(json.loads(run.read_text(encoding="utf-8")).get("step", ""))
    table_path = next((folder / n for n in ("objects.csv", "objects.gpkg")
                       if (folder / n).exists()), None)  # fmt: skip
    if table_path is None or not (folder / "segmented.laz").exists():
        raise InputError(
            "no objects table and segmented.laz",
            path=folder,
            hint="give the output folder of heracles supports, beams or walls",
        )
    if table_path.suffix == ".csv":
        objects = pd.read_csv(table_path)
    else:
        from pyheracles.io.vector import read_layer

        objects = pd.DataFrame(read_layer(table_path, "objects")).drop(
            columns=["geometry"], errors="ignore"
        )
    if step not in ("supports", "beams", "walls"):
        cols = set(objects.columns)
        step = ("walls" if "n_faces" in cols else "beams" if "inclination_deg" in cols
                else "supports" if "radius_m" in cols else step)  # fmt: skip
    if step not in ("supports", "beams", "walls"):
        raise InputError(
            f"cannot export a {step or 'unknown'!r} result to IFC",
            path=folder,
            hint="give the output folder of heracles supports, beams or walls",
        )
    cloud = read_cloud(folder / "segmented.laz")
    return step, objects, cloud


class _Writer:
    """Small helpers over an ifcopenshell file (IFC4, metres)."""

    def __init__(self, name: str) -> None:
        _require_ifcopenshell()
        import ifcopenshell.api

        self.api = ifcopenshell.api
        self.f = ifcopenshell.api.run("project.create_file", version="IFC4")
        self.project = self.run("root.create_entity", ifc_class="IfcProject", name=name)
        units = [
            self.run("unit.add_si_unit", unit_type=t)  # metres, no prefix
            for t in ("LENGTHUNIT", "AREAUNIT", "VOLUMEUNIT", "PLANEANGLEUNIT")
        ]
        self.run("unit.assign_unit", units=units)
        self.model = self.run("context.add_context", context_type="Model")
        self.body = self.run("context.add_context", context_type="Model",
                             context_identifier="Body", target_view="MODEL_VIEW",
                             parent=self.model)  # fmt: skip

    def run(self, usecase: str, **kw: Any) -> Any:
        return self.api.run(usecase, self.f, **kw)

    def point(self, p: Any) -> Any:
        return self.f.createIfcCartesianPoint([float(v) for v in p])

    def direction(self, d: Any) -> Any:
        d = np.asarray(d, dtype=np.float64)
        return self.f.createIfcDirection([float(v) for v in d / np.linalg.norm(d)])

    def placement(self, origin: Any, z: Any, x: Any, rel: Any = None) -> Any:
        z = np.asarray(z, dtype=np.float64)
        z = z / np.linalg.norm(z)
        x = np.asarray(x, dtype=np.float64)
        x = x - (x @ z) * z
        ax = self.f.createIfcAxis2Placement3D(self.point(origin), self.direction(z),
                                              self.direction(x))  # fmt: skip
        return self.f.createIfcLocalPlacement(rel, ax)

    def solid(self, profile: Any, depth: float, start: float = 0.0) -> Any:
        pos = self.f.createIfcAxis2Placement3D(self.point((0.0, 0.0, start)), None, None)
        return self.f.createIfcExtrudedAreaSolid(profile, pos, self.direction((0, 0, 1)),
                                                 float(depth))  # fmt: skip

    def revolved(self, profile: Array) -> Any:
        """Solid of revolution about the local z axis of (radius, height) stations."""
        ring = [(0.0, float(profile[0, 1])), *map(tuple, profile), (0.0, float(profile[-1, 1]))]
        pts = [self.f.createIfcCartesianPoint([float(a), float(b)]) for a, b in ring]
        area = self.f.createIfcArbitraryClosedProfileDef(
            "AREA", None, self.f.createIfcPolyline([*pts, pts[0]])
        )
        # the profile's plane is the element's x-z plane: its y becomes the column axis
        pos = self.f.createIfcAxis2Placement3D(self.point((0.0, 0.0, 0.0)),
                                               self.direction((0, -1, 0)),
                                               self.direction((1, 0, 0)))  # fmt: skip
        axis = self.f.createIfcAxis1Placement(self.point((0.0, 0.0, 0.0)),
                                              self.direction((0, 1, 0)))  # fmt: skip
        return self.f.createIfcRevolvedAreaSolid(area, pos, axis, 2 * math.pi)

    def shape(self, solids: list[Any], kind: str = "SweptSolid") -> Any:
        rep = self.f.createIfcShapeRepresentation(self.body, "Body", kind, solids)
        return self.f.createIfcProductDefinitionShape(None, None, [rep])

    def faceset(self, verts: Array, faces: list[list[int]]) -> Any:
        """A closed IfcPolygonalFaceSet of ``verts`` and 0-based polygon ``faces``."""
        coords = self.f.createIfcCartesianPointList3D([[float(v) for v in p] for p in verts])
        polys = [self.f.createIfcIndexedPolygonalFace([int(i) + 1 for i in face])
                 for face in faces]  # fmt: skip
        return self.f.createIfcPolygonalFaceSet(coords, True, polys, None)

    def prism_faceset(self, ring: Array, t0: float, t1: float) -> Any:
        """A slab (a polygon ``ring`` extruded from ``t0`` to ``t1``) as a face set."""
        ring = np.asarray(ring, dtype=np.float64)
        x, y = ring[:, 0], ring[:, 1]
        if float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) < 0:
            ring = ring[::-1]  # counter-clockwise, so that the faces point outwards
        m = len(ring)
        verts = np.vstack([np.c_[ring, np.full(m, t0)], np.c_[ring, np.full(m, t1)]])
        faces = [[j, (j + 1) % m, m + (j + 1) % m, m + j] for j in range(m)]
        faces += [list(range(m - 1, -1, -1)), list(range(m, 2 * m))]
        return self.faceset(verts, faces)

    def profile_2d(self) -> Any:
        return self.f.createIfcAxis2Placement2D(self.f.createIfcCartesianPoint([0.0, 0.0]),
                                                None)  # fmt: skip

    def rectangle(self, x: float, y: float) -> Any:
        return self.f.createIfcRectangleProfileDef("AREA", None, self.profile_2d(),
                                                   float(x), float(y))  # fmt: skip

    def circle(self, r: float) -> Any:
        return self.f.createIfcCircleProfileDef("AREA", None, self.profile_2d(), float(r))

    def polygon(self, ring: Array) -> Any:
        pts = [self.f.createIfcCartesianPoint([float(a), float(b)]) for a, b in ring]
        pts.append(pts[0])
        return self.f.createIfcArbitraryClosedProfileDef(
            "AREA", None, self.f.createIfcPolyline(pts)
        )

    def element(self, ifc_class: str, name: str, placement: Any, shape: Any,
                predefined: str | None, container: Any) -> Any:  # fmt: skip
        el = self.run("root.create_entity", ifc_class=ifc_class, name=name,
                      predefined_type=predefined)  # fmt: skip
        el.ObjectPlacement = placement
        el.Representation = shape
        self.run("spatial.assign_container", products=[el], relating_structure=container)
        return el

    def pset(self, product: Any, name: str, props: dict[str, Any]) -> None:
        clean = {}
        for k, v in props.items():
            if v is None or (isinstance(v, float) and not math.isfinite(v)):
                continue
            if isinstance(v, np.generic):
                v = v.item()
            clean[k] = v
        pset = self.run("pset.add_pset", product=product, name=name)
        self.run("pset.edit_pset", pset=pset, properties=clean)


def _georeference(w: _Writer, crs: Any, offset: Array, notes: list[str]) -> None:
    if crs is None:
        notes.append("the cloud has no CRS: the model is in a local frame (no IfcMapConversion)")
        return
    from pyproj import CRS

    c = CRS.from_user_input(crs)
    epsg = c.to_epsg()
    name = f"EPSG:{epsg}" if epsg else c.name
    if not c.is_projected:
        notes.append(f"the CRS {name} is not projected: IfcProjectedCRS written as given")
    datum = c.datum.name if c.datum is not None else None
    target = w.f.createIfcProjectedCRS(Name=name, Description=c.name, GeodeticDatum=datum)
    w.f.createIfcMapConversion(
        SourceCRS=w.model, TargetCRS=target, Eastings=float(offset[0]),
        Northings=float(offset[1]), OrthogonalHeight=float(offset[2]),
        XAxisAbscissa=1.0, XAxisOrdinate=0.0, Scale=1.0,
    )  # fmt: skip


def _points_of(cloud: Any, instance: int) -> Array:
    inst = np.asarray(cloud.attributes.get("instance", np.zeros(len(cloud.xyz))))
    return cloud.xyz[inst == instance]


def _unit(v: Array) -> Array | None:
    v = np.asarray(v, dtype=np.float64)
    n = float(np.linalg.norm(v))
    return None if not math.isfinite(n) or n == 0 else v / n


def _band_items(w: _Writer, local: Array, base_top: float, cap_bottom: float, length: float,
                noise: float, layer_m: float = 0.03,
                faceted: bool = False) -> list[Any]:  # fmt: skip
    """Extruded slabs of a support's base and capital bands (:func:`part_slabs`);
    ``faceted``: as closed face sets (in a body whose shaft is one)."""
    items = []
    t = local[:, 2] if len(local) else np.zeros(1)
    bands = []
    if math.isfinite(base_top):
        bands.append((min(float(t.min()), 0.0) - layer_m, base_top + layer_m))
    if math.isfinite(cap_bottom):
        bands.append((cap_bottom - layer_m, max(float(t.max()), length) + layer_m))
    for lo, hi in bands:
        for ring, t0, t1 in part_slabs(local, lo, hi, noise=noise, layer_m=layer_m):
            items.append(w.prism_faceset(ring, t0, t1) if faceted
                         else w.solid(w.polygon(ring), t1 - t0, t0))  # fmt: skip
    return items


def _shaft_flutes(local: Array, stations: Array, base_top: float,
                  cap_bottom: float) -> Flutes | None:  # fmt: skip
    """Flutes of a column's shaft (:func:`measure_flutes`) from its points between the
    base and capital bands (the whole height where the table has none), about the
    smooth radius of ``stations`` (radius, height along the axis)."""
    t = local[:, 2]
    lo = base_top if math.isfinite(base_top) else -np.inf
    hi = cap_bottom if math.isfinite(cap_bottom) else np.inf
    shaft = local[(t > lo) & (t < hi)]
    return measure_flutes(shaft, np.interp(shaft[:, 2], stations[:, 1], stations[:, 0]))


def _local(pts: Array, base: Array, axis: Array, x: Array) -> Array:
    """Points in an element frame: origin ``base``, z ``axis``, x ``x`` (made orthogonal)."""
    z = axis / np.linalg.norm(axis)
    xh = x - (x @ z) * z
    xh = xh / np.linalg.norm(xh)
    rel = pts - base
    return np.c_[rel @ xh, rel @ np.cross(z, xh), rel @ z]


def _supports(w: _Writer, objects: pd.DataFrame, cloud: Any, container: Any,
              rep: IfcReport) -> None:  # fmt: skip
    off = np.asarray(cloud.offset, dtype=np.float64)
    for _, r in objects.iterrows():
        inst, cls = int(r["instance"]), str(r["class"])
        if cls not in ("column", "pier", "engaged_column"):
            continue
        base = np.array([r["x"], r["y"], r["z_min"]], dtype=np.float64) - off
        xy = base[:2]
        height = float(r.get("box_height_m", np.nan)) if cls == "pier" else np.nan
        if not math.isfinite(height):
            height = float(r["height_m"])
        pts = _points_of(cloud, inst)
        base_top = float(r.get("base_top_m", np.nan))
        cap_bottom = float(r.get("capital_bottom_m", np.nan))
        noise = min(float(r["fit_rms_m"]), 0.01) if math.isfinite(float(r["fit_rms_m"])) else 0.005
        if cls == "pier":
            length, width = float(r["box_length_m"]), float(r["box_width_m"])
            if not (math.isfinite(length) and math.isfinite(width)):
                rep.notes.append(f"support {inst}: no box fitted, not written")
                continue
            a = section_roll(pts[:, :2] - base[:2], length, width)  # plan angle of the length
            xdir = np.array([math.cos(a), math.sin(a), 0.0])
            place = w.placement(base, (0, 0, 1), xdir)
            items = [w.solid(w.rectangle(length, width), height)]
            if math.isfinite(base_top) or math.isfinite(cap_bottom):
                loc = _local(pts, base, np.array([0.0, 0.0, 1.0]), xdir)
                items += _band_items(w, loc, base_top, cap_bottom, height, noise)
            shape = w.shape(items)
            predefined, dims = "COLUMN", {"length_m": length, "width_m": width}
            tilt = 0.0
        else:
            radius = float(r["radius_m"])
            axis = _unit([r["axis_x"], r["axis_y"], r["axis_z"]])
            if not math.isfinite(radius) or axis is None:
                rep.notes.append(f"support {inst}: no cylinder fitted, not written")
                continue
            axis = axis if axis[2] >= 0 else -axis
            base = axis_base(pts, xy, axis, radius, float(base[2]))
            tilt = math.degrees(math.acos(min(1.0, abs(float(axis[2])))))
            x = np.cross(axis, [0.0, 1.0, 0.0]) if abs(axis[0]) < 0.9 else np.cross(axis, [0, 0, 1])
            place = w.placement(base, axis, x)
            length = height / max(abs(axis[2]), 1e-6)
            at = float(r.get("radius_height_m", np.nan)) / max(abs(float(axis[2])), 1e-6)
            profile = radius_profile(pts, base, axis, length, radius=radius, at=at)
            predefined = "PILASTER" if cls == "engaged_column" else "COLUMN"
            dims = {"radius_m": radius}
            # table heights are z of the axis above z_min: along the axis / axis_z
            az = max(abs(float(axis[2])), 1e-6)
            loc = _local(pts, base, axis, x)
            stations = (np.array([[radius, 0.0], [radius, length]]) if profile is None
                        else profile)  # fmt: skip
            flutes = _shaft_flutes(loc, stations, base_top / az, cap_bottom / az)
            # the shaft first (its dimensions are the table's), then base and capital slabs
            if flutes is not None:
                items = [w.faceset(*fluted_shaft_mesh(flutes, stations))]
                dims |= {"flutes": flutes.count, "flute_depth_m": flutes.depth_m}
            else:
                items = [w.solid(w.circle(radius), length) if profile is None
                         else w.revolved(profile)]  # fmt: skip
            if math.isfinite(base_top) or math.isfinite(cap_bottom):
                items += _band_items(w, loc, base_top / az, cap_bottom / az, length, noise,
                                     faceted=flutes is not None)  # fmt: skip
            shape = w.shape(items, "SweptSolid" if flutes is None else "Tessellation")
            if profile is not None:  # taper or entasis: the measured radii revolved
                dims |= {
                    "radius_base_m": float(profile[0, 0]),
                    "radius_top_m": float(profile[-1, 0]),
                    "profile": ("fluted face set" if flutes is not None else "revolved")
                    + f", radii measured at {len(profile)} stations",
                }
        el = w.element("IfcColumn", f"{cls} {inst}", place, shape, predefined, container)
        w.pset(el, "Heracles_Provenance", {
            "instance": inst, "class": cls, "n_points": int(r["n_points"]),
            "fit_rms_m": float(r["fit_rms_m"]), "faces_seen": "all round" if
            cls == "column" else "partly (engaged)" if cls == "engaged_column" else "sides",
            "tilt_deg": tilt, "height_m": height, **dims,
            **{k: float(r[k]) for k in PART_FIELDS if k in r.index},
            "circularity": float(r.get("circularity", np.nan)),
        })  # fmt: skip
        rep.guids[inst] = el.GlobalId
        rep.elements["IfcColumn"] = rep.elements.get("IfcColumn", 0) + 1


def _beams(w: _Writer, objects: pd.DataFrame, cloud: Any, container: Any,
           rep: IfcReport) -> None:  # fmt: skip
    off = np.asarray(cloud.offset, dtype=np.float64)
    for _, r in objects.iterrows():
        inst = int(r["instance"])
        axis = _unit([r["axis_x"], r["axis_y"], r["axis_z"]])
        length, width, height = (float(r[k]) for k in ("length_m", "width_m", "height_m"))
        if axis is None or not all(math.isfinite(v) for v in (length, width, height)):
            rep.notes.append(f"beam {inst}: no cuboid fitted, not written")
            continue
        centre = np.array([r["centre_x"], r["centre_y"], r["centre_z"]], dtype=np.float64)
        centre -= off
        incl = float(r.get("inclination_deg", math.degrees(math.asin(min(1, abs(axis[2]))))))
        # the section's width direction: the points' spread across the axis
        pts = _points_of(cloud, inst)
        helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0, 0])
        e1 = np.cross(helper, axis)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        q = pts - centre
        roll = section_roll(np.c_[q @ e1, q @ e2], width, height)
        xdir = math.cos(roll) * e1 + math.sin(roll) * e2  # the profile's x: the width
        place = w.placement(centre - 0.5 * length * axis, axis, xdir)
        shape = w.shape([w.solid(w.rectangle(width, height), length)])
        role = str(r.get("role", ""))
        if role in ROLE_TO_IFC:  # the frame analysis named it (heracles beams, frame.json)
            cls, predefined = ROLE_TO_IFC[role]
        elif incl <= 10.0:
            cls, predefined = "IfcBeam", "BEAM"
        elif incl >= 80.0:
            cls, predefined = "IfcMember", "POST"
        else:
            cls, predefined = "IfcMember", "BRACE"
        el = w.element(cls, f"beam {inst}", place, shape, predefined, container)
        seen = r.get("faces_seen")
        w.pset(el, "Heracles_Provenance", {
            "instance": inst, "class": str(r["class"]), "n_points": int(r["n_points"]),
            "fit_rms_m": float(r["rms_m"]), "n_facets": int(r.get("n_facets", 0)),
            "faces_seen": int(seen) if seen is not None and seen == seen and seen > 0 else None,
            "inclination_deg": incl, "length_m": length, "width_m": width,
            "height_m": height,
            **{k: r[k] for k in FRAME_FIELDS if k in r.index},
        })  # fmt: skip
        rep.guids[inst] = el.GlobalId
        rep.elements[cls] = rep.elements.get(cls, 0) + 1


def _walls(w: _Writer, folder: Path, cloud: Any, container: Any, rep: IfcReport) -> None:
    path = folder / "walls.json"
    if not path.exists():
        raise InputError("no walls.json", path=folder, hint="rerun heracles walls")
    doc = json.loads(path.read_text(encoding="utf-8"))
    off = np.asarray(cloud.offset, dtype=np.float64)
    for j in doc.get("walls", []):
        inst = int(j["instance"])
        n = np.asarray(j["normal"], dtype=np.float64)
        u = np.asarray(j["u_axis"], dtype=np.float64)
        origin = np.asarray(j["origin"], dtype=np.float64) - off
        measured = bool(j["thickness_measured"])
        t = float(j["thickness_m"]) if measured else float(j["assumed_thickness_m"])
        side = int(j.get("material_side", 0))
        start = -0.5 * t if measured or side == 0 else (0.0 if side > 0 else -t)
        ring = np.asarray(j["outline_uz"], dtype=np.float64) - [0.0, off[2]]
        place = w.placement(origin, n, u)
        shape = w.shape([w.solid(w.polygon(ring), t, start)])
        el = w.element("IfcWall", f"wall {inst}", place, shape, "SOLIDWALL", container)
        tilt = math.degrees(math.asin(min(1.0, abs(float(n[2])))))
        w.pset(el, "Heracles_Provenance", {
            "instance": inst, "class": "wall", "n_points": int(j["n_points"]),
            "fit_rms_m": float(j["fit_rms_m"]), "faces_seen": len(j["faces"]),
            "tilt_deg": tilt, "thickness_m": t, "thickness_measured": measured,
            "length_m": float(j["length_m"]), "height_m": float(j["height_m"]),
            "n_openings": len(j["openings"]),
        })  # fmt: skip
        for k, o in enumerate(j["openings"], start=1):
            poly = np.asarray(o["polygon_uz"], dtype=np.float64) - [0.0, off[2]]
            op_shape = w.shape([w.solid(w.polygon(poly), t + 0.2, start - 0.1)])
            opening = w.run("root.create_entity", ifc_class="IfcOpeningElement",
                            name=f"wall {inst} {o['kind']} {k}",
                            predefined_type="OPENING")  # fmt: skip
            opening.ObjectPlacement = w.placement(origin, n, u)
            opening.Representation = op_shape
            try:
                w.run("feature.add_feature", feature=opening, element=el)
            except Exception:  # pragma: no cover - older ifcopenshell
                w.run("void.add_opening", opening=opening, element=el)
            w.pset(opening, "Heracles_Opening", {
                "kind": str(o["kind"]), "width_m": float(o["width_m"]),
                "height_m": float(o["height_m"]),
            })  # fmt: skip
            rep.elements["IfcOpeningElement"] = rep.elements.get("IfcOpeningElement", 0) + 1
        rep.guids[inst] = el.GlobalId
        rep.elements["IfcWall"] = rep.elements.get("IfcWall", 0) + 1


def _buildings(w: _Writer, site: Any, step1: str | Path | None,
               rep: IfcReport) -> list[tuple[Any, Any, int | None]]:  # fmt: skip
    """(IfcBuilding, footprint or None, step-1 instance or None) triples."""
    if step1 is None:
        b = w.run("root.create_entity", ifc_class="IfcBuilding", name="building")
        w.run("aggregate.assign_object", products=[b], relating_object=site)
        return [(b, None, None)]
    from pyheracles.io.vector import read_layer

    path = Path(step1) / "objects.gpkg"
    if not path.exists():
        raise InputError("no objects.gpkg", path=step1, hint="give a heracles complex folder")
    layer = read_layer(path, "objects")
    out = []
    for _, row in layer.iterrows():
        name = str(row.get("name", "") or f"object {row.get('instance', len(out) + 1)}")
        b = w.run("root.create_entity", ifc_class="IfcBuilding", name=name)
        w.run("aggregate.assign_object", products=[b], relating_object=site)
        geom = layer.geometry.name
        props = {str(k): (v if isinstance(v, bool | int | float | str) else str(v))
                 for k, v in row.items() if k != geom and not pd.isna(v)}  # fmt: skip
        w.pset(b, "Heracles_GIS", props)
        inst = row.get("instance")
        out.append((b, row.geometry, None if pd.isna(inst) else int(inst)))
    if not out:
        rep.notes.append(f"{path} has no objects: one building written")
        return _buildings(w, site, None, rep)
    return out


def _container(buildings: list[tuple[Any, Any, int | None]], objects: pd.DataFrame,
               instance: int | None) -> Any:  # fmt: skip
    """The building of a result: by its step-1 instance, else the footprint holding it."""
    import shapely

    for b, _, inst in buildings:
        if instance is not None and inst == instance:
            return b
    if len(buildings) > 1 and len(objects):
        xy = np.c_[objects.get("x", objects.get("centre_x", 0)),
                   objects.get("y", objects.get("centre_y", 0))]  # fmt: skip
        centre = shapely.Point(np.nanmean(xy, axis=0))
        for b, fp, _ in buildings:
            if fp is not None and fp.contains(centre):
                return b
    return buildings[0][0]


def export_ifc(result_dir: str | Path, out: str | Path, *, step1_dir: str | Path | None = None,
               name: str | None = None) -> IfcReport:  # fmt: skip
    """Write the elements of a step-2 output folder as an IFC 4 model.

    Parameters
    ----------
    result_dir
        Output folder of ``heracles supports``, ``heracles beams`` or ``heracles walls``.
    out
        IFC file to write (atomically).
    step1_dir
        Optional ``heracles complex`` folder: one IfcBuilding per object, its GIS
        attributes in ``Heracles_GIS``; elements go into the building whose footprint
        holds them.

    Returns
    -------
    IfcReport
    """
    return export_ifc_folders([(result_dir, None)], out, step1_dir=step1_dir,
                              name=name or f"pyheracles: {Path(result_dir).name}")  # fmt: skip


def export_ifc_folders(
    parts: list[tuple[str | Path, int | None]],
    out: str | Path,
    *,
    step1_dir: str | Path | None = None,
    name: str = "pyheracles",
) -> IfcReport:
    """One IFC 4 model of several step-2 output folders (a pipeline run).

    Parameters
    ----------
    parts
        (result folder, step-1 instance or None) pairs; an instance puts the folder's
        elements in that IfcBuilding, None in the building whose footprint holds them.
    out
        IFC file to write (atomically).
    step1_dir
        ``heracles complex`` folder with ``objects.gpkg`` (one IfcBuilding per
        object), or None for one building.
    name
        Name of the IfcProject.

    Notes
    -----
    The model's origin (IfcMapConversion) is the first folder's cloud offset; the
    other folders' clouds are moved into it exactly (whole-metre offsets).
    """
    from dataclasses import replace

    from pyheracles.io.atomic import atomic_path

    if not parts:
        raise InputError("no result folders to export to IFC")
    loaded = [(Path(f), *read_result_folder(f), inst) for f, inst in parts]
    origin = np.asarray(loaded[0][3].offset, dtype=np.float64)
    rep = IfcReport(Path(out))
    w = _Writer(name)
    site = w.run("root.create_entity", ifc_class="IfcSite", name="site")
    w.run("aggregate.assign_object", products=[site], relating_object=w.project)
    _georeference(w, loaded[0][3].crs, origin, rep.notes)
    buildings = _buildings(w, site, step1_dir, rep)
    for folder, step, objects, cloud, inst in loaded:
        if not np.array_equal(cloud.offset, origin):
            cloud = replace(cloud, xyz=cloud.xyz + (cloud.offset - origin), offset=origin)
        container = _container(buildings, objects, inst)
        before = sum(rep.elements.values())
        if step == "supports":
            _supports(w, objects, cloud, container, rep)
        elif step == "beams":
            _beams(w, objects, cloud, container, rep)
        else:
            _walls(w, folder, cloud, container, rep)
        if sum(rep.elements.values()) == before:
            rep.notes.append(f"no elements in {folder}")
    with atomic_path(Path(out)) as tmp:
        w.f.write(str(tmp))
    return rep
