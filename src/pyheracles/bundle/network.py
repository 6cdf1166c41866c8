"""The network of a bundle adjustment: free-parameter layout, observations, initial values
and datum, built from a :class:`~pyheracles.bundle.project.Project` by
:func:`prepare_network` (the solver is :mod:`pyheracles.bundle.adjust`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from pyheracles.bundle.camera import FORWARD_MODEL, IO_NAMES, MODELS
from pyheracles.bundle.initial import (
    centre_rotation,
    forward_intersection,
    ideal_rays,
    relative_block_orientation,
    spatial_resection,
)
from pyheracles.bundle.parameters import BundleParameters
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.errors import DegenerateGeometryError, InputError

__all__ = ["Network", "prepare_network"]


@dataclass
class Network:
    """Arrays of the adjustment problem (free-parameter layout and observations)."""

    project: Project
    model: int
    uv_mm: np.ndarray  # (m,2) measured, scaled to mm, y flipped
    sqrt_w: np.ndarray  # (m,2) 1 / sigma_mm
    obs_cam: np.ndarray  # (m,) camera index of each observation
    io_free: np.ndarray  # (ncam,10)
    eo_free: np.ndarray  # (n,6)
    op_free: np.ndarray  # (N,3)
    io_col: np.ndarray  # (ncam,10) column in the camera system or -1
    eo_col: np.ndarray  # (n,6)
    n_cam_cols: int
    eo_prior: np.ndarray  # (n,6) prior values, std in eo_prior_std (NaN = none)
    eo_prior_std: np.ndarray
    op_prior: np.ndarray
    op_prior_std: np.ndarray
    datum: str
    fixed_coordinate: tuple[int, int] | None = None  # (image, axis) for "depend"
    xyz_init: np.ndarray | None = None  # (N,3) initial point coordinates (None: project.xyz)

    @property
    def n_free(self) -> int:
        return int(self.io_free.sum() + self.eo_free.sum() + self.op_free.sum())

    @property
    def n_prior(self) -> int:
        return int(np.isfinite(self.eo_prior_std).sum() + np.isfinite(self.op_prior_std).sum())


def _choose_datum(project: Project, params: BundleParameters) -> str:
    if params.datum == "free":
        return "free"
    n_ctrl = int(
        np.sum(
            (project.point_role == "control")
            & np.all(np.isfinite(project.xyz), axis=1)
            & np.all(np.isfinite(project.xyz_std), axis=1)
        )
    )
    if params.datum == "control" or (params.datum == "auto" and project.datum == "control"):
        if n_ctrl < 3:
            raise DegenerateGeometryError(
                f"datum by control points needs at least 3 control points, found {n_ctrl}",
                path=project.source,
                hint="add control points (--control) or use --datum depend",
            )
        return "control"
    if params.datum == "depend" or project.datum == "depend":
        return "depend"
    if n_ctrl >= 3:
        return "control"
    warnings.warn(
        f"{project.source}: {n_ctrl} fixed or weighted control point(s) (3 needed for a "
        "datum by control points): the datum is a dependent relative orientation "
        "('depend': first image fixed, scale by one base coordinate), so coordinates are "
        "in an arbitrary frame and scale",
        BundleWarning,
        stacklevel=4,
    )
    return "depend"


def _initial_values(
    project: Project, uv_mm: np.ndarray, obs_cam: np.ndarray
) -> tuple[Project, np.ndarray]:
    """Resect images without EO and intersect points without coordinates.

    Returns the project with the initial exterior orientations and point
    coordinates, except that check points keep their reference coordinates
    (what they are checked against), and the initial coordinates of every point.
    """
    cams = project.cameras
    model = cams[0].model
    io_all = np.array([c.io_vector() for c in cams])
    eo = project.eo.copy()
    xyz = project.xyz.copy()
    known = np.all(np.isfinite(xyz), axis=1) & (project.point_role == "control")
    need = ~np.all(np.isfinite(eo), axis=1)
    if project.needs_resection:
        need[:] = True
    n_known = np.bincount(project.obs_image[known[project.obs_point]], minlength=project.n_images)
    if np.any(need & (n_known < 4)):
        # Scarce control: orient the block relatively (essential matrix of the best
        # pair, resection on the growing block), then move it onto the control.
        scarce = np.flatnonzero(need & (n_known < 4))
        eo, _, info = relative_block_orientation(
            project.obs_image,
            project.obs_point,
            ideal_rays(uv_mm, io_all[obs_cam], model),
            uv_mm,
            io_all[obs_cam],
            model,
            project.n_images,
            project.n_points,
            np.where(known[:, None], xyz, np.nan),
            source=project.source,
        )
        warnings.warn(
            f"{project.source}: image(s) {project.image_ids[scarce][:10].tolist()} lack an "
            "exterior orientation and see fewer than 4 control points: the block was "
            f"initialised by relative orientation of images {project.image_ids[info['pair'][0]]} "
            f"and {project.image_ids[info['pair'][1]]} and resection of the others"
            + (
                f", moved onto {info['n_control_used']} control points"
                if info["frame"] == "control"
                else " (fewer than 3 control points: arbitrary frame and scale)"
            ),
            BundleWarning,
            stacklevel=4,
        )
        need[:] = False
    for i in np.flatnonzero(need):
        sel = (project.obs_image == i) & known[project.obs_point]
        eo[i] = spatial_resection(
            xyz[project.obs_point[sel]], uv_mm[sel], io_all[project.image_camera[i]], model
        )
    # Intersect every free point that has no prior observation (as DBAT does).
    inter = (project.point_role != "control") | ~np.all(np.isfinite(xyz), axis=1)
    if np.any(inter):
        sel = inter[project.obs_point]
        centres, rots = centre_rotation(eo)
        img = project.obs_image[sel]
        rays = ideal_rays(uv_mm[sel], io_all[obs_cam[sel]], model)
        idx = np.cumsum(inter) - 1
        pts = forward_intersection(
            centres[img], rots[img], rays, idx[project.obs_point[sel]], int(inter.sum())
        )
        xyz[inter] = pts
        bad = inter.copy()
        bad[inter] = ~np.all(np.isfinite(pts), axis=1)
        if np.any(bad):
            raise DegenerateGeometryError(
                f"{int(bad.sum())} point(s) cannot be intersected (parallel rays), ids "
                f"{project.point_ids[bad][:10].tolist()}",
                path=project.source,
            )
    check = (project.point_role == "check") & np.all(np.isfinite(project.xyz), axis=1)
    reference = np.where(check[:, None], project.xyz, xyz)
    return project.replace(eo=eo, xyz=reference), xyz


def prepare_network(project: Project, params: BundleParameters | None = None) -> Network:
    """Validate the project, compute initial values and the free-parameter layout."""
    params = params or BundleParameters()
    project = project.validate(params.min_rays)
    if params.estimate_io is not None:
        project = project.with_estimated_io(params.estimate_io)
    cams = project.cameras
    model = cams[0].model
    if model not in MODELS:
        raise InputError(f"unsupported lens distortion model {model}", path=project.source)
    obs_cam = project.image_camera[project.obs_image]
    pix = np.array([c.pixel_size_mm for c in cams])
    # DBAT scales both axes by the x pixel size (square pixels; the aspect is a parameter).
    s = pix[obs_cam, 0]
    uv_mm = np.column_stack([project.obs_uv_px[:, 0] * s, -project.obs_uv_px[:, 1] * s])
    sqrt_w = 1.0 / (project.obs_std_px * pix[obs_cam])
    if not np.all(np.isfinite(sqrt_w)) or np.any(project.obs_std_px <= 0):
        raise InputError("image observation standard deviations must be > 0", path=project.source)
    eo_observed = project.eo.copy()  # prior EO values, before resection replaces them
    project, xyz_init = _initial_values(project, uv_mm, obs_cam)

    io_free = project.estimate_io.copy()
    if model in (1, 2, FORWARD_MODEL):
        dropped = [IO_NAMES[j] for j in (3, 4) if io_free[:, j].any()]
        if dropped:
            warnings.warn(
                f"{project.source}: {' and '.join(dropped)} requested but lens model {model} "
                "has no affinity or skew term: not estimated (choose lens model 3, 4 or 5 to "
                "estimate them)",
                BundleWarning,
                stacklevel=3,
            )
        io_free[:, 3:5] = False
    eo_free = project.estimate_eo.copy()
    role = project.point_role
    op_free = np.ones((project.n_points, 3), bool)
    op_prior = np.full((project.n_points, 3), np.nan)
    op_prior_std = np.full((project.n_points, 3), np.nan)
    ctrl = role == "control"
    std = project.xyz_std
    fixed = ctrl[:, None] & np.isfinite(std) & (std == 0)
    weighted = ctrl[:, None] & np.isfinite(std) & (std > 0)
    datum = _choose_datum(project, params)
    fixed_coord = None
    if datum == "free":
        pass
    elif datum == "control":
        op_free &= ~fixed
        op_prior[weighted] = project.xyz[weighted]
        op_prior_std[weighted] = std[weighted]
    else:
        # Dependent relative orientation: fix the reference image and the largest
        # positive coordinate offset of another image from it (DBAT 'longest').
        ref = project.ref_image
        off = project.eo[:, :3] - project.eo[ref, :3]
        img, axis = np.unravel_index(int(np.argmax(off)), off.shape)
        eo_free[:] = True
        eo_free[ref] = False
        eo_free[img, axis] = False
        fixed_coord = (int(img), int(axis))
    eo_prior = np.where(np.isfinite(project.eo_std) & eo_free, eo_observed, np.nan)
    eo_prior_std = np.where(np.isfinite(project.eo_std) & eo_free, project.eo_std, np.nan)
    eo_prior_std[eo_prior_std <= 0] = np.nan

    io_col = np.full(io_free.shape, -1)
    io_col[io_free] = np.arange(io_free.sum())
    eo_col = np.full(eo_free.shape, -1)
    eo_col[eo_free] = io_free.sum() + np.arange(eo_free.sum())
    return Network(
        project=project,
        model=model,
        uv_mm=uv_mm,
        sqrt_w=sqrt_w,
        obs_cam=obs_cam,
        io_free=io_free,
        eo_free=eo_free,
        op_free=op_free,
        io_col=io_col,
        eo_col=eo_col,
        n_cam_cols=int(io_free.sum() + eo_free.sum()),
        eo_prior=eo_prior,
        eo_prior_std=eo_prior_std,
        op_prior=op_prior,
        op_prior_std=op_prior_std,
        datum=datum,
        fixed_coordinate=fixed_coord,
        xyz_init=xyz_init,
    )
