"""A church shell scanned outside and inside, with targets and known transforms.

The scene of thesis chapter 3 (Murtiyoso 2020): an exterior photogrammetric cloud
and an interior TLS cloud of a church that overlap only through the window
openings, sphere targets surveyed in a national grid (control and check points) and
the window corners as tie points.

Geometry (building frame, metres): a rectangular shell ``length x width x height``
with 0.6 m walls, 24 windows (8 on each long wall, 4 on each gable) of varied sizes,
each closed by a 2 cm glass pane at mid-wall.  The exterior cloud samples the outer
faces, the window reveals down to the outer face of the pane, the pane, the roof and
a ground ring (noise 5 mm); the interior cloud the inner faces, reveals down to the
inner face of the pane, floor and ceiling (noise 3 mm).  Each side is a
:class:`~pyheracles.synthetic.scene.Scene` sampled uniformly through the scan
simulator (:class:`~pyheracles.synthetic.scanner.SurfaceSampling`, no occlusion: the
idealised union of this named scene); the ray-traced version of the same case is
``pyheracles.synthetic.families.simulate("church", seed, layout="thesis")``.

Frames: ``world`` is a national grid (Lambert-93-like 7-digit coordinates); the
exterior cloud is in an arbitrary photogrammetric model frame (similarity, scale !=
1), the interior cloud in the scanner's levelled frame (rigid).  The true transforms
``T_world_exterior`` and ``T_world_interior`` are returned.

Tie point definition: a window corner is the point where two reveal planes meet the
*mid-plane* of the pane, so that the same physical point is seen from both sides
(pane face +/- 1 cm along its normal).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray
from shapely.geometry import box

from pyheracles.cloud import PointCloud
from pyheracles.registration.points import PointList
from pyheracles.registration.similarity import similarity_matrix
from pyheracles.synthetic.scanner import SurfaceSampling, scan
from pyheracles.synthetic.scene import Scene

__all__ = ["ChurchParams", "ChurchScene", "make_church"]

SURFACE_CODES = {1: "wall", 2: "reveal", 3: "pane", 4: "roof_or_ceiling", 5: "ground", 6: "target"}


@dataclass(frozen=True)
class ChurchParams:
    """Parameters of :func:`make_church` (metres and degrees).

    Attributes
    ----------
    length_m, width_m, height_m
        Outer dimensions of the shell.
    wall_m
        Wall thickness (0.6 m, issue 5).
    pane_m
        Glass pane thickness (2 cm), centred in the wall.
    spacing_m
        Mean point spacing on walls, roof, floor, ground.
    window_spacing_m
        Mean point spacing on window reveals and panes (scanned closer/denser).
    exterior_noise_m, interior_noise_m
        Gaussian noise per coordinate of the exterior (photogrammetry, 5 mm) and the
        interior (TLS, 3 mm) clouds, in object space.
    target_radius_m
        Radius of the sphere targets (a common 145 mm sphere).
    target_spacing_m
        Point spacing on the spheres.
    control_sigma_m
        Standard deviation of the surveyed target coordinates (total station).
    manual_pick_sigma_m
        Standard deviation of a manually picked tie point (window corner) per coordinate.
    n_manual_ties
        Number of window corners picked manually as tie points.
    """

    length_m: float = 30.0
    width_m: float = 12.0
    height_m: float = 10.0
    wall_m: float = 0.6
    pane_m: float = 0.02
    spacing_m: float = 0.08
    window_spacing_m: float = 0.03
    exterior_noise_m: float = 0.005
    interior_noise_m: float = 0.003
    target_radius_m: float = 0.0725
    target_spacing_m: float = 0.01
    control_sigma_m: float = 0.003
    manual_pick_sigma_m: float = 0.01
    n_manual_ties: int = 36


@dataclass(frozen=True, eq=False)
class ChurchScene:
    """Generated church data with ground truth (see module docstring for frames)."""

    exterior: PointCloud
    interior: PointCloud
    T_world_exterior: NDArray[np.float64]
    T_world_interior: NDArray[np.float64]
    control: PointList  # world, surveyed (with noise and sigmas)
    check: PointList  # world, surveyed
    targets_true_world: PointList  # true sphere centres (control + check)
    targets_exterior: PointList  # approximate target positions in the exterior frame
    targets_interior: PointList  # approximate target positions in the interior frame
    manual_ties_exterior: PointList
    manual_ties_interior: PointList
    corners_world: PointList  # true window corners (on the pane mid-plane)
    windows: pd.DataFrame
    params: ChurchParams

    @property
    def T_exterior_interior(self) -> NDArray[np.float64]:
        """True transform from the interior frame into the exterior frame."""
        return np.linalg.inv(self.T_world_exterior) @ self.T_world_interior


# ----------------------------------------------------------------------------- surfaces
@dataclass(frozen=True)
class _Wall:
    origin: NDArray[np.float64]  # outer face, bottom, u = 0
    u: NDArray[np.float64]  # along the wall (unit)
    d: NDArray[np.float64]  # into the wall (unit, = -outward normal)
    length: float


def _walls(p: ChurchParams) -> list[_Wall]:
    L, W = p.length_m, p.width_m
    ex, ey = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    return [
        _Wall(np.array([0.0, 0, 0]), ex, ey, L),  # south
        _Wall(np.array([L, 0.0, 0]), ey, -ex, W),  # east (gable)
        _Wall(np.array([L, W, 0.0]), -ex, -ey, L),  # north
        _Wall(np.array([0.0, W, 0]), -ey, ex, W),  # west (gable)
    ]


def _windows(p: ChurchParams, rng: np.random.Generator) -> pd.DataFrame:
    rows = []
    counts = (8, 4, 8, 4)
    for wall_id, (wall, n) in enumerate(zip(_walls(p), counts, strict=True)):
        slot = wall.length / n
        for k in range(n):
            w = float(rng.uniform(0.9, min(1.8, slot - 1.0)))
            h = float(rng.uniform(1.8, 3.6))
            z0 = float(rng.uniform(2.0, p.height_m - 1.2 - h))
            uc = (k + 0.5) * slot + float(rng.uniform(-0.25, 0.25)) * (slot - w - 0.6)
            uc = float(np.clip(uc, 1.0 + w / 2, wall.length - 1.0 - w / 2))
            rows.append({"wall": wall_id, "u_center": uc, "width": w, "sill": z0, "height": h})
    return pd.DataFrame(rows)


def _wall_frame(wall: _Wall) -> NDArray[np.float64]:
    """Rows (u, z, into the wall) of a wall's face frame."""
    return np.vstack([wall.u, [0.0, 0.0, 1.0], wall.d])


def _side_scene(
    p: ChurchParams, wins: pd.DataFrame, side: str, targets: NDArray[np.float64]
) -> Scene:
    """The surfaces seen from ``side`` ('exterior'/'interior'), parts named by surface code.

    Exterior: outer wall faces, the reveals down to the outer face of the pane, the
    pane's outer face, the flat roof and a 3 m ground ring; interior: inner faces, the
    reveals from the pane's inner face, its inner face, floor (code 5) and ceiling.
    Sphere targets without their bottom cap (hidden by the tripod).
    """
    t, half = p.wall_m, p.pane_m / 2
    H = p.height_m if side == "exterior" else p.height_m - t
    scene = Scene()
    names = SURFACE_CODES
    for wall_id, wall in enumerate(_walls(p)):
        ww = wins[wins.wall == wall_id]
        if side == "exterior":
            depth, u0, u1, d_a, d_b = 0.0, 0.0, wall.length, 0.0, t / 2 - half
        else:
            depth, u0, u1, d_a, d_b = t, t, wall.length - t, t / 2 + half, t
        R = _wall_frame(wall)
        holes = [
            box(w.u_center - w.width / 2, w.sill, w.u_center + w.width / 2, w.sill + w.height)
            for w in ww.itertuples()
        ]
        face = box(u0, 0.0, u1, H).difference(shapely.union_all(holes))
        scene.add_prism(
            face, wall.origin + depth * wall.d, R, 0.0, faces="front", sides=False, part=names[1]
        )
        ez = np.array([0.0, 0.0, 1.0])
        for w in ww.itertuples():  # 24 windows in all
            ua, ub = w.u_center - w.width / 2, w.u_center + w.width / 2
            za, zb = w.sill, w.sill + w.height
            c = [
                wall.origin + ua * wall.u + za * ez,
                wall.origin + ub * wall.u + za * ez,
                wall.origin + ub * wall.u + zb * ez,
                wall.origin + ua * wall.u + zb * ez,
            ]
            for i in range(4):  # four reveals between the face and the pane
                a, b = c[i], c[(i + 1) % 4]
                scene.add_quad(
                    [a + d_a * wall.d, b + d_a * wall.d, b + d_b * wall.d, a + d_b * wall.d],
                    part=names[2],
                )
            pane_depth = t / 2 - half if side == "exterior" else t / 2 + half
            scene.add_quad([x + pane_depth * wall.d for x in c], part=names[3])
    L, W = p.length_m, p.width_m
    flat = np.eye(3)
    if side == "exterior":
        scene.add_prism(
            box(0, 0, L, W), [0, 0, H], flat, 0.0, faces="front", sides=False, part=names[4]
        )
        ring = box(-3.0, -3.0, L + 3.0, W + 3.0).difference(box(0, 0, L, W))
        scene.add_prism(ring, [0, 0, 0], flat, 0.0, faces="front", sides=False, part=names[5])
    else:
        inner = box(t, t, L - t, W - t)
        scene.add_prism(inner, [0, 0, 0], flat, 0.0, faces="front", sides=False, part=names[5])
        scene.add_prism(inner, [0, 0, H], flat, 0.0, faces="front", sides=False, part=names[4])
    for c in targets:  # the bottom cap below 30 deg under the equator is hidden
        scene.add_triangles(_cap_sphere(c, p.target_radius_m), part=names[6])
    return scene


def _cap_sphere(centre: NDArray[np.float64], radius: float, n: int = 48) -> NDArray[np.float64]:
    """Triangles of a sphere without its bottom cap (polar angle up to 120 deg)."""
    th = np.linspace(0.0, np.radians(120.0), n // 3 + 1)
    ph = np.linspace(0.0, 2 * np.pi, n + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pts = centre + radius * np.stack(
        [np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1
    )
    a, b, c, d = pts[:-1, :-1], pts[:-1, 1:], pts[1:, 1:], pts[1:, :-1]
    tris = np.concatenate(
        [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
    )
    area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > 1e-12]


def _sample_side(
    p: ChurchParams,
    wins: pd.DataFrame,
    side: str,
    targets: NDArray[np.float64],
    noise: float,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Points (building frame, with noise) and surface codes: the side's surfaces sampled
    uniformly through the scan simulator (:class:`~pyheracles.synthetic.scanner.SurfaceSampling`:
    walls, roof, ceiling, floor and ground at ``spacing_m``, reveals and panes at
    ``window_spacing_m``, spheres at ``target_spacing_m``)."""
    scene = _side_scene(p, wins, side, targets)
    n = SURFACE_CODES
    acq = [
        SurfaceSampling(p.spacing_m, noise, parts=(n[1], n[4], n[5])),
        SurfaceSampling(p.window_spacing_m, noise, parts=(n[2], n[3])),
        SurfaceSampling(p.target_spacing_m, noise, parts=(n[6],)),
    ]
    res = scan(scene, acq, rng=rng)
    code_of = np.zeros(max(scene.part_names) + 1, np.uint8)
    for k, name in scene.part_names.items():
        code_of[k] = next((c for c, v in n.items() if v == name), 0)
    return res.xyz, code_of[res.part]


def _corners(p: ChurchParams, wins: pd.DataFrame) -> NDArray[np.float64]:
    """(n_windows, 4, 3) window corners on the pane mid-plane (building frame)."""
    walls = _walls(p)
    out = np.zeros((len(wins), 4, 3))
    for i, w in enumerate(wins.itertuples()):
        wall = walls[w.wall]
        mid = wall.origin + (p.wall_m / 2) * wall.d
        for k, (du, z) in enumerate(
            [(-1, w.sill), (1, w.sill), (1, w.sill + w.height), (-1, w.sill + w.height)]
        ):
            out[i, k] = mid + (w.u_center + du * w.width / 2) * wall.u + np.array([0, 0, z])
    return out


def make_church(
    params: ChurchParams | None = None, *, rng: np.random.Generator | int | None = 0
) -> ChurchScene:
    """Generate the church scene with ground truth.

    Parameters
    ----------
    params
        :class:`ChurchParams`.
    rng
        Seed or generator (the scene is deterministic for a given seed).

    Examples
    --------
    >>> scene = make_church(ChurchParams(spacing_m=0.3, window_spacing_m=0.1), rng=1)
    >>> len(scene.windows), scene.control.xyz.shape[1]
    (24, 3)
    """
    p = params or ChurchParams()
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    wins = _windows(p, gen)
    L, W = p.length_m, p.width_m
    # building frame -> world (national grid, rotated by the church's azimuth)
    T_world_building = similarity_matrix(
        [1049800.0 + 12.345, 6842300.0 + 67.89, 142.5], [0.0, 0.0, np.radians(23.0)], 1.0
    )
    # frames of the two clouds (truth)
    T_exterior_world = similarity_matrix([3.2, -7.5, 1.1], np.radians([2.0, -1.5, 40.0]), 0.8)
    T_exterior_world[:3, 3] -= T_exterior_world[:3, :3] @ T_world_building[:3, 3]
    T_interior_world = similarity_matrix([0, 0, 0], np.radians([0.02, -0.03, 117.0]), 1.0)
    scanner_world = (
        T_world_building[:3, :3] @ np.array([L / 2 + 1.3, W / 2 - 0.7, 1.6])
        + (T_world_building[:3, 3])
    )
    T_interior_world[:3, 3] = -T_interior_world[:3, :3] @ scanner_world

    def to_world(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return x @ T_world_building[:3, :3].T + T_world_building[:3, 3]

    def frame(T: NDArray[np.float64], x_world: NDArray[np.float64]) -> NDArray[np.float64]:
        return x_world @ T[:3, :3].T + T[:3, 3]

    # sphere targets (building frame): exterior control 8, exterior check 5,
    # interior control 6, interior check 5
    ext_c = np.array(
        [[-2.5, -2.0, 1.4], [10, -2.8, 1.5], [20, -2.6, 1.3], [L + 2.2, -2.0, 1.6],
         [L + 2.6, W + 1.5, 1.4], [18, W + 2.8, 1.5], [6, W + 2.5, 1.6], [-2.2, W + 2.0, 1.2],
         [L + 0.5, 5.0, 9.0], [-0.5, 7.0, 8.5]]
    )  # fmt: skip
    ext_k = np.array(
        [[5, -1.8, 1.5], [25, -2.2, 1.4], [L + 1.8, 8.0, 1.5], [12, W + 2.0, 1.3],
         [-1.8, 4.0, 1.5]]
    )  # fmt: skip
    int_c = np.array(
        [[2.0, 2.0, 1.5], [L - 2.0, 2.2, 1.2], [L - 2.5, W - 2.0, 1.6], [2.5, W - 2.2, 1.3],
         [15, 1.5, 6.0], [15, W - 1.5, 5.5]]
    )  # fmt: skip
    int_k = np.array(
        [[8, 3.0, 1.0], [22, 4.0, 1.6], [20, W - 3.0, 1.2], [6, W - 4.0, 2.0], [L - 1.5, 6, 4.0]]
    )  # fmt: skip
    ids_ec = [f"GCP_E{i + 1:02d}" for i in range(len(ext_c))]
    ids_ek = [f"CHK_E{i + 1:02d}" for i in range(len(ext_k))]
    ids_ic = [f"GCP_I{i + 1:02d}" for i in range(len(int_c))]
    ids_ik = [f"CHK_I{i + 1:02d}" for i in range(len(int_k))]
    ext_targets = np.vstack([ext_c, ext_k])
    int_targets = np.vstack([int_c, int_k])
    # clouds in the world frame with noise, then into their own frames
    clouds = {}
    for side, targets, noise in (
        ("exterior", ext_targets, p.exterior_noise_m),
        ("interior", int_targets, p.interior_noise_m),
    ):
        pts, codes = _sample_side(p, wins, side, targets, noise, gen)
        world = to_world(pts)
        order = gen.permutation(len(world))
        clouds[side] = (world[order], codes[order])
    ext_world, ext_codes = clouds["exterior"]
    int_world, int_codes = clouds["interior"]
    exterior = PointCloud.from_world(
        frame(T_exterior_world, ext_world), attributes={"surface": ext_codes}, source="exterior"
    )
    interior = PointCloud.from_world(
        frame(T_interior_world, int_world), attributes={"surface": int_codes}, source="interior"
    )
    # surveyed coordinates
    all_ids = ids_ec + ids_ek + ids_ic + ids_ik
    true_world = to_world(np.vstack([ext_targets, int_targets]))
    surveyed = true_world + gen.normal(0.0, p.control_sigma_m, true_world.shape)
    is_control = np.array([i.startswith("GCP") for i in all_ids])
    control = PointList(
        ids=tuple(np.array(all_ids)[is_control]),
        xyz=surveyed[is_control],
        sigma=np.full((int(is_control.sum()), 3), p.control_sigma_m),
        source="control",
    )
    check = PointList(
        ids=tuple(np.array(all_ids)[~is_control]),
        xyz=surveyed[~is_control],
        sigma=np.full((int((~is_control).sum()), 3), p.control_sigma_m),
        source="check",
    )
    n_ext = len(ext_targets)
    approx_err = gen.normal(0.0, 0.03, true_world.shape)  # operator's click, 3 cm
    targets_exterior = PointList(
        ids=tuple(all_ids[:n_ext]),
        xyz=frame(T_exterior_world, true_world[:n_ext] + approx_err[:n_ext]),
        source="exterior targets (approximate)",
    )
    targets_interior = PointList(
        ids=tuple(all_ids[n_ext:]),
        xyz=frame(T_interior_world, true_world[n_ext:] + approx_err[n_ext:]),
        source="interior targets (approximate)",
    )
    corners = to_world(_corners(p, wins).reshape(-1, 3))
    corner_ids = tuple(f"W{i // 4 + 1:02d}_{'ABCD'[i % 4]}" for i in range(len(corners)))
    pick = np.sort(gen.choice(len(corners), size=min(p.n_manual_ties, len(corners)), replace=False))
    s = p.manual_pick_sigma_m
    man_e = frame(T_exterior_world, corners[pick] + gen.normal(0, s, (len(pick), 3)))
    man_i = frame(T_interior_world, corners[pick] + gen.normal(0, s, (len(pick), 3)))
    pick_ids = tuple(corner_ids[i] for i in pick)
    scale_ext = float(np.cbrt(np.linalg.det(T_exterior_world[:3, :3])))
    wins = wins.assign(window=[f"W{i + 1:02d}" for i in range(len(wins))])
    return ChurchScene(
        exterior=exterior,
        interior=interior,
        T_world_exterior=np.linalg.inv(T_exterior_world),
        T_world_interior=np.linalg.inv(T_interior_world),
        control=control,
        check=check,
        targets_true_world=PointList(ids=tuple(all_ids), xyz=true_world, source="truth"),
        targets_exterior=targets_exterior,
        targets_interior=targets_interior,
        manual_ties_exterior=PointList(
            pick_ids,
            man_e,
            sigma=np.full((len(pick), 3), s * scale_ext),  # exterior model units
            source="manual ties (exterior)",
        ),
        manual_ties_interior=PointList(
            pick_ids, man_i, sigma=np.full((len(pick), 3), s), source="manual ties (interior)"
        ),
        corners_world=PointList(corner_ids, corners, source="window corners (truth)"),
        windows=wins,
        params=p,
    )
