"""The photogrammetric project: cameras, images, object points and image observations.

A :class:`Project` is what every reader returns and what :func:`bundle_adjust`
takes.  It stores data and the processing choices that come with some formats
(a DBAT script says which parameters to estimate and which datum to use);
everything is in the units of :mod:`pyheracles.bundle.camera` (mm, m, radians,
pixels).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from pyheracles.bundle.camera import IO_NAMES, Camera
from pyheracles.errors import InputError

__all__ = ["BundleWarning", "Project"]

ROLES = ("tie", "control", "check")


class BundleWarning(UserWarning):
    """Something in the project was dropped or changed to make it processable."""


def _refuse_duplicate_ids(ids: np.ndarray, what: str, src: str) -> None:
    uniq, counts = np.unique(np.asarray(ids), return_counts=True)
    if np.any(counts > 1):
        raise InputError(
            f"{what} id(s) {uniq[counts > 1][:10].tolist()} occur more than once",
            path=src,
            hint=f"give every {what} a unique id",
        )


@dataclass(frozen=True)
class Project:
    """A photogrammetric network.

    Attributes
    ----------
    name, source
        Project name and the file it was read from.
    cameras
        The physical cameras.
    image_ids, image_names, image_camera
        (n,) image ids, file names and index into ``cameras``.
    eo
        (n,6) initial exterior orientation X0, Y0, Z0 (object units), omega, phi,
        kappa (radians); NaN where unknown.
    eo_std
        (n,6) prior standard deviations of ``eo`` used as weighted observations;
        NaN = not observed.
    point_ids, point_labels
        (N,) object point ids and labels (control point names).
    xyz
        (N,3) initial or known object coordinates; NaN where unknown.
    xyz_std
        (N,3) prior standard deviations of control/check coordinates: 0 = fixed,
        > 0 = weighted observation, NaN = free unknown.
    point_role
        (N,) "tie", "control" or "check".  Check points are estimated from their
        image observations only and compared with their reference coordinates.
    obs_image, obs_point
        (m,) image and point index of each image observation.
    obs_uv_px
        (m,2) measured image coordinates in pixels (origin upper-left, y down).
    obs_std_px
        (m,2) a priori standard deviation of each coordinate, pixels.
    estimate_io
        (ncam,10) which interior parameters to estimate (:data:`IO_NAMES`).
    estimate_eo
        (n,6) which exterior parameters to estimate (before the datum is applied).
    datum
        "control", "depend" (dependent relative orientation) or None (decide from
        the control points).
    ref_image
        Index of the reference image for the "depend" datum.
    needs_resection
        The script asked for a spatial resection of the initial exterior orientation.
    """

    name: str
    source: str
    cameras: tuple[Camera, ...]
    image_ids: np.ndarray
    image_names: tuple[str, ...]
    image_camera: np.ndarray
    eo: np.ndarray
    eo_std: np.ndarray
    point_ids: np.ndarray
    point_labels: tuple[str, ...]
    xyz: np.ndarray
    xyz_std: np.ndarray
    point_role: np.ndarray
    obs_image: np.ndarray
    obs_point: np.ndarray
    obs_uv_px: np.ndarray
    obs_std_px: np.ndarray
    estimate_io: np.ndarray
    estimate_eo: np.ndarray
    datum: str | None = None
    ref_image: int = 0
    needs_resection: bool = False
    meta: dict = field(default_factory=dict, compare=False)

    @property
    def n_images(self) -> int:
        return len(self.image_ids)

    @property
    def n_points(self) -> int:
        return len(self.point_ids)

    @property
    def n_observations(self) -> int:
        return len(self.obs_image)

    def replace(self, **changes) -> Project:
        """A copy with some fields changed."""
        return replace(self, **changes)

    def rays(self) -> np.ndarray:
        """(N,) number of images observing each point."""
        return np.bincount(self.obs_point, minlength=self.n_points)

    def validate(self, min_rays: int = 2) -> Project:
        """Check consistency; drop points seen by fewer than ``min_rays`` images.

        Raises
        ------
        InputError
            No observations, an image without observations, an observation that
            refers to an unknown image, point or camera.
        """
        src = self.source
        if self.n_observations == 0:
            raise InputError("the project has no image observations", path=src)
        if self.n_images == 0:
            raise InputError("the project has no images", path=src)
        if len(self.cameras) == 0:
            raise InputError("the project has no camera", path=src)
        if np.any(self.image_camera < 0) or np.any(self.image_camera >= len(self.cameras)):
            bad = self.image_ids[(self.image_camera < 0) | (self.image_camera >= len(self.cameras))]
            raise InputError(
                f"image(s) {bad[:5].tolist()} refer to an unknown camera",
                path=src,
                hint="define every camera the images use",
            )
        if not np.all(np.isfinite(self.obs_uv_px)):
            raise InputError("image observations contain NaN/inf coordinates", path=src)
        _refuse_duplicate_ids(self.point_ids, "point", src)
        _refuse_duplicate_ids(self.image_ids, "image", src)
        names = np.asarray(self.image_names, dtype=object)
        uniq_names, counts = np.unique(names.astype(str), return_counts=True)
        if np.any(counts > 1):
            warnings.warn(
                f"{src}: image file name(s) {uniq_names[counts > 1][:5].tolist()} used by more "
                "than one image (the same photograph entered twice?)",
                BundleWarning,
                stacklevel=2,
            )
        models = {c.model for c in self.cameras}
        if len(models) > 1:
            raise InputError(f"mixed lens distortion models {sorted(models)}", path=src)
        proj = self
        key = self.obs_image.astype(np.int64) * max(self.n_points, 1) + self.obs_point
        _, first = np.unique(key, return_index=True)
        if len(first) < self.n_observations:
            dup = np.ones(self.n_observations, bool)
            dup[first] = False
            k = np.flatnonzero(dup)
            pairs = [
                f"point {self.point_ids[self.obs_point[j]]} on image "
                f"{self.image_ids[self.obs_image[j]]}"
                for j in k[:5]
            ]
            warnings.warn(
                f"{src}: {len(k)} duplicate image measurement(s) (same point measured twice "
                f"on one image: {', '.join(pairs)}{' ...' if len(k) > 5 else ''}): the first "
                "of each is kept",
                BundleWarning,
                stacklevel=2,
            )
            keep = np.sort(first)
            proj = proj.replace(
                obs_image=self.obs_image[keep],
                obs_point=self.obs_point[keep],
                obs_uv_px=self.obs_uv_px[keep],
                obs_std_px=self.obs_std_px[keep],
            )
        rays = proj.rays()
        weak = (rays < min_rays) & (self.point_role == "tie")
        if np.any(weak & (rays > 0)):
            ids = self.point_ids[weak & (rays > 0)]
            warnings.warn(
                f"{src}: {len(ids)} point(s) seen by fewer than {min_rays} images dropped "
                f"(ids {ids[:10].tolist()}{' ...' if len(ids) > 10 else ''})",
                BundleWarning,
                stacklevel=2,
            )
        unobserved = (rays == 0) & (self.point_role != "check")
        if np.any(unobserved):
            ids = self.point_ids[unobserved]
            warnings.warn(
                f"{src}: {len(ids)} point(s) without image observations dropped "
                f"(ids {ids[:10].tolist()}{' ...' if len(ids) > 10 else ''})",
                BundleWarning,
                stacklevel=2,
            )
        if np.any(weak | unobserved):
            proj = proj.drop_points(weak | unobserved)
        per_image = np.bincount(proj.obs_image, minlength=proj.n_images)
        if np.any(per_image == 0):
            ids = proj.image_ids[per_image == 0]
            raise InputError(
                f"image(s) {ids.tolist()} have no observations",
                path=src,
                hint="remove these images from the project or measure points on them",
            )
        return proj

    def drop_points(self, mask: np.ndarray) -> Project:
        """A copy without the points where ``mask`` is true (and their observations)."""
        keep = ~np.asarray(mask, bool)
        new_index = np.cumsum(keep) - 1
        keep_obs = keep[self.obs_point]
        return self.replace(
            point_ids=self.point_ids[keep],
            point_labels=tuple(lab for lab, k in zip(self.point_labels, keep, strict=True) if k),
            xyz=self.xyz[keep],
            xyz_std=self.xyz_std[keep],
            point_role=self.point_role[keep],
            obs_image=self.obs_image[keep_obs],
            obs_point=new_index[self.obs_point[keep_obs]],
            obs_uv_px=self.obs_uv_px[keep_obs],
            obs_std_px=self.obs_std_px[keep_obs],
        )

    def with_estimated_io(self, names: tuple[str, ...] | list[str]) -> Project:
        """A copy estimating exactly the interior parameters ``names`` for every camera."""
        unknown = set(names) - set(IO_NAMES) - {"pp"}
        if unknown:
            raise InputError(
                f"unknown interior parameter(s) {sorted(unknown)}; choose from {list(IO_NAMES)}"
            )
        est = np.zeros((len(self.cameras), len(IO_NAMES)), bool)
        for name in names:
            for n in ("px", "py") if name == "pp" else (name,):
                est[:, IO_NAMES.index(n)] = True
        return self.replace(estimate_io=est)

    def with_control(self, control: dict) -> Project:
        """A copy using the control/check points of ``control`` (matched by id).

        ``control`` is the dict of :func:`~pyheracles.bundle.readers.read_control_points`.
        Points of the project that were control points and are not in the table
        become tie points; table points the project does not observe are ignored
        (with a warning).
        """
        ids = np.asarray(control["id"])
        uniq, counts = np.unique(ids, return_counts=True)
        if np.any(counts > 1):
            raise InputError(
                f"control point id(s) {uniq[counts > 1][:10].tolist()} given more than once",
                path=control.get("source"),
                hint="every control or check point appears once in the control table",
            )
        idx = np.searchsorted(self.point_ids, ids)
        idx = np.clip(idx, 0, max(self.n_points - 1, 0))
        found = (self.n_points > 0) & (self.point_ids[idx] == ids)
        if not np.any(found):
            raise InputError(
                "none of the control point ids occurs in the project",
                path=control.get("source"),
                hint="check that the ids in the control file match the project's point ids",
            )
        if not np.all(found):
            warnings.warn(
                f"{control.get('source')}: control point id(s) {ids[~found][:10].tolist()} "
                "not observed in the project: ignored",
                BundleWarning,
                stacklevel=2,
            )
        role = np.where(self.point_role == "control", "tie", self.point_role).astype(object)
        xyz = self.xyz.copy()
        std = self.xyz_std.copy()
        std[self.point_role == "control"] = np.nan
        labels = list(self.point_labels)
        for k in np.flatnonzero(found):
            i = idx[k]
            role[i] = control["role"][k]
            xyz[i] = control["xyz"][k]
            std[i] = control["std"][k] if control["role"][k] == "control" else np.nan
            labels[i] = control["label"][k]
        return self.replace(
            point_role=role.astype(str),
            xyz=xyz,
            xyz_std=std,
            point_labels=tuple(labels),
            datum="control",
            meta={
                **self.meta,
                "control": {
                    "source": control.get("source"),
                    "layout": control.get("layout"),
                    "header": control.get("header"),
                    "echo": control.get("echo", []),
                    "n_control": int(
                        sum(r == "control" for r in np.asarray(control["role"])[found])
                    ),
                    "n_check": int(sum(r == "check" for r in np.asarray(control["role"])[found])),
                },
            },
        )

    def with_default_io(self, cc_mm: float | None = None) -> Project:
        """A copy with DBAT's default interior orientation as initial values.

        Camera constant ``cc_mm`` (default: each camera's nominal focal length),
        principal point at the sensor centre, no distortion, no affinity.
        """
        cams = []
        for c in self.cameras:
            io = np.zeros(len(IO_NAMES))
            io[0] = cc_mm if cc_mm is not None else c.extra.get("focal_mm", c.cc_mm)
            fmt = c.extra.get("format_mm", c.sensor_size_mm)
            io[1:3] = np.asarray(fmt, float) / 2
            cams.append(c.with_io(io))
        return self.replace(cameras=tuple(cams))

    def with_model(self, model: int) -> Project:
        """A copy whose cameras use lens distortion model ``model``."""
        from dataclasses import replace as _replace

        if model not in (1, 2, 3, 4, 5, -1):
            raise InputError(f"unknown lens distortion model {model}; choose 1-5 or -1")
        return self.replace(cameras=tuple(_replace(c, model=model) for c in self.cameras))

    def with_prior_positions(self, positions: dict) -> Project:
        """A copy observing camera positions (GNSS-like priors) with their accuracies.

        ``positions`` maps an image name (or id as text) to ``(xyz (3,), std (3,))``,
        see :func:`~pyheracles.bundle.readers.read_camera_positions`.  The prior
        positions also become the initial positions of those images.
        """
        eo = self.eo.copy()
        eo_std = self.eo_std.copy()
        found = 0
        for i, (name, iid) in enumerate(zip(self.image_names, self.image_ids, strict=True)):
            key = name if name in positions else str(int(iid))
            if key in positions:
                xyz, sd = positions[key]
                eo[i, :3] = xyz
                eo_std[i, :3] = sd
                found += 1
        if found == 0:
            raise InputError(
                "no camera position matches an image name or id of the project",
                hint="the first column of the position file must be the image file name or id",
            )
        return self.replace(eo=eo, eo_std=eo_std)
