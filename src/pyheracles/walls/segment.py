"""The driver: :func:`segment_walls`, from a cloud to walls with openings and labels."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pyheracles.errors import InputError
from pyheracles.walls.faces import face_points, find_faces
from pyheracles.walls.joins import join_walls, snap_outline
from pyheracles.walls.junctions import cut_faces, junction_cuts
from pyheracles.walls.model import Wall, WallFace, WallParams, WallResult
from pyheracles.walls.outlines import wall_outline
from pyheracles.walls.pairing import join_coplanar, material_side, pair_faces, reveal_drafts
from pyheracles.walls.planes import fit_vertical, plane_frame, voxel_sample

__all__ = ["segment_walls"]


def segment_walls(xyz: ArrayLike, params: WallParams | None = None) -> WallResult:
    """Walls of a building cloud: planes, thickness, outlines with openings, labels.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres, local frame (z up).
    params
        :class:`WallParams`; defaults when omitted.

    Returns
    -------
    WallResult
        Per-point wall labels (0 = not in a wall) and one :class:`Wall` per wall.
        No vertical plane gives no walls and a note, never an error; a wall seen
        on one face has ``thickness_m`` NaN and a note.

    Raises
    ------
    InputError
        Not an ``(N, 3)`` finite array.
    """
    import time

    from scipy.spatial import cKDTree

    from pyheracles.geometry.neighbours import local_pca

    p = params or WallParams()
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"walls need (N, 3) coordinates, got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError("walls: the cloud has NaN or infinite coordinates")
    n = len(pts)
    labels = np.zeros(n, dtype=np.int32)
    timings: dict[str, float] = {}
    notes: list[str] = []
    if n < 50:
        notes.append(f"no walls: {n} points are too few for a wall plane")
        return WallResult(labels, (), p, tuple(notes), timings)
    t = time.perf_counter()
    voxel = p.voxel_m
    if voxel is None:
        from pyheracles.geometry.neighbours import point_spacing

        voxel = max(0.02, 2.0 * float(point_spacing(pts)))
    sample = voxel_sample(pts, voxel)
    if len(sample) < 50:
        notes.append("no walls: too few points after thinning for a wall plane")
        return WallResult(labels, (), p, tuple(notes), timings)
    pca = local_pca(pts[sample], k=p.normal_neighbours, directions=False)
    timings["normals"] = time.perf_counter() - t
    t = time.perf_counter()
    found = find_faces(pts, sample, pca.normals, p)
    timings["faces"] = time.perf_counter() - t
    if not found:
        notes.append(
            "no walls: no vertical plane at least "
            f"{p.min_length_m:g} m long and {p.min_height_m:g} m high in the cloud"
        )
        return WallResult(labels, (), p, tuple(notes), timings)
    t = time.perf_counter()
    faces: list[WallFace] = []
    run_on: set[int] = set()  # faces long enough only when run on to their corners
    keep_alive: list[WallFace] = []  # (their ids stay theirs)
    taken = np.zeros(n, dtype=bool)
    for nrm, d, seeds, short in found:
        idx = face_points(pts, nrm, d, seeds, p)
        idx = idx[~taken[idx]]
        if len(idx) < 3:
            continue
        nrm2, d2, rms = fit_vertical(pts[idx])
        if rms > p.distance_m / 3:
            continue  # spread across the band (layered glass, a curved or stepped
            # surface), not one planar face: its points stay in the pool
        taken[idx] = True
        faces.append(WallFace(nrm2, d2, idx, rms))
        if short:
            run_on.add(id(faces[-1]))
            keep_alive.append(faces[-1])
    timings["face_points"] = time.perf_counter() - t
    t = time.perf_counter()
    tree = cKDTree(pts[sample])
    sample_pts = pts[sample]
    faces, groups = join_coplanar(pts, faces, pair_faces(pts, faces, p), p)
    drafts = _no_reveals(pts, _drafts(pts, faces, groups, tree, p), run_on, p)
    cuts = junction_cuts(pts, drafts, p)
    if any(cuts):  # faces cut where walls abut their wall, and paired again
        faces = cut_faces(pts, faces, drafts, cuts, p)
        faces, groups = join_coplanar(pts, faces, pair_faces(pts, faces, p), p)
        drafts = _no_reveals(pts, _drafts(pts, faces, groups, tree, p), run_on, p)
    # outlines and openings
    for w in drafts:
        idx = np.concatenate([f.indices for f in w["faces"]])
        q = pts[idx] - w["origin"]
        w_uz = np.c_[q @ w["u_axis"], q[:, 2]]
        face_of = np.repeat(np.arange(len(w["faces"])), [len(f.indices) for f in w["faces"]])
        # points on their face's plane within 3 RMS (at least 5 mm) set the openings'
        # edges: mixed pixels along the edges, up to distance_m off the plane, do not
        res = np.concatenate([np.abs(pts[f.indices] @ f.normal - f.d) for f in w["faces"]])
        tol = np.array([max(3.0 * f.rms_m, 0.005) for f in w["faces"]])[face_of]
        on_plane = res <= tol
        qa = sample_pts - w["origin"]
        depth = qa @ w["normal"]
        uz_all = np.c_[qa @ w["u_axis"], qa[:, 2]]
        if len(w["faces"]) == 2:
            half = 0.5 * w["thickness"]
            behind = np.abs(depth) < half - p.distance_m
            front = (np.abs(depth) > half + p.distance_m) & (np.abs(depth) < half + 1.0)
        else:
            s = w["side"] or 1
            behind = (s * depth > p.distance_m) & (s * depth < 1.5)
            front = (-s * depth > p.distance_m) & (-s * depth < 1.5)
            if w["side"] == 0:  # unknown side: anything through the hole counts
                behind = behind | front
        between = None
        if len(w["faces"]) == 2:  # every point between the faces (full resolution)
            qf = pts - w["origin"]
            df = qf @ w["normal"]
            inner = np.abs(df) < 0.5 * w["thickness"] - p.distance_m
            between = (np.c_[qf[inner] @ w["u_axis"], qf[inner, 2]], df[inner])
        near = np.abs(depth) < 1.5 + (0 if np.isnan(w["thickness"]) else w["thickness"])
        side = np.sign(depth).astype(np.int64)  # of the wall's plane: the floor, the ground
        outline, openings, ur, zr = wall_outline(
            w_uz, face_of, on_plane, uz_all, near, behind, front, p, side, depth, between
        )
        w.update(outline=outline, openings=openings, u_range=ur, z_range=zr, idx=idx,
                 ends=list(ur))  # fmt: skip
    timings["outlines"] = time.perf_counter() - t
    t = time.perf_counter()
    join_walls(drafts, p)
    walls: list[Wall] = []
    for k, w in enumerate(drafts, start=1):
        outline = snap_outline(w["outline"], w["u_range"], w["ends"], 1.5 * p.cell_m)
        labels[w["idx"]] = k
        rms = float(np.sqrt(np.mean([f.rms_m**2 for f in w["faces"]])))
        walls.append(Wall(
            instance=k, normal=w["normal"], d=float(w["d"]), origin=w["origin"],
            u_axis=w["u_axis"], faces=tuple(w["faces"]), thickness_m=float(w["thickness"]),
            outline=outline, openings=tuple(w["openings"]),
            u_range=(float(min(w["ends"])), float(max(w["ends"]))), z_range=w["z_range"],
            rms_m=rms, n_points=len(w["idx"]), material_side=int(w["side"]),
            joined=tuple(dict.fromkeys(w["joined"])),
        ))  # fmt: skip
        if len(w["faces"]) == 1:
            notes.append(
                f"wall {k}: seen on one face only; thickness not measured"
                + ("" if w["side"] else "; side of the wall unknown")
            )
    timings["walls"] = time.perf_counter() - t
    return WallResult(labels, tuple(walls), p, tuple(notes), timings)


def _no_reveals(pts: np.ndarray, drafts: list[dict[str, Any]], run_on: set[int],
                p: WallParams) -> list[dict[str, Any]]:  # fmt: skip
    """``drafts`` without the reveals of other walls (:func:`reveal_drafts`): their
    points stay in the pool."""
    if not run_on:
        return drafts
    drop = set(reveal_drafts(pts, drafts, run_on, p))
    return [w for k, w in enumerate(drafts) if k not in drop]


def _drafts(pts: np.ndarray, faces: list[WallFace], groups: list[tuple[int, ...]], tree: Any,
            p: WallParams) -> list[dict[str, Any]]:  # fmt: skip
    """One draft wall per group of faces (:func:`pair_faces`): its faces, mid-plane,
    thickness (NaN seen on one face), plane frame and the side of a lone face."""
    drafts: list[dict[str, Any]] = []
    for g in groups:
        fs = [faces[i] for i in g]
        nrm = fs[0].normal
        if len(fs) == 2:
            s = math.copysign(1.0, float(nrm @ fs[1].normal))
            d_mid = 0.5 * (fs[0].d + s * fs[1].d)
            thick = abs(fs[0].d - s * fs[1].d)
            side = 0
        else:
            d_mid, thick = fs[0].d, float("nan")
            side = material_side(pts, tree, fs[0], p)
        origin, u = plane_frame(nrm, d_mid)
        drafts.append({"faces": fs, "normal": nrm, "d": d_mid, "thick": 0.0 if len(fs) == 1
                       else thick, "thickness": thick, "origin": origin, "u_axis": u,
                       "side": side, "joined": []})  # fmt: skip
    return drafts
