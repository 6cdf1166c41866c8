"""LAS / LAZ / COPC reading and writing with laspy (LAZ through lazrs).

Reading
    Coordinates are read as integers and turned into local-frame float64
    without ever forming the large world values in float arithmetic:
    ``local = (X - X_min) * scale`` and ``offset = file_offset + X_min * scale``.
    The local frame then depends only on the points, not on the header offset
    nor on the size of the world coordinates, so every result computed in it
    is the same for a cloud shifted by 10^9 m (DESIGN.md rule 3).  Every
    dimension of the point record becomes an attribute under its laspy name
    (standard fields and flags, waveform packet fields, extra bytes of any
    type, scaled or not, arrays, unregistered extra bytes as ``ExtraBytes``),
    and the header rides along as :attr:`PointCloud.las_header` (point format,
    extra-byte descriptions, VLRs, EVLRs).

Writing
    :func:`write_las` starts from the source's point format and header and
    adds the new dimensions as extra bytes.  When the source format cannot
    hold what is written (ASPRS class codes above 31, a LAS 1.4 field) the
    points are written in the smallest LAS 1.4 format (6-10) holding every
    field of the source (``scan_angle_rank`` becomes ``scan_angle`` in
    0.006° units); nothing is dropped.  COPC inputs are written as plain LAZ
    1.4 (the points stay in input order, which is not COPC's octree order).
    Files are always LAS 1.4, written atomically.
"""

from __future__ import annotations

import copy
import struct
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import laspy
import numpy as np
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud, reject_non_finite
from pyheracles.errors import HeraclesError, InputError
from pyheracles.io.atomic import atomic_path
from pyheracles.threads import map_threads, n_workers

__all__ = ["read_las", "without_crs", "write_las"]

_DEFAULT_SCALE = 0.001  # metres; 1 mm, the resolution the design promises
_SCAN_ANGLE_UNIT_DEG = 0.006  # LAS 1.4 scan_angle unit (formats 6-10)
_XYZ = ("X", "Y", "Z")
_FORMAT_DIMS = {
    f: tuple(n for n in laspy.PointFormat(f).dimension_names if n not in _XYZ) for f in range(11)
}
#: Every standard dimension name of point formats 0-10 (coordinates excepted).
_STANDARD = frozenset(n for dims in _FORMAT_DIMS.values() for n in dims)
_LEGACY = (0, 1, 2, 3, 4, 5)
_MODERN = (6, 7, 8, 9, 10)
#: Fields that only formats 6-10 hold.
_MODERN_ONLY = frozenset({"overlap", "scanner_channel", "nir"})
_CRS_VLRS = (
    "WktCoordinateSystemVlr",
    "GeoKeyDirectoryVlr",
    "GeoAsciiParamsVlr",
    "GeoDoubleParamsVlr",
)
_MANAGED_VLRS = ("ExtraBytesVlr", "LasZipVlr")  # rewritten by laspy from the new header
_EXTRA_BASES = frozenset("u1 i1 u2 i2 u4 i4 u8 i8 f4 f8".split())


def _laz_backend() -> laspy.LazBackend | None:
    """lazrs with one thread per core when available (LAZ chunks are independent)."""
    if laspy.LazBackend.LazrsParallel.is_available():
        return laspy.LazBackend.LazrsParallel
    return None


# ----------------------------------------------------------------------------- reading
def read_las(path: str | Path) -> PointCloud:
    """Read a LAS, LAZ or COPC file into a :class:`PointCloud`.

    Every dimension of the point record becomes an attribute (standard fields,
    flags, waveform packet fields, all extra bytes); the header is kept as
    ``las_header`` so that :func:`write_las` writes them all back.  The CRS
    comes from the header's WKT or GeoTIFF keys (``None`` when absent).

    Raises
    ------
    InputError
        If the path is a folder, the file is missing, truncated or not a
        LAS/LAZ file, or its header scales / offsets are not finite.
    """
    from pyheracles.io import check_cloud_path

    p = check_cloud_path(path)
    try:
        las = laspy.read(p, laz_backend=_laz_backend())
    except Exception as exc:  # laspy raises many types for damaged files
        raise InputError(
            f"cannot read as LAS/LAZ ({type(exc).__name__}: {exc})",
            path=p,
            hint="the file may be truncated or not a LAS/LAZ file; re-export it",
        ) from exc
    header = las.header
    n_declared = int(header.point_count)
    if len(las.points) != n_declared:
        raise InputError(
            f"header declares {n_declared} points but {len(las.points)} could be read",
            path=p,
            hint="the file is truncated; copy or export it again",
        )
    scale = np.asarray(header.scales, dtype=np.float64)
    file_offset = np.asarray(header.offsets, dtype=np.float64)
    if not (np.isfinite(scale).all() and (scale > 0).all() and np.isfinite(file_offset).all()):
        raise InputError(
            f"invalid header scales {scale.tolist()} / offsets {file_offset.tolist()}",
            path=p,
            hint="the header is damaged; export the file again",
        )
    xyz, kmin, attrs = _point_arrays(las, scale)
    offset = file_offset + kmin * scale
    if (
        header.version.minor == 3
        and header.global_encoding.waveform_data_packets_internal
        and header.start_of_waveform_data_packet_record > 0
    ):
        header.evlrs = _read_waveform_evlr_13(p, header.start_of_waveform_data_packet_record)
    try:
        crs = header.parse_crs()
    except Exception:  # unparseable VLR: say so rather than guess (VLRs are kept)
        crs = None
    return PointCloud(
        xyz=xyz, offset=offset, attributes=attrs, crs=crs, scale=scale, source=str(p),
        las_header=header,
    )  # fmt: skip


def _point_arrays(
    las: laspy.LasData, scale: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """Local coordinates, their integer origin and every other dimension of a LAS record.

    The origin is on the file's own lattice at the minimum corner: exact integers times
    scale, a column at a time (no (N, 3) integer copies: a fifth of reading 10 M points).
    The three columns and the dimensions are independent copies out of the record, so
    they run on threads (:func:`pyheracles.threads.map_threads`; numpy releases the
    interpreter while it copies): each fills its own array, the values are those of a
    loop.  A byte shared by bit fields is tested for zeros once, not once per field.
    """
    xyz = np.empty((len(las.points), 3))
    kmin = np.zeros(3, dtype=np.int64)
    names = [n for n in las.point_format.dimension_names if n not in _XYZ]
    views = {name: las[name] for name in names}
    zero_bytes = _zero_bit_field_bytes(views.values())

    def column(j: int) -> None:
        ints = np.asarray(las.points[_XYZ[j]])
        kmin[j] = ints.min() if len(ints) else 0
        np.multiply(np.subtract(ints, kmin[j], dtype=np.int64), scale[j], out=xyz[:, j])

    def piece(task: int | str) -> NDArray[Any] | None:
        if isinstance(task, int):
            column(task)
            return None
        return _dimension_values(views[task], zero_bytes)

    values = map_threads(piece, [0, 1, 2, *names])
    return xyz, kmin, dict(zip(names, values[3:], strict=True))


def _zero_bit_field_bytes(views: Any) -> set[tuple]:
    """Keys (:func:`_bytes_key`) of the record bytes under bit-field views that are 0 in
    every point.

    Several bit fields share a byte (the return numbers, the flags and the scanner
    channel): one test per byte, not per field.
    """
    arrays = {}
    for view in views:
        if isinstance(view, laspy.point.dims.SubFieldView):
            arrays.setdefault(_bytes_key(view.array), view.array)
    return {key for key, arr in arrays.items() if not arr.any()}


def _bytes_key(arr: NDArray[Any]) -> tuple:
    """The memory an array views: its address, strides, shape and type (the views of
    one record field made for different bit fields are different objects)."""
    return (arr.__array_interface__["data"][0], arr.strides, arr.shape, arr.dtype.str)


def _dimension_values(view: Any, zero_bytes: set[tuple] | None = None) -> NDArray[Any]:
    """The values of one dimension of a LAS point record as a new array.

    A bit field (return numbers, the flags, the scanner channel) whose byte is 0 in
    every point is all 0: it is made as zeros without masking and shifting that byte,
    and a bit field is not copied again after its mask and shift made it (the 10 flag
    and bit fields of the benchmark's 10 M point cloud, all 0, cost ~0.1 s of CPU each
    that way).  The dtype is the one the mask and shift give.
    """
    if isinstance(view, laspy.point.dims.SubFieldView):
        zero = (
            _bytes_key(view.array) in zero_bytes if zero_bytes is not None else not view.array.any()
        )
        if zero:
            dtype = ((view.array[:1] & view.bit_mask) >> view.lsb).dtype
            return np.zeros(len(view.array), dtype=dtype)
        return np.asarray(view)  # a new array already
    return np.array(view)  # a copy: not a view into the whole record


def _read_waveform_evlr_13(p: Path, start: int) -> Any:
    """The internal waveform data packets of a LAS 1.3 file (laspy reads EVLRs from 1.4 on)."""
    from laspy.vlrs.vlrlist import VLRList

    try:
        with open(p, "rb") as fh:
            fh.seek(start)
            return VLRList.read_from(fh, 1, extended=True)
    except Exception as exc:
        raise InputError(
            f"cannot read the waveform data packets at byte {start} ({exc})",
            path=p,
            hint="the file is truncated; copy or export it again",
        ) from exc


# ----------------------------------------------------------------------------- writing
def _fits_exactly(values: NDArray[Any], lo: float, hi: float) -> bool:
    """True if every value is a whole number within [lo, hi]."""
    if values.size == 0:
        return True
    if values.dtype == np.bool_:
        return lo <= 0 and hi >= 1
    if values.dtype.kind not in "iuf":
        return False
    if values.dtype.kind == "f" and not np.array_equal(values, np.round(values)):
        return False
    return bool(values.min() >= lo and values.max() <= hi)


def _field_range(fmt: int, name: str) -> tuple[float, float, bool]:
    """(min, max, is_float) of a standard field of point format ``fmt``."""
    dim = laspy.PointFormat(fmt).dimension_by_name(name)
    kind = dim.kind
    if kind == laspy.DimensionKind.FloatingPoint:
        return -np.inf, np.inf, True
    return float(dim.min), float(dim.max), False


def _choose_format(
    standard: Mapping[str, NDArray[Any]], source_format: int | None
) -> tuple[int, str]:
    """Point format that holds every standard field given; the reason when it changed."""
    names = set(standard)

    def above(name: str, limit: int) -> bool:
        values = standard.get(name)
        return values is not None and len(values) > 0 and int(np.max(values)) > limit

    big_class = above("classification", 31)
    many_returns = above("return_number", 7) or above("number_of_returns", 7)
    angle_only = "scan_angle" in names and "scan_angle_rank" not in names
    legacy_source = (
        source_format in _LEGACY if source_format is not None else "scan_angle_rank" in names
    )
    legacy = (
        legacy_source
        and not (big_class or many_returns or angle_only)
        and not (names & _MODERN_ONLY)
    )
    if legacy:
        family, needed = _LEGACY, names - {"scan_angle"}
    else:
        family, needed = _MODERN, {("scan_angle" if n == "scan_angle_rank" else n) for n in names}
    if source_format in family and needed <= set(_FORMAT_DIMS[source_format]):
        return source_format, ""
    fmt = min(
        (f for f in family if needed <= set(_FORMAT_DIMS[f])),
        key=lambda f: laspy.PointFormat(f).size,
    )
    if source_format is None or legacy:
        return fmt, ""
    if big_class:
        reason = "ASPRS class codes above 31 need a LAS 1.4 point format"
    elif many_returns:
        reason = "more than 7 returns need a LAS 1.4 point format"
    else:
        extra = sorted(needed - set(_FORMAT_DIMS[source_format]))
        reason = f"the fields {', '.join(extra)} need it"
    return fmt, reason


def _extra_params(
    name: str, values: NDArray[Any], source: laspy.PointFormat | None
) -> tuple[laspy.ExtraBytesParams, NDArray[Any]]:
    """Extra-bytes description for an attribute (the source's own when it has one)."""
    if len(name.encode()) > 32:
        raise InputError(
            f"attribute name {name!r} is longer than the 32 bytes LAS extra bytes allow",
            hint="rename the attribute before writing LAS/LAZ",
        )
    arr = np.asarray(values)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8)
    elif arr.dtype == np.float16:
        arr = arr.astype(np.float32)
    if arr.ndim > 2 or arr.dtype.kind not in "iuf":
        raise InputError(
            f"attribute {name!r} ({arr.dtype}, shape {arr.shape[1:]} per point) cannot be "
            "stored as LAS extra bytes",
            hint="LAS holds numbers, up to 3 per point; convert or drop the attribute",
        )
    count = 1 if arr.ndim == 1 else arr.shape[1]
    base = arr.dtype.str[1:]
    if source is not None and name in set(source.extra_dimension_names):
        dim = source.dimension_by_name(name)
        if dim.num_elements == count and (dim.is_scaled or dim.type_str().endswith(base)):
            return (
                laspy.ExtraBytesParams(
                    name, dim.type_str(), description=dim.description, offsets=dim.offsets,
                    scales=dim.scales, no_data=dim.no_data,
                ),
                arr,
            )  # fmt: skip
    if base not in _EXTRA_BASES or (count > 3 and base != "u1"):
        raise InputError(
            f"attribute {name!r} ({arr.dtype}, {count} values per point) cannot be stored as "
            "LAS extra bytes",
            hint="LAS extra bytes hold 1 to 3 numbers of 1, 2, 4 or 8 bytes per point",
        )
    return laspy.ExtraBytesParams(name, f"{count}{base}" if count > 1 else base), arr


def without_crs(header: laspy.LasHeader | None) -> laspy.LasHeader | None:
    """A copy of a LAS header without its coordinate system (GeoTIFF keys and WKT VLRs).

    For clouds moved into another frame (registration, georeferencing): the other
    VLRs and EVLRs (extra-byte descriptions, project records) still describe the
    points, the source's CRS no longer does.  ``None`` stays ``None``.
    """
    if header is None:
        return None
    from laspy.vlrs.vlrlist import VLRList

    out = copy.deepcopy(header)
    out.vlrs = VLRList([v for v in out.vlrs if type(v).__name__ not in _CRS_VLRS])
    out.evlrs = VLRList([e for e in (out.evlrs or []) if type(e).__name__ not in _CRS_VLRS])
    return out


def _header_for(
    cloud: PointCloud, fmt: int, extras: list[laspy.ExtraBytesParams], notes: list[str]
) -> laspy.LasHeader:
    """LAS 1.4 header in format ``fmt``: the source's identity, VLRs and EVLRs, new extras."""
    from laspy.vlrs.vlrlist import VLRList

    src = cloud.las_header
    header = laspy.LasHeader(point_format=fmt, version="1.4")
    header.generating_software = "pyheracles"
    keep_crs_vlrs = cloud.crs is None
    if src is not None:
        header.global_encoding.value = src.global_encoding.value
        header.file_source_id = src.file_source_id
        header.uuid = src.uuid
        header.system_identifier = src.system_identifier
        copc = any(v.user_id == "copc" for v in src.vlrs)
        if copc:
            notes.append(
                f"{Path(cloud.source or 'the input').name} is COPC: written as plain LAZ 1.4 "
                "in the input's point order (COPC needs octree order); the COPC info VLR "
                "and hierarchy EVLR are not copied"
            )
        if cloud.crs is not None:
            try:
                src_crs = src.parse_crs()
            except Exception:
                src_crs = None
            has_wkt = bool(src.vlrs.get("WktCoordinateSystemVlr"))
            same = src_crs is not None and cloud.crs.equals(src_crs)
            keep_crs_vlrs = same and (fmt < 6 or has_wkt)
        for vlr in src.vlrs:
            kind = type(vlr).__name__
            if kind in _MANAGED_VLRS or vlr.user_id == "copc":
                continue
            if kind in _CRS_VLRS and not keep_crs_vlrs:
                continue
            header.vlrs.append(vlr)
        evlrs = [
            e
            for e in (src.evlrs or [])
            if e.user_id != "copc" and (keep_crs_vlrs or type(e).__name__ not in _CRS_VLRS)
        ]
        header.evlrs = VLRList(evlrs)
    if fmt >= 6:
        header.global_encoding.wkt = True
    if not keep_crs_vlrs:
        try:
            header.add_crs(cloud.crs)
        except Exception:  # GeoTIFF keys cannot encode every CRS: WKT can
            header.add_crs(cloud.crs, keep_compatibility=False)
    if extras:
        header.add_extra_dims(extras)
    return header


def _integer_coordinates(
    cloud: PointCloud, scale: NDArray[np.float64], offset: NDArray[np.float64]
) -> list[NDArray[np.int32]] | None:
    """X, Y, Z integer columns for a header (scale, offset); None if they overflow int32.

    A column at a time through a float buffer of its own, the three on threads
    (:func:`pyheracles.threads.map_threads`): the (N, 3) float and int64 copies of the
    whole cloud cost 1.2 s of CPU on 10 M points.  ``np.rint``
    rounds half to even as ``np.round`` does, so the integers are unchanged.
    """
    shift = (cloud.offset - offset) / scale
    whole = np.round(shift)
    # the cloud's offset on the file lattice (always, for clouds read from LAS): add the
    # whole shift after rounding, so that the local coordinates round as they were read
    on_lattice = bool(np.all(np.abs(shift - whole) < 1e-3))
    lo, hi = np.iinfo(np.int32).min, np.iinfo(np.int32).max

    def column(j: int) -> NDArray[np.int32] | None:
        buf = np.empty(len(cloud))
        if on_lattice:
            np.divide(cloud.xyz[:, j], scale[j], out=buf)
            np.rint(buf, out=buf)
            buf += whole[j]
        else:
            np.add(cloud.xyz[:, j], cloud.offset[j] - offset[j], out=buf)
            buf /= scale[j]
            np.rint(buf, out=buf)
        if len(buf) and (buf.min() < lo or buf.max() > hi):
            return None
        return buf.astype(np.int32)

    columns = map_threads(column, range(3))
    return None if any(c is None for c in columns) else columns


def write_las(
    cloud: PointCloud,
    path: str | Path,
    extra_dims: Mapping[str, NDArray[Any]] | None = None,
    *,
    notes: list[str] | None = None,
) -> Path:
    """Write a cloud as LAS 1.4 (``.las``) or LAZ (``.laz``), atomically, losing no field.

    Parameters
    ----------
    cloud
        The cloud.  Attributes named like LAS fields go to those fields, the
        others become extra dimensions.  With a ``las_header`` (a cloud read
        from LAS/LAZ) its point format, extra-byte descriptions (types, scales,
        offsets, no-data), VLRs and EVLRs are kept.
    path
        Output file; the extension chooses compression.
    extra_dims
        Further per-point arrays written as extra dimensions (e.g. ``instance``
        int32, ``class_id`` uint8); they override attributes of the same name.
    notes
        When given, what the writer had to change is appended to it (a point
        format upgrade and its reason, COPC written as plain LAZ), for ``run.json``.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        NaN or infinite coordinates, an attribute of the wrong length or one LAS
        cannot hold (text, more than 3 numbers per point), coordinates beyond the
        int32 range of the scale.
    """
    p = Path(path)
    reject_non_finite(cloud.xyz, cloud.source)
    said = [] if notes is None else notes
    attrs: dict[str, NDArray[Any]] = {k: np.asarray(v) for k, v in cloud.attributes.items()}
    attrs.update({k: np.asarray(v) for k, v in (extra_dims or {}).items()})
    n = len(cloud)
    for name, values in attrs.items():
        if len(values) != n:
            raise InputError(f"attribute {name!r} has {len(values)} values for {n} points")
    src = cloud.las_header
    src_format = None if src is None else int(src.point_format.id)
    standard = {k: v for k, v in attrs.items() if k in _STANDARD and v.ndim == 1}
    # a standard name whose values the LAS field cannot hold exactly (a PLY's float
    # intensity, say) keeps its values as an extra dimension of its own
    for name in list(standard):
        widest = next(f for f in reversed(range(11)) if name in _FORMAT_DIMS[f])
        lo, hi, is_float = _field_range(widest, name)
        values = standard[name]
        if not is_float and name != "classification" and not _fits_exactly(values, lo, hi):
            del standard[name]
            attrs[f"{name}_value"] = attrs.pop(name)
            said.append(
                f"attribute {name!r} ({values.dtype}) does not fit the LAS field: written as "
                f"extra dimension '{name}_value'"
            )
    fmt, reason = _choose_format(standard, src_format)
    if reason:
        said.append(f"point format {src_format} written as {fmt}: {reason}")
    fields = set(_FORMAT_DIMS[fmt])
    values_of: dict[str, NDArray[Any]] = {}
    extras: dict[str, NDArray[Any]] = {}
    for name, values in attrs.items():
        if name in fields and name in standard:
            values_of[name] = values
        elif name == "scan_angle_rank" and name in standard and "scan_angle" in fields:
            angle = np.round(values.astype(np.float64) / _SCAN_ANGLE_UNIT_DEG)
            if "scan_angle" in standard:
                if np.abs(standard["scan_angle"] - angle).max(initial=0) > 0.5 / 0.006:
                    extras[name] = values  # disagrees with scan_angle: keep both
                continue
            values_of["scan_angle"] = angle.astype(np.int16)
        elif name == "scan_angle" and name in standard and "scan_angle_rank" in fields:
            rank = np.round(values.astype(np.float64) * _SCAN_ANGLE_UNIT_DEG)
            if np.abs(standard["scan_angle_rank"] - rank).max(initial=0) > 0.5:
                extras[name] = values
        elif name in standard:  # pragma: no cover - _choose_format covers every field
            raise HeraclesError(f"no field of point format {fmt} for {name!r}")
        else:
            extras[name] = values
    source_pf = None if src is None else src.point_format
    params, arrays = [], {}
    for name, values in extras.items():
        param, arr = _extra_params(name, values, source_pf)
        params.append(param)
        arrays[name] = arr
    header = _header_for(cloud, fmt, params, said)
    scale = cloud.scale if cloud.scale is not None else np.full(3, _DEFAULT_SCALE)
    header.scales = scale
    offset = np.asarray(src.offsets, dtype=np.float64) if src is not None else cloud.offset
    ints = _integer_coordinates(cloud, scale, offset)
    if ints is None and src is not None:  # moved far from the source: a new offset
        offset = cloud.offset
        ints = _integer_coordinates(cloud, scale, offset)
    if ints is None:
        raise InputError(
            f"the coordinates span more than LAS holds at a scale of {scale.tolist()} m",
            path=cloud.source,
            hint="write a coarser scale or split the cloud into tiles",
        )
    header.offsets = offset
    record = laspy.ScaleAwarePointRecord.zeros(n, header=header)
    columns: dict[str, NDArray[Any]] = dict(zip(_XYZ, ints, strict=True))
    for name, values in values_of.items():
        if name == "classification":
            lo, hi, _ = _field_range(fmt, name)
            if not _fits_exactly(values, lo, hi):
                raise InputError(
                    f"classification values {values.min()}..{values.max()} do not fit LAS "
                    f"point format {fmt}",
                    hint="ASPRS class codes are whole numbers 0-255",
                )
        if _all_zero_integers(values):
            continue  # the record is zeros already
        columns[name] = values.astype(np.uint8) if values.dtype == np.bool_ else values
    for name, arr in arrays.items():
        if record.point_format.dimension_by_name(name).is_scaled:
            _set_extra(record, name, arr)
        else:
            columns[name] = arr
    _fill_record(record, columns)
    # no las.update_header(): laspy's writer resets the header's bounds and counts and
    # computes them again from the points (a second pass over all of them, with a sort
    # of the return numbers); the record already has the header's format and size
    las = laspy.LasData(header, points=record)
    compress = p.suffix.lower() == ".laz"
    with atomic_path(p) as tmp:
        las.write(tmp, laz_backend=_laz_backend() if compress else None)
        if compress and fmt in (4, 5, 9, 10) and not _same_points(tmp, record):
            # lazrs 0.8 garbles the wave packet fields of formats 9/10 when the scanner
            # channel changes between points: keep the data, uncompressed
            with open(tmp, "wb") as fh:
                las.write(fh, do_compress=False)
            said.append(
                f"{p.name}: written uncompressed (LAS content) because the LAZ compressor "
                f"lost wave packet fields of point format {fmt}"
            )
        if header.global_encoding.waveform_data_packets_internal:
            _point_header_at_waveform_evlr(tmp)
    return p


def _fill_record(record: Any, columns: Mapping[str, NDArray[Any]]) -> None:
    """Set whole fields of a point record, in blocks of points on threads.

    Each thread writes every field of its own block of points (:func:`map_threads`),
    never a byte another one writes: the bit fields sharing a byte are read, masked and
    written by the thread of those points only, and no two threads share the cache
    lines of one record (as they would writing different fields of the same points).
    The bytes are those of setting each field in turn (``record[name] = values``); on
    10 M points these strided writes were a sixth of the time of writing the LAZ, the
    rest being the compression, which lazrs spreads over the cores itself.
    """
    n = len(record)
    k = n_workers() if n >= 2 * _MIN_BLOCK else 1
    edges = np.linspace(0, n, k + 1).astype(np.int64)

    def fill(block: int) -> None:
        a, b = int(edges[block]), int(edges[block + 1])
        for name, values in columns.items():
            record[name][a:b] = values[a:b]

    map_threads(fill, range(k))


#: Fewest points per thread of :func:`_fill_record` (fewer: one thread).
_MIN_BLOCK = 1 << 16


def _all_zero_integers(values: NDArray[Any]) -> bool:
    """Whether a field's values are integers (or flags) that are all 0: nothing to write
    into a record of zeros.

    Setting a field of a 10 M point record costs 0.03-0.1 s of CPU (a strided write; a
    read, mask and write of the shared byte for the bit fields: return numbers, the
    flags, the scanner channel), checking it is zero 1 ms; most flags of a survey are
    all 0 (the 10 flag and bit fields of the benchmark's cloud took 1.1 s of the 4.6 s
    of writing it).  Floats are written whatever they hold (a -0.0 is not +0.0 in the
    file).
    """
    return values.dtype.kind in "biu" and not values.any()


def _set_extra(record: Any, name: str, values: NDArray[Any]) -> None:
    """Set an extra dimension; scaled ones through their raw integers (exact, range-checked).

    laspy's scaled view compares the largest value of all elements with each
    element's range, which fails for arrays whose elements have different scales.
    """
    dim = record.point_format.dimension_by_name(name)
    if not dim.is_scaled:
        record[name] = values
        return
    scales = np.ones(dim.num_elements) if dim.scales is None else np.asarray(dim.scales)
    offsets = np.zeros(dim.num_elements) if dim.offsets is None else np.asarray(dim.offsets)
    if dim.num_elements == 1:
        scales, offsets = scales.reshape(()), offsets.reshape(())
    raw = np.round((np.asarray(values, dtype=np.float64) - offsets) / scales)
    base = np.dtype(dim.type_str()).base
    if raw.size and base.kind in "iu":
        info = np.iinfo(base)
        if raw.min() < info.min or raw.max() > info.max:
            raise InputError(
                f"extra dimension {name!r}: values outside what its scale and offset hold",
                hint="check the attribute's values",
            )
    record.array[name] = raw.astype(base)


def _same_points(path: Path, record: Any) -> bool:
    """True if the file at ``path`` holds exactly the points of ``record``."""
    back = laspy.read(path, laz_backend=_laz_backend())
    return bool(np.array_equal(back.points.array, record.array))


def _point_header_at_waveform_evlr(path: Path) -> None:
    """Set ``start_of_waveform_data_packet_record`` to the waveform EVLR (laspy writes 0).

    The waveform packet offsets of the points are relative to that record, so
    a file with internal waveforms needs it to find them.
    """
    with open(path, "r+b") as fh:
        fh.seek(235)
        start, count = struct.unpack("<QI", fh.read(12))
        position = start
        for _ in range(count):
            fh.seek(position)
            raw = fh.read(60)
            if len(raw) < 60:
                return
            user_id = raw[2:18].rstrip(b"\0")
            record_id = struct.unpack("<H", raw[18:20])[0]
            length = struct.unpack("<Q", raw[20:28])[0]
            if user_id == b"LASF_Spec" and record_id == 65535:
                fh.seek(227)
                fh.write(struct.pack("<Q", position))
                return
            position += 60 + length
