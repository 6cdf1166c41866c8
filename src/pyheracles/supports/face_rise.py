"""Whether the wall face beside an engaged column rises with it, seen along the wall.

An engaged column's wall is tested over the column's height
(:func:`~pyheracles.supports.cookies.face_cover`) on the points of its cookie: a few
decimetres of the face on either side of the shaft.  There the face is often not seen:
the shaft shadows it from a station on one side, and an opening (a door, a window, a
reveal) beside the column leaves a stretch of face a cookie wide or less on the other
(supports draw 0: two engaged columns of a hypostyle, 0.17 m radius, the face in 0 and 5
% of the layers of their cookies, in every layer a metre along the wall).  Here the face
is followed along the wall's own line, ``FACE_REACH_M`` beyond the shaft on either side:
a wall rises there in most layers of the column's height, a fence rail, a bench, a
pew's back or a railing in a few.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array

#: How far along the wall's line, beyond the shaft on either side, the face is sought
#: (metres).
FACE_REACH_M = 1.0
#: Depth off a wall's face, on either side, searched for points (metres): a wall is
#: solid behind it and the room is open in front of it; the surface of a neighbouring
#: column that the line cuts or touches goes on there (a twin column of 0.63 m radius
#: fills 0.39 m of a 6 cm band along its tangent).
OFF_FACE_M = 0.15


@dataclass(frozen=True)
class FaceRiseParams:
    """Parameters of :func:`face_rise`.

    Attributes
    ----------
    reach_m
        Stretch of the wall's face searched on either side of the shaft, beyond its
        circle, metres.
    cell_m
        Cells along the face, metres.
    fill_m
        A layer holds the face when its face points on one side of the shaft fill
        cells of at least this much length along the face, metres (a post or a pipe
        beside a column fills its own width only; the line through a neighbouring
        column's shaft meets its surface in two bits a few centimetres long).
    off_share
        ... and has fewer cells with points ``OFF_FACE_M`` or less off the face than
        this share of its face cells (a wall is solid behind its face, the room open in
        front of it).
    max_layers
        Largest number of height layers tested.
    """

    reach_m: float = FACE_REACH_M
    cell_m: float = 0.05
    fill_m: float = 0.3
    off_share: float = 0.5
    max_layers: int = 40


def face_points(
    xy: Array,
    centre: Array,
    radius: float,
    normal: Array,
    d: float,
    gap: float,
    reach: float,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], Array]:
    """The points of ``xy`` on a wall's face line beside a shaft, and just off it.

    Parameters
    ----------
    xy
        ``(N, 2)`` plan positions, metres.
    centre, radius
        The shaft's circle, metres.
    normal, d
        The face line, ``normal . x = d`` on it (unit normal).
    gap
        Largest offset from the line of a point of the face, metres.
    reach
        Stretch along the line beyond the circle on either side, metres.

    Returns
    -------
    (on, off, along)
        Masks of the points on the face and of those ``OFF_FACE_M`` or less off it on
        either side (none at a wall but in its openings and at mouldings or clutter),
        both outside the circle and within reach, and every point's position along the
        line from the centre (metres).
    """
    t = np.array([-normal[1], normal[0]])
    q = xy - centre
    along = q @ t
    front = xy @ normal - d
    beside = (np.abs(along) > radius) & (np.abs(along) <= radius + reach)
    on = beside & (np.abs(front) <= gap)
    off = beside & (np.abs(front) > gap) & (np.abs(front) <= gap + OFF_FACE_M)
    return on, off, along


def face_rise(
    z: Array,
    along: Array,
    off: NDArray[np.bool_],
    z_range: tuple[float, float],
    layer: float,
    params: FaceRiseParams = FaceRiseParams(),
) -> float:
    """Share of the height layers in which a wall's face beside a shaft is seen (0..1).

    Parameters
    ----------
    z, along
        Heights and positions along the face (from the shaft's centre, signed) of the
        face's points and of those just off it (:func:`face_points`), metres.
    off
        Which of them lie just off the face: a layer's side with half as many cells off
        the face as on it is no wall face (a neighbouring column cut or touched by the
        line).
    z_range
        Floor and top of the column, metres.
    layer
        Smallest layer height, metres (the layers are ``max(layer, height /
        params.max_layers)`` tall).
    params
        :class:`FaceRiseParams`.

    Returns
    -------
    float
        Share of the layers whose points on one side of the shaft fill at least
        ``params.fill_m`` of cells along the face; 0 for an empty range.
    """
    lo_z, hi_z = z_range
    if hi_z <= lo_z:
        return 0.0
    step = max(layer, (hi_z - lo_z) / params.max_layers)
    n_layers = int(np.ceil((hi_z - lo_z) / step))
    sel = (z > lo_z) & (z < hi_z)
    if not sel.any():
        return 0.0
    iz = np.minimum(((z[sel] - lo_z) / step).astype(np.int64), n_layers - 1)
    a = along[sel]
    ia = np.floor(np.abs(a) / params.cell_m).astype(np.int64)
    m = int(ia.max()) + 1
    group = (iz * 2 + (a > 0)) * 2 + off[sel]  # layer, side, off the face
    keys = np.unique(group * m + ia)  # occupied cells
    per = np.bincount(keys // m, minlength=4 * n_layers).reshape(n_layers, 2, 2)
    need = int(np.ceil(params.fill_m / params.cell_m))
    face, beside = per[:, :, 0], per[:, :, 1]
    held = ((face >= need) & (beside < params.off_share * face)).any(axis=1)
    return float(np.count_nonzero(held)) / n_layers


def face_rise_along_wall(
    p: Array,
    height_band: Callable[[float, float], NDArray[np.intp]],
    sh: dict,
    tol: float,
    z_range: tuple[float, float],
    layer: float,
    params: FaceRiseParams = FaceRiseParams(),
) -> float:
    """:func:`face_rise` of an engaged column's shape ``sh`` (``centre``, ``radius``,
    ``normal``, ``d``, ``face_gap``) on the points of ``p`` between the heights of
    ``z_range`` (``height_band`` gives their indices), within ``params.reach_m`` of
    the shaft along its wall, leaving out the points within ``3 x tol`` of the other
    supports' shapes (``sh["neighbours"]``: rows of centre x, y and reach, metres;
    :func:`neighbour_discs`): a twin column's shaft beside it is no wall (supports draw
    18: twin columns of 0.63 m radius, the line touching the twin's shaft 0.6 m long)."""
    idx = height_band(*z_range)
    if len(idx) == 0:
        return 0.0
    c = np.asarray(sh["centre"], dtype=np.float64)
    r = float(sh["radius"])
    reach = r + params.reach_m
    xy = p[idx, :2]
    box = (np.abs(xy[:, 0] - c[0]) <= reach) & (np.abs(xy[:, 1] - c[1]) <= reach)
    idx = idx[box]
    others = np.asarray(sh.get("neighbours", np.zeros((0, 3))), dtype=np.float64)
    if len(others):  # another support's surface is no wall (a twin column beside it)
        xy = p[idx, :2]
        clear = np.ones(len(idx), dtype=bool)
        for ox, oy, o_reach in others:  # loop over the few shapes within reach
            clear &= np.hypot(xy[:, 0] - ox, xy[:, 1] - oy) > o_reach + 3.0 * tol
        idx = idx[clear]
    on, off, along = face_points(
        p[idx, :2], c, r + 2.0 * tol, sh["normal"], sh["d"], max(sh["face_gap"], tol),
        params.reach_m,
    )  # fmt: skip
    sel = on | off
    return face_rise(p[idx[sel], 2], along[sel], off[sel], z_range, layer, params)


def neighbour_discs(centres: Array, reaches: Array, k: int, reach_m: float) -> Array:
    """The discs (rows of centre x, y and reach, metres) of the shapes other than
    shape ``k`` that come within ``reach_m`` of its disc (``centres`` ``(S, 2)``,
    ``reaches`` ``(S,)``: how far each shape reaches from its centre)."""
    gap = np.hypot(*(centres - centres[k]).T) - reaches - reaches[k]
    near = gap <= reach_m
    near[k] = False
    return np.c_[centres[near], reaches[near]]
