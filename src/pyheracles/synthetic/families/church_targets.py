"""Sphere targets, control and check points, manual tie points of a ``church`` draw.

Targets are spheres on tripods or on wall brackets, placed where the
stations (or cameras) see them.  Each is a control or a check point; its
centre is surveyed in the scene frame (total station, ``control_sigma_m``) and
picked approximately in every cloud that sees it (the operator's click, 3 cm,
to be refined by a sphere fit: ``heracles georef --sphere-radius``).

Files written by :func:`write_target_files` (the formats of
:mod:`pyheracles.registration.points`, read by ``heracles georef`` /
``heracles checkpoints`` / ``heracles register --tiepoints``):

``control.csv``, ``check.csv``
    ``id,X,Y,Z,sX,sY,sZ``: surveyed centres in the scene frame.
``check_<cloud>.csv``
    The check points that cloud sees (``heracles checkpoints --points``).
``targets_<cloud>.csv``
    ``id,X,Y,Z``: approximate centres in that cloud's own frame (the targets
    it sees), for ``--measured ... --sphere-radius R``.
``targets.csv``
    ``id,cloud,X,Y,Z``: the same, both clouds in one file.
``targets_true.csv``
    ``id,role,side,mount,radius_m,frame,X,Y,Z,n_points``: true centres in the
    scene frame and in each cloud's frame, with the points each cloud has on it.
``ties_manual.csv``
    ``id,cloud,X,Y,Z``: window corners (on the pane mid-plane) picked by hand in
    both clouds (``pick_sigma_m``), for ``heracles register --tiepoints``.
``window_corners.csv``
    ``id,window,kind,X,Y,Z``: true corners of every window light (scene frame):
    ``sharp`` where the outline turns, ``box`` the corners of its bounding
    rectangle in the wall plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from shapely.geometry import Point, Polygon

from pyheracles.registration.points import PointList, write_points
from pyheracles.synthetic.families.church_geometry import Wall
from pyheracles.synthetic.families.church_layout import ChurchPlan
from pyheracles.synthetic.families.church_site import InstanceCounter
from pyheracles.synthetic.scanner import RayCaster, ScanResult
from pyheracles.synthetic.scene import METAL, PLASTER, Scene

__all__ = [
    "Targets",
    "add_targets",
    "choose_targets",
    "manual_ties",
    "target_points",
    "write_target_files",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Targets:
    """Sphere targets of a draw (scene frame).

    Attributes
    ----------
    ids, role, side, mount
        Name, ``control``/``check``, ``interior``/``exterior``, ``tripod``/``wall``.
    centre
        ``(T, 3)`` true centres, metres.
    radius_m
        Sphere radius.
    instance
        Scene instance of each sphere.
    """

    ids: tuple[str, ...]
    role: tuple[str, ...]
    side: tuple[str, ...]
    mount: tuple[str, ...]
    centre: Array
    radius_m: float
    instance: NDArray[np.int_]


def _visible_from(caster: RayCaster, views: Array, centre: Array, max_range: float) -> int:
    """How many of ``views`` see ``centre`` unobstructed within ``max_range``."""
    if len(views) == 0:
        return 0
    d = centre - views
    dist = np.linalg.norm(d, axis=1)
    ok = dist < max_range
    if not ok.any():
        return 0
    t, _ = caster.cast(views[ok], d[ok] / dist[ok, None])
    return int(np.sum(t >= dist[ok] - 0.02))


def _clear_of_openings(wall: Wall, u: float, z: float, margin: float) -> bool:
    pt = Point(u, z)
    return all(Polygon(op.outline(op.splay_m)).distance(pt) > margin for op in wall.openings)


def _wall_candidates(
    plan: ChurchPlan, rng: np.random.Generator, radius: float, side: str, n: int
) -> list[tuple[Array, str, Array | None]]:
    """Sphere centres on brackets off the inner (interior) or outer (exterior) wall faces.

    The bracket holds the sphere ``2.5 r + 0.1`` m off the wall, clear of the
    neighbourhood a sphere fit searches (a sphere closer to a wall is pulled
    towards it by :func:`~pyheracles.registration.targets.measure_sphere`).
    """
    standoff = 2.5 * radius + 0.1
    out = []
    for _ in range(n * 6):
        if len(out) >= n:
            break
        w = plan.walls[int(rng.integers(len(plan.walls)))]
        if side == "interior":
            u0, u1 = w.inner_u
            top = w.inner_top_m - 0.5
            depth = w.thickness_m + standoff
        else:
            u0, u1 = 0.5, w.length_m - 0.5
            top = min(3.2, w.outer_top[-1][1] - 0.5)
            depth = -standoff
        if u1 - u0 < 1.0 or top < 2.0:
            continue
        u, z = float(rng.uniform(u0 + 0.4, u1 - 0.4)), float(rng.uniform(1.8, min(top, 3.8)))
        if not _clear_of_openings(w, u, z, radius + 0.25):
            continue
        c = w.to_3d(np.array([[u, z]]), depth)[0]
        anchor = w.to_3d(np.array([[u, z]]), w.thickness_m if side == "interior" else 0.0)[0]
        probe = shapely.Point(c[:2])
        inside = any(poly.buffer(-0.05).contains(probe) for poly in plan.inner_polygons)
        if (side == "interior") != inside or (
            side == "exterior" and plan.footprint.contains(probe)
        ):
            continue
        out.append((c, "wall", anchor))
    return out


def _tripod_candidates(
    plan: ChurchPlan, rng: np.random.Generator, side: str, n: int, keep_clear: Array
) -> list[tuple[Array, str, Array | None]]:
    out = []
    if side == "interior":
        areas = [a for a in plan.floor_free if a.area > 0.5]
        if not areas:
            return out
        weights = np.array([a.area for a in areas])
        for _ in range(n * 6):
            if len(out) >= n:
                break
            a = areas[int(rng.choice(len(areas), p=weights / weights.sum()))]
            x0, y0, x1, y1 = a.bounds
            xy = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
            if not a.contains(shapely.Point(xy)):
                continue
            if len(keep_clear) and np.min(np.linalg.norm(keep_clear[:, :2] - xy, axis=1)) < 1.0:
                continue
            out.append((np.array([xy[0], xy[1], rng.uniform(1.2, 1.7)]), "tripod", None))
    else:
        for _ in range(n * 6):
            if len(out) >= n:
                break
            ring = plan.footprint.buffer(float(rng.uniform(1.5, 5.0))).exterior
            xy = np.asarray(ring.interpolate(rng.uniform(0, ring.length)).coords)[0]
            if len(keep_clear) and np.min(np.linalg.norm(keep_clear[:, :2] - xy, axis=1)) < 1.2:
                continue
            z = float(plan.terrain.height(xy)[0]) + rng.uniform(1.2, 1.7)
            out.append((np.array([xy[0], xy[1], z]), "tripod", None))
    return out


def _spread_pick(points: Array, n: int, rng: np.random.Generator) -> list[int]:
    """Greedy farthest-point choice of ``n`` of ``points`` (targets spread over the site)."""
    if len(points) <= n:
        return list(range(len(points)))
    chosen = [int(rng.integers(len(points)))]
    d = np.linalg.norm(points - points[chosen[0]], axis=1)
    while len(chosen) < n:
        k = int(np.argmax(d))
        chosen.append(k)
        d = np.minimum(d, np.linalg.norm(points - points[k], axis=1))
    return chosen


def choose_targets(
    plan: ChurchPlan,
    rng: np.random.Generator,
    radius: float,
    n_interior: int,
    n_exterior: int,
    interior_views: Array,
    exterior_views: Array,
    min_views_exterior: int,
) -> list[tuple[Array, str, str, Array | None]]:
    """Targets seen from the stations: ``(centre, side, mount, wall anchor)`` per target."""
    caster = RayCaster(plan.scene)
    chosen: list[tuple[Array, str, str, Array | None]] = []
    for side, n, views, need in (
        ("interior", n_interior, interior_views, 1),
        ("exterior", n_exterior, exterior_views, min_views_exterior),
    ):
        cands = _wall_candidates(plan, rng, radius, side, 4 * n) + _tripod_candidates(
            plan, rng, side, 6 * n, np.vstack([interior_views, exterior_views])
        )
        reach = 30.0 if side == "interior" else 40.0
        seen = [c for c in cands if _visible_from(caster, views, c[0], reach) >= need]
        if not seen:
            continue
        pts = np.array([c[0] for c in seen])
        for k in _spread_pick(pts, n, rng):
            chosen.append((seen[k][0], side, seen[k][1], seen[k][2]))
    return chosen


def _roles(centres: Array, n_check: int) -> NDArray[np.object_]:
    """Control points spread round the site and over the heights, check points in between.

    As a surveyor lays out a network: control targets by farthest-point choice
    (heights weighted three times, so that they do not all stand at tripod
    height), the rest are check points.
    """
    role = np.full(len(centres), "check", dtype=object)
    n_control = len(centres) - n_check
    if n_control <= 0:
        return role
    q = centres * np.array([1.0, 1.0, 3.0])
    k = int(np.argmax(np.linalg.norm(q - q.mean(axis=0), axis=1)))
    chosen = [k]
    d = np.linalg.norm(q - q[k], axis=1)
    while len(chosen) < n_control:
        k = int(np.argmax(d))
        chosen.append(k)
        d = np.minimum(d, np.linalg.norm(q - q[k], axis=1))
    role[chosen] = "control"
    return role


def add_targets(
    scene: Scene,
    plan: ChurchPlan,
    chosen: list[tuple[Array, str, str, Array | None]],
    radius: float,
    rng: np.random.Generator,
    ids: InstanceCounter,
) -> Targets:
    """Add the spheres (and their tripods or brackets) and assign control/check roles."""
    names, roles, sides, mounts, centres, inst = [], [], [], [], [], []
    for side in ("exterior", "interior"):
        mine = [(c, m, a) for c, s, m, a in chosen if s == side]
        n_check = len(mine) // 2 if len(mine) >= 6 else max(len(mine) - 3, 0)
        role = _roles(np.array([c for c, _, _ in mine]).reshape(-1, 3), n_check)
        count = {"control": 0, "check": 0}
        tag = "E" if side == "exterior" else "I"
        for (c, mount, anchor), r in zip(mine, role, strict=True):
            count[r] += 1
            names.append(f"{'GCP' if r == 'control' else 'CHK'}_{tag}{count[r]:02d}")
            k = ids()
            scene.add_sphere(
                c,
                radius,
                segments=48,
                instance=k,
                class_name="target",
                part="sphere",
                material=PLASTER,
            )
            stand = ids()
            if mount == "tripod":
                ground = 0.0 if side == "interior" else float(plan.terrain.height(c[:2])[0])
                top = c - np.array([0, 0, radius])
                scene.add_cylinder(
                    top - [0, 0, 0.25],
                    [0, 0, 1],
                    0.25,
                    0.012,
                    segments=12,
                    instance=stand,
                    class_name="tripod",
                    part="head",
                    material=METAL,
                )
                for a in np.deg2rad([0.0, 120.0, 240.0]) + rng.uniform(0, 2 * np.pi):
                    foot = np.array([c[0] + 0.45 * np.cos(a), c[1] + 0.45 * np.sin(a), ground])
                    axis = (top - [0, 0, 0.25]) - foot
                    scene.add_cylinder(
                        foot,
                        axis,
                        float(np.linalg.norm(axis)),
                        0.01,
                        segments=8,
                        instance=stand,
                        class_name="tripod",
                        part="leg",
                        material=METAL,
                    )
            else:
                axis = c - anchor
                scene.add_cylinder(
                    anchor,
                    axis,
                    float(np.linalg.norm(axis)),
                    0.012,
                    segments=12,
                    instance=stand,
                    class_name="tripod",
                    part="bracket",
                    material=METAL,
                )
            scene.objects.append(
                {
                    "instance": k,
                    "class": "target",
                    "id": names[-1],
                    "role": r,
                    "side": side,
                    "mount": mount,
                    "centre": c.tolist(),
                    "radius_m": radius,
                }
            )
            scene.objects.append(
                {"instance": stand, "class": "tripod", "target": names[-1], "mount": mount}
            )
            roles.append(str(r))
            sides.append(side)
            mounts.append(mount)
            centres.append(c)
            inst.append(k)
    return Targets(
        tuple(names),
        tuple(roles),
        tuple(sides),
        tuple(mounts),
        np.array(centres).reshape(-1, 3),
        radius,
        np.array(inst, int),
    )


def _to_frame(T_scene_cloud: Array, xyz: Array) -> Array:
    R, t = T_scene_cloud[:3, :3], T_scene_cloud[:3, 3]
    return (np.asarray(xyz, float).reshape(-1, 3) - t) @ R


def target_points(targets: Targets, res: ScanResult) -> NDArray[np.int_]:
    """Non-outlier points of each target sphere in a scan (0 when not seen)."""
    good = res.instance[~res.outlier]
    counts = np.bincount(good, minlength=int(targets.instance.max(initial=0)) + 1)
    return counts[targets.instance]


def _survey(targets: Targets, role: str, sigma: float, rng: np.random.Generator) -> PointList:
    m = np.array([r == role for r in targets.role], bool)
    xyz = targets.centre[m] + rng.normal(0.0, sigma, (int(m.sum()), 3)) * [1.0, 1.0, 1.5]
    sig = np.tile([sigma, sigma, 1.5 * sigma], (int(m.sum()), 1))
    return PointList(tuple(np.array(targets.ids)[m]), xyz, sig, source=f"{role} (surveyed)")


def survey_points(
    targets: Targets,
    clouds: dict[str, ScanResult],
    transforms: dict[str, Array],
    sigma_m: float,
    rng: np.random.Generator,
    min_points: int = 30,
) -> dict[str, Any]:
    """Control/check lists (surveyed, scene frame), picks per cloud, the truth table."""
    control = _survey(targets, "control", sigma_m, rng)
    check = _survey(targets, "check", sigma_m, rng)
    rows = []
    picks = {}
    for i, k in enumerate(targets.ids):
        rows.append(
            {
                "id": k,
                "role": targets.role[i],
                "side": targets.side[i],
                "mount": targets.mount[i],
                "radius_m": targets.radius_m,
                "frame": "scene",
                "X": targets.centre[i, 0],
                "Y": targets.centre[i, 1],
                "Z": targets.centre[i, 2],
                "n_points": -1,
            }
        )
    for name, res in clouds.items():
        n = target_points(targets, res)
        local = _to_frame(transforms[name], targets.centre)
        seen = n >= min_points
        for i, k in enumerate(targets.ids):
            rows.append(
                {
                    "id": k,
                    "role": targets.role[i],
                    "side": targets.side[i],
                    "mount": targets.mount[i],
                    "radius_m": targets.radius_m,
                    "frame": name,
                    "X": local[i, 0],
                    "Y": local[i, 1],
                    "Z": local[i, 2],
                    "n_points": int(n[i]),
                }
            )
        click = local[seen] + rng.normal(0.0, 0.03, (int(seen.sum()), 3))
        picks[name] = PointList(
            tuple(np.array(targets.ids)[seen]), click, source=f"targets picked in {name}"
        )
    return {"control": control, "check": check, "picks": picks, "table": pd.DataFrame(rows)}


def window_corner_table(objects: list[dict[str, Any]]) -> pd.DataFrame:
    """True corners of every window light (scene frame)."""
    rows = []
    for o in objects:
        if o.get("class") != "window":
            continue
        for kind in ("sharp", "box"):
            for j, c in enumerate(o[f"{kind}_corners_m"]):
                rows.append(
                    {
                        "id": f"W{o['instance']:04d}_{kind[0]}{j}",
                        "window": o["instance"],
                        "kind": kind,
                        "X": c[0],
                        "Y": c[1],
                        "Z": c[2],
                    }
                )
    return pd.DataFrame(rows, columns=["id", "window", "kind", "X", "Y", "Z"])


def manual_ties(
    corners: pd.DataFrame,
    class_names: dict[int, str],
    part_names: dict[int, str],
    clouds: dict[str, ScanResult],
    transforms: dict[str, Array],
    sigma_m: float,
    rng: np.random.Generator,
    min_points: int = 5,
    radius_m: float = 0.25,
) -> dict[str, PointList]:
    """Sharp window corners seen by every cloud, picked by hand in each (cloud frames)."""
    sharp = corners[corners["kind"] == "sharp"]
    if sharp.empty:
        return {name: PointList((), np.empty((0, 3))) for name in clouds}
    xyz = sharp[["X", "Y", "Z"]].to_numpy(float)
    seen = np.ones(len(xyz), bool)
    for res in clouds.values():
        # only the points of window reveals, panes and cames can show a window corner
        near_window = np.isin(res.class_id, [k for k, v in class_names.items() if v == "window"])
        near_window |= np.isin(res.part, [k for k, v in part_names.items() if v == "reveal"])
        pts = res.xyz[near_window & ~res.outlier]
        if len(pts) == 0:
            seen[:] = False
            break
        near = cKDTree(pts).query_ball_point(xyz, radius_m, return_length=True)
        seen &= near >= min_points
    ids = tuple(sharp["id"][seen])
    out = {}
    for name in clouds:
        picked = xyz[seen] + rng.normal(0.0, sigma_m, (int(seen.sum()), 3))
        out[name] = PointList(
            ids,
            _to_frame(transforms[name], picked),
            np.full((len(ids), 3), sigma_m),
            source=f"manual ties ({name})",
        )
    return out


def _grouped_csv(path: Path, lists: dict[str, PointList]) -> Path:
    from pyheracles.io.atomic import atomic_write_text

    lines = ["id,cloud,X,Y,Z"]
    for name, pl in lists.items():
        for k, c in zip(pl.ids, pl.xyz, strict=True):
            lines.append(f"{k},{name},{c[0]:.4f},{c[1]:.4f},{c[2]:.4f}")
    return atomic_write_text(path, "\n".join(lines) + "\n")


def write_target_files(extras: dict[str, Any], outdir: str | Path) -> dict[str, Path]:
    """Write the target, control, check and tie files of a draw (see module docstring)."""
    from pyheracles.io.atomic import atomic_write_text

    out = Path(outdir)
    written = {
        "control": write_points(out / "control.csv", extras["control"]),
        "check": write_points(out / "check.csv", extras["check"]),
    }
    check: PointList = extras["check"]
    for name, pl in extras["targets_measured"].items():
        if len(pl):
            written[f"targets_{name}"] = write_points(out / f"targets_{name}.csv", pl)
        seen = [k for k in check.ids if k in set(pl.ids)]
        if seen:  # the check points this cloud sees, for ``heracles checkpoints``
            written[f"check_{name}"] = write_points(out / f"check_{name}.csv", check.select(seen))
    written["targets"] = _grouped_csv(out / "targets.csv", extras["targets_measured"])
    table: pd.DataFrame = extras["targets_true"]
    written["targets_true"] = atomic_write_text(
        out / "targets_true.csv", table.to_csv(index=False, float_format="%.4f")
    )
    if any(len(pl) for pl in extras["ties_manual"].values()):
        written["ties_manual"] = _grouped_csv(out / "ties_manual.csv", extras["ties_manual"])
    corners: pd.DataFrame = extras["window_corners"]
    written["window_corners"] = atomic_write_text(
        out / "window_corners.csv", corners.to_csv(index=False, float_format="%.4f")
    )
    return written
