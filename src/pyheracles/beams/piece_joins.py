"""Pieces of one member seen on one face, apart by a shadow: one face, one line, one width.

A member far from the stations is often seen on one face only, and in pieces:
a nearer member shadows a stretch of it (1-3 m on a far slope), and each piece
becomes a one-face cuboid.  Two such pieces have no located section
(:func:`~pyheracles.beams.cuboids.same_section` needs a piece seen on two
faces); their depth behind the face is not measured or measured from a few
side points, so their sections differ by centimetres.  What they share is the
face: the same plane, the same width across it and the same centre line.  Two
one-face pieces that share their face, apart along it by no more than the
scan's shadow length (and no more than the longer piece is long), are pieces
of one member.  A shadow may be longer than either piece (a rafter's underside
seen in a 1.0 and a 1.5 m piece past a purlin's 1.9 m shadow): the pieces are
then joined when nothing else lies on the line between them
(:func:`gap_clear`); a member there would make them two members meeting it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.model import BeamCuboid, StraightFacet
from pyheracles.errors import InputError

__all__ = ["FaceJoinParams", "PieceFace", "gap_clear", "piece_faces", "same_face"]


@dataclass(frozen=True)
class FaceJoinParams:
    """Tolerances of :func:`same_face`.

    Attributes
    ----------
    width_share
        Face widths agree within this share of the wider one (dimensionless) ...
    width_m
        ... or within this many metres.
    across_share
        The face centre lines lie within this share of the face width of each
        other, measured across the longer piece's axis (dimensionless).
    plane_share
        The faces' planes lie within this share of the face width of each other
        (or within the surface tolerance, whichever is larger; dimensionless):
        a sagging member's face moves off a straight piece's plane by a few
        millimetres over a shadow.
    """

    width_share: float = 0.1
    width_m: float = 0.01
    across_share: float = 0.25
    plane_share: float = 0.1

    def validate(self) -> FaceJoinParams:
        for name in ("width_share", "width_m", "across_share", "plane_share"):
            if getattr(self, name) < 0:
                raise InputError(f"{name} must be >= 0, got {getattr(self, name)}")
        return self


@dataclass(frozen=True)
class PieceFace:
    """The one face a one-face piece is seen on.

    Attributes
    ----------
    normal
        ``(3,)`` unit normal (point-weighted mean of its facets' normals).
    point
        ``(3,)`` a point on the face: the median of its facets' points, metres.
    width
        The piece's size across the face (the cuboid's section size whose axis
        is the more perpendicular to ``normal``), metres.
    """

    normal: NDArray[np.float64]
    point: NDArray[np.float64]
    width: float


def piece_faces(
    xyz: NDArray[np.float64],
    facets: list[StraightFacet],
    facet_beam: NDArray[np.int32],
    cuboids: list[BeamCuboid],
) -> list[PieceFace | None]:
    """The face of every cuboid seen on one face (``None`` for the others).

    Parameters
    ----------
    xyz
        ``(N, 3)`` points, metres.
    facets
        Straight facets.
    facet_beam
        ``(len(facets),)`` 1-based cuboid of each facet, 0 = none.
    cuboids
        The cuboids.
    """
    out: list[PieceFace | None] = []
    for k, cub in enumerate(cuboids):
        own = [facets[i] for i in np.flatnonzero(facet_beam == k + 1)]
        if cub.faces_seen != 1 or not own:
            out.append(None)
            continue
        ref = max(own, key=lambda f: len(f.index)).normal
        n = np.sum([f.normal * np.sign(f.normal @ ref) * len(f.index) for f in own], axis=0)
        n = n / np.linalg.norm(n)
        pts = xyz[np.concatenate([f.index for f in own])]
        sizes = (cub.width, cub.height)
        across = int(np.argmin(np.abs(cub.axes[:, 1:].T @ n)))
        out.append(PieceFace(normal=n, point=np.median(pts, axis=0), width=float(sizes[across])))
    return out


def same_face(
    a: BeamCuboid,
    b: BeamCuboid,
    fa: PieceFace | None,
    fb: PieceFace | None,
    cos_par: float,
    plane_tol: float,
    params: FaceJoinParams | None = None,
) -> bool:
    """Whether two one-face pieces show one face of one member.

    Both seen on one face, their face normals parallel (within ``cos_par``),
    their faces' widths within ``width_share`` or ``width_m``, each face's
    point within ``max(plane_tol, plane_share x width)`` of the other's plane
    (both planes taken with the two faces' mean normal),
    and within ``across_share`` of the width of the other's centre line
    (across the axis of the longer piece, whose direction is the better
    known).  The gap along the axis is the caller's to bound.
    """
    p = params or FaceJoinParams()
    if fa is None or fb is None or a.faces_seen != 1 or b.faces_seen != 1:
        return False
    if abs(fa.normal @ fb.normal) < cos_par or abs(a.axis @ b.axis) < cos_par:
        return False
    wide = max(fa.width, fb.width)
    if abs(fa.width - fb.width) > max(p.width_share * wide, p.width_m):
        return False
    ref, fr = (a, fa) if a.length >= b.length else (b, fb)
    d = fb.point - fa.point
    # the plane of their mean normal: a short piece's normal a degree off puts a
    # face 3 m along it 5 cm off its plane (roof draw 19: +2.7 and -2.2 cm on the
    # two pieces' own normals, 0.2 cm on their mean)
    n = fa.normal + np.sign(fa.normal @ fb.normal) * fb.normal
    n /= max(float(np.linalg.norm(n)), 1e-12)
    if abs(d @ n) > max(plane_tol, p.plane_share * wide):
        return False
    across = np.cross(fr.normal, ref.axis)
    across /= max(float(np.linalg.norm(across)), 1e-12)
    return bool(abs(d @ across) <= p.across_share * wide)


def gap_clear(a: BeamCuboid, b: BeamCuboid, others: list[BeamCuboid], step_m: float = 0.05) -> bool:
    """Whether the centre line between two collinear pieces runs through no other cuboid.

    The stretch from ``a``'s end facing ``b`` to ``b``'s end facing ``a``
    (each on its own centre line, sampled every ``step_m`` metres) lies inside
    none of ``others``: the gap is a shadow on one member, not a member (a
    post, a rafter's foot) that two pieces meet from either side.  Pieces that
    overlap or touch along the axis have no gap: True.
    """
    d = b.centre - a.centre
    s = 1.0 if d @ a.axis >= 0 else -1.0
    start = a.centre + s * 0.5 * a.length * a.axis
    t = 1.0 if d @ b.axis <= 0 else -1.0
    end = b.centre + t * 0.5 * b.length * b.axis
    if (end - start) @ (s * a.axis) <= 0:
        return True
    n = max(2, int(np.ceil(float(np.linalg.norm(end - start)) / step_m)) + 1)
    line = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    return not any(np.any(o.signed_distance(line) < 0.0) for o in others)
