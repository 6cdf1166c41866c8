"""Engaged columns told by a neighbour's wall face: the row line of an engaged column.

An engaged column stands in its wall: its axis lies less than its radius in front of
the wall's face, and its ring stops at that face.  The face beside a column is often not
seen in the slab about the section: the shaft shadows the wall next to it from stations
in the room, and a large column leaves only a short stretch of face within its window
(supports draw 38: 0.94 m columns 0.30 m in front of their walls, 0.8 m of face beside
one, none beside another found in the low section).  When one column of a row found the
face (:func:`~pyheracles.supports.detect.engage_on_wall_faces`), its neighbours of the
same radius standing at the same depth in front of that face stand in the same wall.

The test is geometric, not a count of wall points: per free round shape, a face line
``n . x = d`` of an engaged column of about its radius, its centre as far in front of
that line as the engaged column's (within ``max(tol, centre_share x radius)``), less
than ``max_offset_share`` of its radius (the circle crosses the face: no free column
can stand there), and its ring seen on the room's side only (at most
``behind_share`` of its points more than ``tol`` behind the line).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Scales
from pyheracles.supports.engaged_rows import column_rings

#: Half thickness of the slab whose points round a column are its ring, metres (as the
#: rows of :mod:`~pyheracles.supports.engaged_rows` read it).
RING_SLAB_M = 0.15


@dataclass(frozen=True)
class FaceRowParams:
    """Settings of :func:`face_row_columns`.

    Attributes
    ----------
    radius_ratio
        The radii of a free column and the engaged column whose face it takes lie
        within this ratio of each other.
    centre_share
        The free column's centre lies as far in front of the face as the engaged
        column's within this share of its radius (or the surface tolerance, if larger),
        metres per metre.
    max_offset_share
        The centre lies at most this share of the radius in front of the face (a half
        or three-quarter column; a free column's ring stays in front of every wall).
    behind_share
        At most this share of the ring's points lies more than the surface tolerance
        behind the face (a ring going on behind it is a free column's).
    min_ring_points
        Ring points a column needs for the test.
    """

    radius_ratio: float = 1.25
    centre_share: float = 0.25
    max_offset_share: float = 0.6
    behind_share: float = 0.02
    min_ring_points: int = 8


def face_row_columns(
    centres: Array,
    radii: Array,
    rings: list[Array],
    faces: list[tuple[Array, float, Array, float]],
    tol: float,
    params: FaceRowParams | None = None,
) -> dict[int, int]:
    """Free round shapes standing in the wall face of an engaged column of their row.

    Parameters
    ----------
    centres
        ``(N, 2)`` plan centres of the free round shapes, metres.
    radii
        ``(N,)`` their radii, metres.
    rings
        Per shape, ``(K, 2)`` plan points of its ring.
    faces
        Per engaged column with a wall face: ``(centre, radius, unit normal into the
        room, offset d)`` (``n . x = d`` on the face).
    tol
        Surface tolerance, metres.
    params
        Settings.

    Returns
    -------
    dict
        Per engaged shape (index into ``centres``), the index into ``faces`` of the face
        it stands in.  A shape that would stand in faces of different directions is
        left out.
    """
    params = params or FaceRowParams()
    found: dict[int, int] = {}
    for i, (c, r, ring) in enumerate(zip(centres, radii, rings, strict=True)):
        if len(ring) < params.min_ring_points:
            continue
        hits: list[tuple[float, int]] = []
        for j, (ce, re, n, d) in enumerate(faces):
            if max(r, re) > params.radius_ratio * min(r, re):
                continue
            t, te = float(c @ n - d), float(ce @ n - d)
            if abs(t - te) > max(tol, params.centre_share * r):
                continue
            if t > params.max_offset_share * r + tol:
                continue
            if np.mean(ring @ n - d < -tol) > params.behind_share:
                continue
            hits.append((float(np.hypot(*(c - ce))), j))
        if not hits:
            continue
        normals = np.array([faces[j][2] for _, j in hits])
        if np.any(normals @ normals[0] < 0.99):
            continue  # faces of other directions: a corner, not a row
        found[i] = min(hits)[1]
    return found


def engage_face_rows(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    shapes: list[dict],
    h_sec: float,
    sc: Scales,
    params: FaceRowParams | None = None,
) -> int:
    """Turn the free column shapes standing in the wall face of an engaged column of
    their row into engaged ones, in place (:func:`face_row_columns`); returns how many.

    The faces are those of the engaged shapes that found one (``normal``, ``d``; not
    the lines of rows cut on one line, :mod:`~pyheracles.supports.engaged_rows`); an
    engaged shape takes the face's line, gap and normal.  Each ring is read among the
    points of a slab ``RING_SLAB_M`` above and below the shape's section.
    """
    cols = [k for k, sh in enumerate(shapes) if sh["class"] == "column"]
    owners = [
        sh
        for sh in shapes
        if sh["class"] == "engaged_column" and "normal" in sh and not sh.get("row_cut", False)
    ]
    if not cols or not owners:
        return 0
    faces = [
        (
            np.asarray(sh["centre"], dtype=np.float64),
            float(sh["radius"]),
            np.asarray(sh["normal"], dtype=np.float64),
            float(sh["d"]),
        )
        for sh in owners
    ]
    centres = np.array([np.asarray(shapes[k]["centre"], dtype=np.float64) for k in cols])
    radii = np.array([float(shapes[k]["radius"]) for k in cols])
    rings = column_rings(p, order, z_sorted, [shapes[k] for k in cols], h_sec, sc, RING_SLAB_M)
    found = face_row_columns(centres, radii, rings, faces, sc.tol, params)
    for i, j in found.items():
        sh, owner = shapes[cols[i]], owners[j]
        r = float(sh["radius"])
        sh["class"] = "engaged_column"
        sh.update(normal=faces[j][2].copy(), d=faces[j][3], face_gap=owner["face_gap"], angle=0.0)
        sh["half"] = np.array([r, r])
    return len(found)
