"""PLY reading and writing (ASCII and binary little/big endian), vertex element only.

Hand-written because the well-kept options are heavy (Open3D) or drop
per-vertex properties (trimesh keeps them but pulls in a mesh stack); the
format is small: a text header, then a table we hand to numpy in one call.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud, reject_non_finite
from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path

__all__ = ["read_ply", "write_ply", "write_vertex_table"]

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_NUMPY_TO_PLY = {"i1": "char", "u1": "uchar", "i2": "short", "u2": "ushort",
                 "i4": "int", "u4": "uint", "f4": "float", "f8": "double"}  # fmt: skip


def _parse_header(
    raw: bytes, p: Path
) -> tuple[str, list[tuple[str, int, list[tuple[str, str]]]], int]:
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise InputError("not a PLY file (no 'ply' magic or no end_header)", path=p)
    body_start = raw.index(b"\n", end) + 1
    fmt = ""
    elements: list[tuple[str, int, list[tuple[str, str]]]] = []
    for line in raw[:end].decode("ascii", errors="replace").splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "format":
            fmt = parts[1]
        elif parts[0] == "element":
            elements.append((parts[1], int(parts[2]), []))
        elif parts[0] == "property":
            if parts[1] == "list":
                elements[-1][2].append((parts[-1], "list"))
            else:
                if parts[1] not in _PLY_TYPES:
                    raise InputError(f"unknown PLY property type {parts[1]!r}", path=p)
                elements[-1][2].append((parts[2], _PLY_TYPES[parts[1]]))
    return fmt, elements, body_start


def read_ply(path: str | Path) -> PointCloud:
    """Read the vertices of a PLY file (x, y, z plus every other scalar property).

    Elements after ``vertex`` (faces) are ignored; elements before it must be
    scalar-only.  Raises :class:`InputError` on a folder, a damaged or truncated
    file, or NaN / infinite vertices (one error naming the file and counting them).
    """
    from pyheracles.io import check_cloud_path

    p = check_cloud_path(path)
    raw = p.read_bytes()
    fmt, elements, pos = _parse_header(raw, p)
    vertex = None
    for name, count, props in elements:
        if name == "vertex":
            vertex = (count, props)
            break
        if any(t == "list" for _, t in props):
            raise InputError(f"list property in element {name!r} before vertices", path=p)
        if fmt != "ascii":
            pos += count * sum(np.dtype(t).itemsize for _, t in props)
    if vertex is None:
        raise InputError("PLY file has no vertex element", path=p)
    count, props = vertex
    if any(t == "list" for _, t in props):
        raise InputError("list properties on vertices are not supported", path=p)
    names = [n for n, _ in props]
    if not {"x", "y", "z"} <= set(names):
        raise InputError("PLY vertices have no x, y, z properties", path=p)
    try:
        if fmt == "ascii":
            text = raw[pos:].decode("ascii", errors="replace").split("\n")
            # Skip lines of earlier elements, then parse `count` rows at once.
            skip = sum(c for n, c, _ in elements[: [e[0] for e in elements].index("vertex")])
            rows = [ln for ln in text[skip : skip + count]]
            table = np.loadtxt(rows, dtype=np.float64, ndmin=2)
            if table.shape != (count, len(names)):
                raise ValueError(f"expected {count} rows of {len(names)} values")
            cols = {n: table[:, i].astype(t) for i, (n, t) in enumerate(props)}
        else:
            endian = "<" if fmt == "binary_little_endian" else ">"
            dtype = np.dtype([(n, endian + t) for n, t in props])
            if pos + count * dtype.itemsize > len(raw):
                raise ValueError(f"file ends before its {count} vertices")
            table = np.frombuffer(raw, dtype=dtype, count=count, offset=pos)
            cols = {n: table[n].astype(np.dtype(t)) for n, t in props}
    except ValueError as exc:
        raise InputError(
            f"truncated or malformed PLY ({exc})", path=p, hint="export the file again"
        ) from exc
    world = np.column_stack([cols.pop("x"), cols.pop("y"), cols.pop("z")]).astype(np.float64)
    return PointCloud.from_world(world, attributes=cols, source=str(p))


def write_ply(
    cloud: PointCloud, path: str | Path, extra_dims: dict[str, NDArray[Any]] | None = None
) -> Path:
    """Write a binary little-endian PLY with world coordinates (float64) and attributes."""
    reject_non_finite(cloud.xyz, cloud.source)
    attrs = dict(cloud.attributes)
    attrs.update(extra_dims or {})
    world = cloud.world_xyz()
    fields: list[tuple[str, NDArray[Any]]] = [("x", world[:, 0]), ("y", world[:, 1]),
                                              ("z", world[:, 2])]  # fmt: skip
    for name, values in attrs.items():
        arr = np.asarray(values)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.uint8)
        if arr.dtype.kind not in "iuf" or arr.ndim not in (1, 2):
            continue
        if arr.dtype.itemsize == 8 and arr.dtype.kind in "iu":
            arr = arr.astype(np.float64)
        if arr.ndim == 1:
            fields.append((name, arr))
        else:  # several values per point (LAS array extra bytes): one property each
            fields.extend((f"{name}_{i}", arr[:, i]) for i in range(arr.shape[1]))
    return write_vertex_table(path, fields)


def write_vertex_table(
    path: str | Path, fields: list[tuple[str, NDArray[Any]]], comments: tuple[str, ...] = ()
) -> Path:
    """Write named per-vertex columns as a binary little-endian PLY, atomically.

    Parameters
    ----------
    path
        Output file.
    fields
        ``(property name, 1-D array)`` in file order; every array has one value per vertex
        and a numeric dtype PLY can hold (int8-32, uint8-32, float32, float64).
    comments
        ``comment`` lines of the header (no newlines).
    """
    n = len(fields[0][1]) if fields else 0
    dtype = np.dtype([(name, "<" + a.dtype.str[1:]) for name, a in fields])
    table = np.empty(n, dtype=dtype)
    for name, a in fields:
        table[name] = a
    header = ["ply", "format binary_little_endian 1.0"]
    header += [f"comment {c}" for c in comments]
    header.append(f"element vertex {n}")
    header += [f"property {_NUMPY_TO_PLY[dtype[name].str[1:]]} {name}" for name, _ in fields]
    header.append("end_header\n")
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write("\n".join(header).encode("ascii"))
        fh.write(table.tobytes())
    return Path(path)
