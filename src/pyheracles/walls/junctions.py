"""Junctions: a wall cut where another wall abuts it along its length (a T junction).

A church's west or east front is one plane from one aisle's outer corner to the
other's, but three walls: the nave's gable and the two aisles' end walls, parted where
the nave's side walls (the arcades) meet it.  Inside, the front's face is interrupted
by each arcade's end; outside, one face runs on.  The wall graph of a BIM model has a
node there, and the front is cut into the walls between its junctions.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from pyheracles.walls.model import Array, WallFace, WallParams

__all__ = ["beside_columns", "building_side", "cut_faces", "junction_cuts", "run_ends"]

#: width of the columns of a face (m) in which it is seen to run on beside a junction
_COLUMN_M = 0.1


#: share of the columns that make a face run on beside a junction (80 % of
#: ``min_length_m``) below which it stops there: a stray return or two, not a face
_BARE_FRACTION = 0.25

#: points of a wall within one column (``_COLUMN_M``) that make an end of it
_END_POINTS = 5


def _extent(xyz: Array, w: dict[str, Any]) -> tuple[float, float, float]:
    """A draft wall's ends along its ``u`` axis (:func:`run_ends`) and its points'
    median height."""
    idx = np.concatenate([f.indices for f in w["faces"]])
    q = xyz[idx] - w["origin"]
    lo, hi = run_ends(q @ w["u_axis"])
    return lo, hi, float(np.median(xyz[idx, 2]))


def run_ends(u: Array, n: int = _END_POINTS, width: float = _COLUMN_M) -> tuple[float, float]:
    """The ends of a wall's points ``u`` (m along it): the first and last point with
    ``n`` points in a ``width`` m column from it inwards; a stray return standing
    apart beyond the wall's end is not its end (the extremes when fewer points).

    Church draw 12: one isolated return 0.6 m past the east end of the south arcade's
    aisle face put the arcade's end 0.84 m beyond the east wall's mid-plane, no
    junction, and the south aisle's east wall stayed in the east gable.

    Examples
    --------
    >>> import numpy as np
    >>> run_ends(np.r_[np.linspace(0.0, 4.0, 401), 4.6])
    (0.0, 4.0)
    """
    v = np.sort(np.asarray(u, dtype=np.float64))
    if len(v) < n:
        return float(v[0]), float(v[-1])
    dense = np.flatnonzero(v[n - 1 :] - v[: len(v) - n + 1] <= width)
    if len(dense) == 0:
        return float(v[0]), float(v[-1])
    return float(v[dense[0]]), float(v[dense[-1] + n - 1])


def beside_columns(u: Array, reach: float) -> tuple[int, int]:
    """How many ``_COLUMN_M`` columns hold points of a face within ``reach`` m of a
    junction, on either side of it: ``u`` are the face's positions along its wall
    from the junction (negative side first).

    Examples
    --------
    >>> import numpy as np
    >>> beside_columns(np.r_[np.linspace(-0.95, -0.05, 10), 0.35], 1.0)
    (10, 1)
    """
    v = np.asarray(u, dtype=np.float64)
    out = []
    for s in (-1.0, 1.0):
        w = s * v
        out.append(len(np.unique(np.floor(w[(w > 0) & (w <= reach)] / _COLUMN_M))))
    return out[0], out[1]


def _face_u(xyz: Array, w: dict[str, Any], f: WallFace) -> Array:
    return (xyz[f.indices] - w["origin"]) @ w["u_axis"]


def building_side(xyz: Array, walls: list[dict[str, Any]], k: int,
                  every: int = 8) -> float:  # fmt: skip
    """The side of wall ``k`` (+1/-1 along its normal) where the rest of the building
    stands: the side holding more of the other walls' face points (one in ``every``)
    over the wall's stretch; 0 when as many lie on either side."""
    w = walls[k]
    idx = np.concatenate([f.indices[::every] for m, v in enumerate(walls) if m != k
                          for f in v["faces"]])  # fmt: skip
    if len(idx) == 0:
        return 0.0
    q = xyz[idx] - w["origin"]
    u = q @ w["u_axis"]
    own = np.concatenate([f.indices for f in w["faces"]])
    uo = (xyz[own] - w["origin"]) @ w["u_axis"]
    depth = xyz[idx] @ np.asarray(w["normal"]) - float(w["d"])
    half = 0.5 * float(w["thickness"]) if math.isfinite(float(w["thickness"])) else 0.0
    over = (u >= uo.min()) & (u <= uo.max()) & (np.abs(depth) > half + 0.1)
    return float(np.sign(np.sum(np.sign(depth[over]))))


def junction_cuts(xyz: Array, walls: list[dict[str, Any]], p: WallParams) -> list[list[float]]:
    """Where each draft wall is cut by walls abutting it: sorted ``u`` positions per wall.

    A wall ``B`` abuts a wall ``A`` when ``B`` makes at least 30 deg with ``A``, one
    of ``B``'s ends lies at ``A`` (within ``A``'s half thickness and 0.3 m of its
    mid-plane, on either side: a nave wall's outer face above an aisle's roof runs on
    to the front's outer corner, church draws 20 and 29; a wall seen on one face: within
    ``max_thickness_m`` of that face towards ``B`` and 0.3 m past it; ``B``'s ends
    from :func:`run_ends`), and
    ``B`` runs on from there, on the side of ``A`` where the building stands
    (:func:`building_side`), by at least twice ``min_length_m``.  ``A`` is cut at
    ``B``'s plane when that lies at least ``min_length_m`` inside ``A``'s ends (a
    corner is no junction), and when ``A``'s face on ``B``'s side runs on beside ``B``
    on both sides: at least 80 % of ``min_length_m`` covered in 0.1 m columns within
    ``min_length_m`` plus ``B``'s thickness (``max_thickness_m`` when not measured) of
    ``B``'s plane; or, ``A`` seen on both faces, when that face runs on beside ``B`` on
    one side and stops at ``B`` on the other (fewer than a quarter of those columns,
    ``_BARE_FRACTION``) while ``A``'s other face runs on beside ``B`` on both: the
    front's inner face ends at the arcade where the aisle's end behind it is not seen,
    and its outer face, running on, is the aisle's end wall seen on one face (church
    draws 15 and 25: a south tower built into the aisle's west end hides it, and the
    aisle's west wall was part of the nave's).  An apse, a chancel, a tower, a porch or
    a buttress is built against a wall from outside, and their walls do not cut it (the
    front of a church is one wall with its tower, and the east wall one with its apse,
    whose arch opens in it); the walls dividing the building inside (the arcades
    between nave and aisles) do.  A tower's walls also meet the front's outer face
    where that face stops (not seen inside the tower).  Cuts closer than
    ``min_length_m`` are one, at their mean.
    """
    ext = [_extent(xyz, w) for w in walls]
    cos_max = math.cos(math.radians(30.0))
    cuts: list[list[float]] = [[] for _ in walls]
    for a, wa in enumerate(walls):
        na = np.asarray(wa["normal"], dtype=np.float64)
        a0, a1, _ = ext[a]
        thick_a = float(wa["thickness"])
        half_a = 0.5 * thick_a if math.isfinite(thick_a) else p.max_thickness_m
        found: list[float] = []
        inside: float | None = None
        for b, wb in enumerate(walls):
            if b == a:
                continue
            ub = np.asarray(wb["u_axis"], dtype=np.float64)
            c = float(na[:2] @ ub[:2]) / float(np.hypot(na[0], na[1]))
            if abs(c) < 1.0 - cos_max:  # B's axis within 30 deg of A's plane: no junction
                continue
            b0, b1, zb = ext[b]
            ob = np.asarray(wb["origin"], dtype=np.float64)
            # B's axis meets A's mid-plane at height zb: na . (ob + t ub) = d - na_z zb
            t_x = (float(wa["d"]) - float(na[2]) * zb - float(na[:2] @ ob[:2])) / float(
                na[:2] @ ub[:2]
            )
            near, far = (b0, b1) if abs(b0 - t_x) <= abs(b1 - t_x) else (b1, b0)
            body = math.copysign(1.0, far - t_x)
            gap = body * (near - t_x) * abs(c)  # B's end from A's mid-plane, towards B
            if not (-half_a if math.isfinite(thick_a) else 0.0) - 0.3 <= gap <= half_a + 0.3:
                continue
            if abs(far - t_x) * abs(c) < 2.0 * p.min_length_m:
                continue
            x = ob[:2] + t_x * ub[:2]
            u_x = float((x - np.asarray(wa["origin"])[:2]) @ np.asarray(wa["u_axis"])[:2])
            if not a0 + p.min_length_m <= u_x <= a1 - p.min_length_m:
                continue
            side = body * math.copysign(1.0, c)  # along na, towards B's body
            if inside is None:
                inside = building_side(xyz, walls, a)
            if side != inside:
                continue
            # A's face on B's side
            fa = max(wa["faces"], key=lambda f: side * float(f.d) * math.copysign(
                1.0, float(f.normal @ na)))  # fmt: skip
            thick_b = float(wb["thickness"])
            reach = p.min_length_m + (thick_b if math.isfinite(thick_b) else p.max_thickness_m)
            need = 0.8 * p.min_length_m / _COLUMN_M
            near_cols = beside_columns(_face_u(xyz, wa, fa) - u_x, reach)
            ok = min(near_cols) >= need
            if not ok and len(wa["faces"]) == 2:  # A's face on B's side stops at B
                fo = next(f for f in wa["faces"] if f is not fa)
                far_cols = beside_columns(_face_u(xyz, wa, fo) - u_x, reach)
                ok = (min(far_cols) >= need and max(near_cols) >= need
                      and min(near_cols) <= _BARE_FRACTION * need)  # fmt: skip
            if ok:
                found.append(u_x)
        found.sort()
        merged: list[list[float]] = []
        for u in found:
            if merged and u - merged[-1][-1] < p.min_length_m:
                merged[-1].append(u)
            else:
                merged.append([u])
        cuts[a] = [float(np.mean(m)) for m in merged]
    return cuts


def cut_faces(xyz: Array, faces: list[WallFace], walls: list[dict[str, Any]],
              cuts: list[list[float]], p: WallParams) -> list[WallFace]:  # fmt: skip
    """Faces cut at the junctions of the walls (:func:`junction_cuts`), to be paired again.

    Every face parallel to a cut wall (within ``parallel_deg``) and on the plane of
    one of its faces (within ``distance_m``), whether in that wall or not (a face's
    piece beyond a tower, paired with nothing), is cut at the wall's cuts: its points
    on either side, on the same plane.  Pieces shorter than half ``min_length_m`` or
    lower than ``min_height_m`` (a sliver between a junction and the end of a face,
    within the abutting wall's half thickness) are no face.  A longer piece is a face
    cut from one found whole: an aisled front's outer face beside a tower runs on past
    the arcade's mid-plane, where the nave's piece is cut off it (church draw 29: 1.0 m
    of it beside the tower, 11 m high, fell under ``min_length_m`` and the nave's west
    wall was seen on its inner face only).
    """
    cos_par = math.cos(math.radians(p.parallel_deg))
    out = list(faces)
    for w, cs in zip(walls, cuts, strict=True):
        if not cs:
            continue
        na = np.asarray(w["normal"], dtype=np.float64)
        planes = [(f.normal, f.d) for f in w["faces"]]
        nxt: list[WallFace] = []
        for f in out:
            c = float(f.normal @ na)
            on = abs(c) >= cos_par and any(
                abs(f.d - math.copysign(1.0, float(f.normal @ n)) * d) <= p.distance_m
                for n, d in planes
            )
            u = (xyz[f.indices] - w["origin"]) @ w["u_axis"]
            if not on or not any(u.min() < x < u.max() for x in cs):
                nxt.append(f)
                continue
            bounds = [-math.inf, *cs, math.inf]
            for lo, hi in itertools.pairwise(bounds):
                keep = (u >= lo) & (u < hi)
                part = xyz[f.indices[keep]]
                if (len(part) < 30 or np.ptp(part @ w["u_axis"]) < 0.5 * p.min_length_m
                        or np.ptp(part[:, 2]) < p.min_height_m):  # fmt: skip
                    continue
                idx = f.indices[keep]
                rms = float(np.sqrt(np.mean((xyz[idx] @ f.normal - f.d) ** 2)))
                nxt.append(WallFace(f.normal, f.d, idx, rms))
        out = nxt
    return out
