"""The supports scorer measures a pier's box only across sides whose two faces were
scanned (issue 12's pier-box target): a face turned away from every station has no
points, and nothing can measure the side across it."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from pyheracles.synthetic.families.supports_score import observable_sides

W, D, H = 0.72, 0.64, 4.0


def _pier(faces: tuple[bool, bool, bool, bool], yaw_deg: float = 30.0) -> tuple:
    """Points on the faces +x, -x, +y, -y (in the pier's frame) that are ``True``."""
    rng = np.random.default_rng(3)
    pts = []
    for k, sign in ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)):
        if not faces[len(pts)]:
            pts.append(np.zeros((0, 3)))
            continue
        n = 400
        q = np.zeros((n, 3))
        half = (W / 2, D / 2)
        q[:, k] = sign * half[k] + rng.normal(0, 0.003, n)
        q[:, 1 - k] = rng.uniform(-half[1 - k], half[1 - k], n)
        q[:, 2] = rng.uniform(0.2, H - 0.2, n)
        pts.append(q)
    q = np.vstack(pts)
    a = np.radians(yaw_deg)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    xyz = np.c_[q[:, :2] @ rot.T + [5.0, 2.0], q[:, 2]]
    res = SimpleNamespace(xyz=xyz, instance=np.full(len(xyz), 7))
    row = {
        "instance": 7, "axis_base": [5.0, 2.0, 0.0], "axis_direction": [0.0, 0.0, 1.0],
        "z_bottom": 0.0, "parts": {"shaft": [0.1, H - 0.1]}, "box_yaw_deg": yaw_deg,
        "box_width_m": W, "box_depth_m": D,
    }  # fmt: skip
    return res, np.ones(len(xyz), bool), row


def test_a_side_is_measurable_only_when_both_its_faces_were_scanned() -> None:
    assert observable_sides(*_pier((True, True, True, True))) == (True, True)
    assert observable_sides(*_pier((True, False, True, True))) == (False, True)
    assert observable_sides(*_pier((True, True, False, True))) == (True, False)
    assert observable_sides(*_pier((False, True, True, False))) == (False, False)


def test_outliers_and_other_objects_do_not_make_a_face_seen() -> None:
    res, valid, row = _pier((True, False, True, True))
    # points on the missing face that are outliers, or another object's
    extra = np.c_[np.full(50, -W / 2), np.linspace(-D / 2, D / 2, 50), np.full(50, 1.0)]
    a = np.radians(row["box_yaw_deg"])
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    extra = np.c_[extra[:, :2] @ rot.T + [5.0, 2.0], extra[:, 2]]
    res.xyz = np.vstack([res.xyz, extra, extra])
    res.instance = np.r_[res.instance, np.full(50, 7), np.full(50, 8)]
    valid = np.r_[valid, np.zeros(50, bool), np.ones(50, bool)]
    assert observable_sides(res, valid, row) == (False, True)
