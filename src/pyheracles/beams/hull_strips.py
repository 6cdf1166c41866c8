"""Boxes fitted to a member's face and the strip of boarding beside it: air, not a member.

A common rafter's side face meets the boarding it carries at an inside corner.
Grouped together, the side face and the strip of boarding beside it are two
straight bands at a right angle, and the box fitted to them lies in the air
beside the rafter: its top is the boarding, its side the rafter's face seen
from outside (roof seed 21: a box 12 cm wide beside common rafter 5, 5423
boarding points and the rafter's side face; seed 3: beside common rafter 32).
:func:`~pyheracles.beams.surfaces.seen_from_behind` judges corners of two
hull surfaces (a gable wall under the boarding); here one of the two faces is
a member's side, inside the room, so it has no room's side and that test does
not apply.

What tells the box apart is its two kinds of facets.  The strip is a strip of
the room's hull: the box lies on the room's side of it, nothing lies behind it
within a member's depth, and its plane goes on past one of its edges
(:func:`~pyheracles.beams.surfaces.hull_strip`).  No member is seen on its
face against the boarding: that face is hidden.  The box's other facets lie
on the surface of another beam found apart (the rafter, from its underside):
they are that beam's faces, and the box is no member (its points go to the
beam whose surface they lie on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.beams.model import BeamCuboid, StraightFacet
from pyheracles.beams.surfaces import PROUD_MARGIN_M, hull_strip

__all__ = ["HullStripParams", "face_of_other_beam", "on_hull_strip"]


@dataclass(frozen=True)
class HullStripParams:
    """Parameters of :func:`on_hull_strip`.

    Attributes
    ----------
    depth_m
        The deepest member section, metres: behind a strip of the hull the
        cloud holds nothing within this depth.
    margin_m
        Points nearer than this to a plane are on it, metres.
    max_cover
        A strip has points behind it over at most this share of its length,
        and its plane goes on past an edge over all but this share.
    parallel_deg
        A facet lies on another beam's face only when its axis is parallel to
        that beam's within this angle, degrees.
    """

    depth_m: float = 0.6
    margin_m: float = PROUD_MARGIN_M
    max_cover: float = 0.2
    parallel_deg: float = 5.0


def face_of_other_beam(
    xyz: NDArray[np.float64],
    facet: StraightFacet,
    beams: list[BeamCuboid],
    own: int,
    tol_m: float,
    cos_par: float,
) -> bool:
    """Whether a facet lies on the surface of one of ``beams`` other than ``beams[own]``.

    Its axis parallel to that beam's (``cos_par``), and the median distance of
    its points (``xyz[facet.index]``) to that beam's box within ``tol_m``.
    """
    pts = xyz[facet.index]
    for k, b in enumerate(beams):
        if k == own or abs(float(b.axis @ facet.axis)) < cos_par:
            continue
        if float(np.median(np.abs(b.signed_distance(pts)))) <= tol_m:
            return True
    return False


def on_hull_strip(
    xyz: NDArray[np.float64],
    beams: list[BeamCuboid],
    own: int,
    facets: list[StraightFacet],
    tree: cKDTree,
    probe: NDArray[np.float64],
    tol_m: float,
    p: HullStripParams | None = None,
) -> bool:
    """Whether ``beams[own]`` is the air beside a member's face, under a strip of the hull.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points the facets index, metres.
    beams
        All cuboids found.
    own
        Index of the cuboid judged.
    facets
        Its facets.
    tree
        KD-tree on the cloud.
    probe
        A sample of the cloud (the room's side of a plane).
    tol_m
        Surface tolerance, metres: a facet within it of another beam's box lies
        on that beam.
    p
        :class:`HullStripParams`.

    Returns
    -------
    bool
        True when at least one facet is a strip of the hull on whose room's
        side the box lies, and every other facet (at least one) lies on the
        surface of another beam.
    """
    p = p or HullStripParams()
    if len(facets) < 2:
        return False
    cub = beams[own]
    strip = np.array(
        [hull_strip(f, cub.centre, tree, probe, p.depth_m, p.margin_m, p.max_cover) for f in facets]
    )
    if not strip.any() or strip.all():
        return False
    cos_par = float(np.cos(np.radians(p.parallel_deg)))
    return all(
        face_of_other_beam(xyz, f, beams, own, tol_m, cos_par)
        for f, s in zip(facets, strip, strict=True)
        if not s
    )
