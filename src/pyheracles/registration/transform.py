"""4x4 transforms ``T_target_source``: apply to clouds exactly, write and read transform.json.

A transform named ``T_target_source`` maps homogeneous coordinates of the source
frame into the target frame: ``x_target = T[:3, :3] @ x_source + T[:3, 3]`` (the
small_gicp / kiss-icp naming).  Applied to a :class:`~pyheracles.cloud.PointCloud`
the transform is split so that national-grid coordinates stay exact: the large
part ``T(offset_source)`` goes into the new offset, the local coordinates are only
rotated and scaled (DESIGN.md rule 3).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.io.las import without_crs

__all__ = [
    "apply_to_cloud",
    "apply_to_points",
    "compose",
    "invert",
    "read_transform_json",
    "transform_dict",
    "write_transform_json",
]


def _check(T: ArrayLike) -> NDArray[np.float64]:
    M = np.asarray(T, dtype=np.float64)
    if M.shape != (4, 4) or not np.isfinite(M).all():
        raise InputError(f"a transform must be a finite 4x4 matrix, got shape {M.shape}")
    if not np.allclose(M[3], [0, 0, 0, 1]):
        raise InputError("the last row of a 4x4 similarity transform must be [0, 0, 0, 1]")
    return M


def apply_to_points(T_target_source: ArrayLike, xyz: ArrayLike) -> NDArray[np.float64]:
    """Transform ``(N, 3)`` coordinates."""
    M = _check(T_target_source)
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return p @ M[:3, :3].T + M[:3, 3]


def invert(T_target_source: ArrayLike) -> NDArray[np.float64]:
    """``T_source_target`` (works for similarity transforms with scale)."""
    return np.linalg.inv(_check(T_target_source))


def compose(T_c_b: ArrayLike, T_b_a: ArrayLike) -> NDArray[np.float64]:
    """``T_c_a = T_c_b @ T_b_a``."""
    return _check(T_c_b) @ _check(T_b_a)


def apply_to_cloud(
    cloud: PointCloud,
    T_target_source: ArrayLike,
    *,
    offset: ArrayLike | None = None,
    crs: Any = None,
) -> PointCloud:
    """The cloud expressed in the target frame, with large coordinates kept exact.

    ``world_target = A @ (xyz + offset_source) + t`` is evaluated as
    ``A @ xyz + (A @ offset_source + t - offset_target)`` in local coordinates, so no
    7-digit number is ever multiplied with the rotation per point.

    Parameters
    ----------
    cloud
        Source cloud.
    T_target_source
        4x4 transform (similarity allowed).
    offset
        Offset of the result; default the transformed source offset rounded to whole
        metres.
    crs
        CRS of the target frame (e.g. the national grid of the control points).

    Notes
    -----
    The source's LAS header rides along without its CRS records
    (:func:`pyheracles.io.las.without_crs`): extra-byte descriptions and the other
    VLRs still describe the points, the old coordinate system does not.
    """
    M = _check(T_target_source)
    A = M[:3, :3]
    shifted = A @ cloud.offset + M[:3, 3]
    new_offset = np.floor(shifted) if offset is None else np.asarray(offset, float).reshape(3)
    local = cloud.xyz @ A.T + (shifted - new_offset)
    return PointCloud(
        xyz=local,
        offset=new_offset,
        attributes=dict(cloud.attributes),
        crs=crs,
        scale=cloud.scale,
        source=cloud.source,
        las_header=without_crs(cloud.las_header),
    )


def transform_dict(
    T_target_source: ArrayLike,
    *,
    source: str | None = None,
    target: str | None = None,
    result: Any = None,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The content of ``transform.json``.

    ``result`` may be a :class:`~pyheracles.registration.similarity.SimilarityResult`
    or anything with a ``to_dict()`` (ICP result); its parameters, standard
    deviations, sigma0 and residuals are included.
    """
    M = _check(T_target_source)
    from scipy.spatial.transform import Rotation

    scale = float(np.cbrt(np.linalg.det(M[:3, :3])))
    R = M[:3, :3] / scale
    out: dict[str, Any] = {
        "convention": (
            "x_target = T_target_source[:3, :3] @ x_source + T_target_source[:3, 3]; "
            "R = Rz(kappa) Ry(phi) Rx(omega) (scipy from_euler('xyz')), angles in radians"
        ),
        "source": source,
        "target": target,
        "T_target_source": M.tolist(),
        "translation_m": M[:3, 3].tolist(),
        "rotation_omega_phi_kappa_deg": np.degrees(
            Rotation.from_matrix(R).as_euler("xyz")
        ).tolist(),
        "scale": scale,
    }
    if result is not None:
        out["estimation"] = result.to_dict()
    if extra:
        out.update(extra)
    return out


def write_transform_json(path: str | Path, T_target_source: ArrayLike, **kwargs: Any) -> Path:
    """Write ``transform.json`` atomically (see :func:`transform_dict` for the keywords)."""
    from pyheracles.io.atomic import atomic_write_json

    return atomic_write_json(path, transform_dict(T_target_source, **kwargs))


def read_transform_json(path: str | Path) -> NDArray[np.float64]:
    """Read the 4x4 ``T_target_source`` of a ``transform.json``."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
        return _check(data["T_target_source"])
    except FileNotFoundError as exc:
        raise InputError("transform file not found", path=p) from exc
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(
            "not a transform.json (needs a 4x4 'T_target_source' list)", path=p
        ) from exc
