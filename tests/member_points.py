"""Points sampled on a generated timber member's faces, the F1 of a found beam against
a member's points, the classes of the beams found on a roof draw, a facet along x
made from given points and a cuboid along given directions, shared by the beams tests."""

from __future__ import annotations

import numpy as np


def surface_points(m, n: int, noise: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` points uniform by area on the (bent, twisted) lateral and end faces of a
    member (:class:`pyheracles.synthetic` member with ``triangles()``), with Gaussian
    noise of ``noise`` metres."""
    tri = m.triangles()
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    k = rng.choice(len(tri), n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    pts = (
        (1 - s)[:, None] * tri[k, 0]
        + (s * (1 - r2))[:, None] * tri[k, 1]
        + (s * r2)[:, None] * tri[k, 2]
    )
    return pts + rng.normal(0.0, noise, pts.shape)


def best_f1(truth: np.ndarray, labels: np.ndarray, member: int) -> float:
    """Best F1 of a found beam (``labels`` > 0) against the points of ``member`` in
    ``truth``."""
    mine = truth == member
    counts = np.bincount(labels[mine], minlength=labels.max() + 1)
    if len(counts) < 2 or counts[1:].max() == 0:
        return 0.0
    best = int(counts[1:].argmax()) + 1
    return 2 * counts[best] / (mine.sum() + (labels == best).sum())


def found_classes(seed: int, noise_draw: int) -> list[str]:
    """The class most of each found beam's points belong to, on a roof draw."""
    from pyheracles.beams import segment_beams
    from pyheracles.synthetic.families import simulate

    sim = simulate("roof", seed, noise_draw=noise_draw)
    cloud = sim.clouds["cloud"]
    result = segment_beams(cloud.xyz)
    names = sim.scene.class_names
    good = ~cloud.outlier
    out = []
    for i in range(1, len(result.beams) + 1):
        counts = np.bincount(cloud.class_id[(result.labels == i) & good], minlength=max(names) + 1)
        out.append(names[int(counts.argmax())])
    return out


def facet_along_x(xyz: np.ndarray, index: np.ndarray, normal: np.ndarray):
    """The :class:`~pyheracles.beams.model.StraightFacet` of the points ``xyz[index]``
    of a beam running along x, with face normal ``normal`` (``test_beams_hidden_side_surface``,
    ``test_beams_seen_side_corner``)."""
    from pyheracles.beams.model import StraightFacet

    x = np.array([1.0, 0.0, 0.0])
    pts = xyz[index]
    return StraightFacet(
        index=index,
        normal=normal,
        axis=x,
        centre=pts.mean(axis=0),
        width=float(np.ptp(pts @ np.cross(normal, x))),
        length=float(np.ptp(pts @ x)),
        plane_rms=float(np.std((pts - pts.mean(axis=0)) @ normal)),
        parent=1,
    )


def oriented_cuboid(
    centre,
    axis,
    side,
    length: float,
    width: float,
    height: float,
    *,
    faces_seen: int = 1,
    rms: float = 0.0,
):
    """A beam cuboid of the given sizes (metres) along ``axis``, its width along ``side``
    made square to the axis, seen on ``faces_seen`` faces (one facet each) with its depth
    measured."""
    from pyheracles.beams.model import BeamCuboid

    a = np.asarray(axis, float) / np.linalg.norm(axis)
    s = np.asarray(side, float) - (np.asarray(side, float) @ a) * a
    s /= np.linalg.norm(s)
    return BeamCuboid(
        centre=np.asarray(centre, float),
        axes=np.column_stack([a, s, np.cross(a, s)]),
        length=length,
        width=width,
        height=height,
        rms=rms,
        n_facets=faces_seen,
        faces_seen=faces_seen,
        height_measured=True,
    )
