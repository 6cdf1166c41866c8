"""CityJSON 2.0 building models: one Building per step-1 object, LoD1.2 and LoD2.2.

Written as https://www.cityjson.org/specs/2.0.1/ says: ``transform`` with a
1 mm scale and integer ``vertices``, ``metadata.referenceSystem`` as an OGC
CRS URL, every GIS attribute of the footprint on its Building, one ``Solid``
per LoD with semantic surfaces (``RoofSurface``, ``WallSurface``,
``GroundSurface``).  Every solid is checked
(:func:`pyheracles.export.validate_solid.validate_solid`) after quantisation;
an invalid one is left out and listed in the returned report, never written
silently.  :func:`validate_cityjson` checks a whole file the same way.
"""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.export.validate_solid import validate_solid

__all__ = [
    "CityBuilding",
    "CityJSONReport",
    "crs_url",
    "json_value",
    "validate_cityjson",
    "write_cityjson",
]

SCALE_M = 0.001
"""Vertex quantisation, metres."""
_LODS = {"1.2", "1.3", "2.2"}
_SURFACES = {"RoofSurface", "WallSurface", "GroundSurface"}


@dataclass(frozen=True)
class CityBuilding:
    """One Building: id, attributes and its solids in world coordinates.

    ``solids`` maps a LoD (``"1.2"``, ``"2.2"``) to ``(vertices (M, 3) world
    metres, faces [[ring, ...], ...], semantics per face)``.
    """

    id: str
    attributes: Mapping[str, Any]
    solids: Mapping[str, tuple[NDArray[np.float64], list[list[list[int]]], list[str]]] = field(
        default_factory=dict
    )


@dataclass
class CityJSONReport:
    """What :func:`write_cityjson` wrote and what it left out (and why)."""

    path: Path | None = None
    n_buildings: int = 0
    n_solids: dict[str, int] = field(default_factory=dict)
    invalid: list[str] = field(default_factory=list)


def crs_url(crs: Any) -> str | None:
    """The OGC URL of a CRS (``.../def/crs/EPSG/0/<code>``); None without an EPSG code."""
    if crs is None:
        return None
    from pyproj import CRS

    code = CRS.from_user_input(crs).to_epsg()
    return None if code is None else f"https://www.opengis.net/def/crs/EPSG/0/{code}"


def json_value(value: Any) -> Any:
    """An attribute value as JSON: numpy scalars as numbers, dates as ISO text, NaN as null."""
    if value is None:
        return None
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, _dt.datetime | _dt.date):
        return value.isoformat()
    if hasattr(value, "isoformat"):  # pandas Timestamp
        try:
            return value.isoformat()
        except ValueError:  # NaT
            return None
    try:
        import pandas as pd

        if pd.isna(value):
            return None
    except (TypeError, ValueError):
        pass
    return str(value)


def _quantise(xyz: NDArray[np.float64], translate: NDArray[np.float64]) -> NDArray[np.int64]:
    return np.round((xyz - translate) / SCALE_M).astype(np.int64)


def _geometry(
    lod: str,
    qv: NDArray[np.int64],
    faces: list[list[list[int]]],
    semantics: list[str],
    registry: dict[tuple[int, int, int], int],
) -> dict[str, Any]:
    ids = []
    for x, y, z in qv.tolist():
        k = (x, y, z)
        if k not in registry:
            registry[k] = len(registry)
        ids.append(registry[k])
    kinds = sorted(set(semantics), key=["RoofSurface", "WallSurface", "GroundSurface"].index)
    shell = [[[ids[i] for i in ring] for ring in face] for face in faces]
    return {
        "type": "Solid",
        "lod": lod,
        "boundaries": [shell],
        "semantics": {
            "surfaces": [{"type": k} for k in kinds],
            "values": [[kinds.index(s) for s in semantics]],
        },
    }


def _clean_face(qv: NDArray[np.int64], face: list[list[int]]) -> list[list[int]]:
    """Rings without the consecutive duplicates that quantisation may create."""
    out = []
    for ring in face:
        keys = [tuple(qv[i]) for i in ring]
        r = [i for j, i in enumerate(ring) if keys[j] != keys[j - 1]]
        out.append(r)
    return out


def write_cityjson(
    path: str | Path,
    buildings: Sequence[CityBuilding],
    *,
    crs: Any = None,
    title: str = "pyheracles buildings",
) -> CityJSONReport:
    """Write ``buildings`` as one CityJSON 2.0 file (atomically).

    Each solid is quantised (1 mm) and validated; invalid solids are left out
    and listed in ``CityJSONReport.invalid``.
    """
    from pyheracles import __version__
    from pyheracles.io.atomic import atomic_write_json

    allv = [s[0] for b in buildings for s in b.solids.values() if len(s[0])]
    stack = np.vstack(allv) if allv else np.zeros((1, 3))
    translate = np.floor(stack.min(axis=0))
    report = CityJSONReport(path=Path(path))
    registry: dict[tuple[int, int, int], int] = {}
    objects: dict[str, Any] = {}
    for b in buildings:
        geoms = []
        for lod in sorted(b.solids):
            verts, faces, sem = b.solids[lod]
            qv = _quantise(np.asarray(verts, dtype=np.float64), translate)
            faces = [_clean_face(qv, f) for f in faces]
            errors = validate_solid(qv * SCALE_M, faces)
            if errors:
                report.invalid.append(f"building {b.id} LoD{lod}: {errors[0]}")
                continue
            geoms.append(_geometry(lod, qv, faces, list(sem), registry))
            report.n_solids[lod] = report.n_solids.get(lod, 0) + 1
        objects[b.id] = {
            "type": "Building",
            "attributes": {str(k): json_value(v) for k, v in b.attributes.items()},
            "geometry": geoms,
        }
    report.n_buildings = len(objects)
    vertices = [list(k) for k in sorted(registry, key=registry.__getitem__)]
    if vertices:
        q = np.asarray(vertices, dtype=np.float64) * SCALE_M + translate
        extent = [*q.min(axis=0).tolist(), *q.max(axis=0).tolist()]
    else:
        extent = [0.0] * 6
    metadata: dict[str, Any] = {
        "title": title,
        "geographicalExtent": [round(x, 3) for x in extent],
        "referenceDate": _dt.date.today().isoformat(),
        "identifier": f"pyheracles {__version__}",
    }
    url = crs_url(crs)
    if url:
        metadata["referenceSystem"] = url
    doc = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [SCALE_M] * 3, "translate": translate.tolist()},
        "metadata": metadata,
        "CityObjects": objects,
        "vertices": vertices,
    }
    atomic_write_json(Path(path), doc)
    return report


def validate_cityjson(doc: Mapping[str, Any]) -> list[str]:
    """Errors of a CityJSON 2.0 document of buildings (empty list: valid).

    Checks the structure the schema asks for (type, version, transform,
    CityObjects, integer vertices), vertex indices in range, LoD values,
    semantic surfaces (types and one value per surface), and every solid as
    :func:`~pyheracles.export.validate_solid.validate_solid` does.
    """
    errors: list[str] = []
    if doc.get("type") != "CityJSON":
        errors.append("type is not 'CityJSON'")
    if doc.get("version") != "2.0":
        errors.append(f"version is {doc.get('version')!r}, not '2.0'")
    tr = doc.get("transform")
    if not (isinstance(tr, Mapping) and len(tr.get("scale", [])) == 3
            and len(tr.get("translate", [])) == 3):  # fmt: skip
        return [*errors, "transform needs scale and translate (3 numbers each)"]
    verts = doc.get("vertices")
    if not isinstance(verts, list) or not all(
        isinstance(v, list) and len(v) == 3 and all(isinstance(x, int) for x in v) for v in verts
    ):
        return [*errors, "vertices must be a list of 3 integers each"]
    xyz = np.asarray(verts, dtype=np.float64).reshape(-1, 3) * np.asarray(tr["scale"]) + np.asarray(
        tr["translate"]
    )
    objects = doc.get("CityObjects")
    if not isinstance(objects, Mapping):
        return [*errors, "CityObjects missing"]
    for oid, obj in objects.items():
        if obj.get("type") not in ("Building", "BuildingPart"):
            errors.append(f"{oid}: type {obj.get('type')!r} is not a Building")
        for g in obj.get("geometry", []):
            if g.get("type") != "Solid":
                errors.append(f"{oid}: geometry type {g.get('type')!r} is not Solid")
                continue
            if str(g.get("lod")) not in _LODS:
                errors.append(f"{oid}: LoD {g.get('lod')!r} not one of {sorted(_LODS)}")
            shells = g.get("boundaries", [])
            if not shells:
                errors.append(f"{oid}: empty solid")
                continue
            shell = shells[0]
            flat = [i for face in shell for ring in face for i in ring]
            if any(not isinstance(i, int) or i < 0 or i >= len(xyz) for i in flat):
                errors.append(f"{oid}: vertex index out of range")
                continue
            sem = g.get("semantics")
            if sem is not None:
                kinds = [s.get("type") for s in sem.get("surfaces", [])]
                if any(k not in _SURFACES for k in kinds):
                    errors.append(f"{oid}: unknown semantic surface in {kinds}")
                values = sem.get("values", [])
                if len(values) != len(shells) or len(values[0]) != len(shell):
                    errors.append(f"{oid}: semantics values do not match the surfaces")
                elif any(v is not None and not 0 <= v < len(kinds) for v in values[0]):
                    errors.append(f"{oid}: semantics value out of range")
            used = sorted(set(flat))
            local = {v: i for i, v in enumerate(used)}
            faces = [[[local[i] for i in ring] for ring in face] for face in shell]
            for e in validate_solid(xyz[used], faces):
                errors.append(f"{oid} LoD{g.get('lod')}: {e}")
    return errors
