"""Training data export (issue 18): blocks, objects, class map, the three formats."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pyheracles.cli import main
from pyheracles.cloud import PointCloud
from pyheracles.export.training import TRAINING_CLASSES, TrainingParams, export_training
from pyheracles.io.ply import read_ply
from pyheracles.io.results import write_segmentation
from pyheracles.labels import Segmentation

OFFSET = np.array([651000.0, 6862000.0, 30.0])


@pytest.fixture()
def result(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    """A supports-like result: 3 columns, 1 pier, a beam, a kiosk (unmapped), ground, rest."""
    rng = np.random.default_rng(5)
    n = 6000
    xyz = np.round(rng.uniform([0, 0, 0], [24, 13, 6], (n, 3)), 3)  # mm, as LAS stores
    inst = np.zeros(n, np.int32)
    cid = np.zeros(n, np.uint8)
    names = {1: "column", 2: "pier", 3: "beam", 4: "kiosk"}
    cls_of = {1: 1, 2: 1, 3: 1, 4: 2, 5: 3, 6: 4}
    for o in range(1, 7):
        sel = slice((o - 1) * 700, o * 700)
        inst[sel], cid[sel] = o, cls_of[o]
    ground = np.zeros(n, bool)
    ground[4200:5200] = True
    cls = np.where(ground, 2, 1).astype(np.uint8)
    rgb = rng.integers(0, 65535, (n, 3)).astype(np.uint16)
    cloud = PointCloud(xyz, offset=OFFSET, crs="EPSG:2154", attributes={
        "classification": cls, "red": rgb[:, 0], "green": rgb[:, 1], "blue": rgb[:, 2],
        "intensity": rng.integers(0, 4000, n).astype(np.uint16)})  # fmt: skip
    objects = pd.DataFrame({"instance": np.arange(1, 7),
                            "class": [names[cls_of[o]] for o in range(1, 7)],
                            "n_points": np.full(6, 700)})  # fmt: skip
    seg = Segmentation(instance=inst, class_id=cid, classes=names, objects=objects,
                       ground=ground)  # fmt: skip
    out = tmp_path / "supports"
    write_segmentation(cloud, seg, out, step="supports")
    return out, xyz, inst, ground


def _expected_labels(inst: np.ndarray, ground: np.ndarray) -> np.ndarray:
    by_object = {1: 1, 2: 1, 3: 1, 4: 1, 5: 10, 6: 9}  # columns+pier -> column, beam, kiosk
    lab = np.full(len(inst), 9, np.uint8)
    for o, c in by_object.items():
        lab[inst == o] = c
    lab[ground] = 3
    return lab


def test_ply_blocks_hold_every_point_once_with_its_label(result, tmp_path: Path) -> None:
    folder, xyz, inst, ground = result
    rep = export_training(folder, tmp_path / "train", TrainingParams(format="ply", block_m=5.0))
    assert rep.n_points == len(xyz) and rep.unmapped == ["kiosk"]
    blocks = pd.read_csv(tmp_path / "train" / "blocks.csv")
    assert blocks["n_points"].sum() == len(xyz)
    assert len(blocks) == rep.n_blocks == 5 * 3  # 24 x 13 m from a 651000/6862000 origin
    got_xyz, got_lab, got_inst = [], [], []
    for rel in blocks["path"]:
        pc = read_ply(tmp_path / "train" / rel)  # a real PLY our reader (and others) reads
        assert np.ptp(pc.world_xyz()[:, :2], axis=0).max() <= 5.0 + 1e-6
        got_xyz.append(pc.world_xyz())
        got_lab.append(pc.attributes["label"])
        got_inst.append(pc.attributes["instance"])
        assert set(pc.attributes) >= {"red", "green", "blue", "intensity", "label", "instance"}
    meta = json.loads((tmp_path / "train" / "classes.json").read_text())
    got = np.vstack(got_xyz) + np.array(meta["offset"]) - OFFSET  # world = xyz + offset
    key = np.lexsort(np.round(got * 1000).T)
    ref = np.lexsort(np.round(xyz * 1000).T)
    np.testing.assert_allclose(got[key], xyz[ref], atol=1e-5)  # float32 local coordinates
    np.testing.assert_array_equal(np.concatenate(got_lab)[key], _expected_labels(inst, ground)[ref])
    np.testing.assert_array_equal(np.concatenate(got_inst)[key], inst[ref])
    assert "Lambert" in meta["crs"]
    counts = {c["name"]: c["n_points"] for c in meta["classes"]}
    assert counts["column"] == 2800 and counts["beam"] == 700 and counts["floor"] == 1000
    assert sum(counts.values()) == len(xyz)
    objects = sorted(p.name for p in (tmp_path / "train" / "objects").iterdir())
    assert objects == ["beam_5.ply", "column_1.ply", "column_2.ply", "column_3.ply",
                       "column_4.ply", "other_6.ply"]  # fmt: skip


def test_npz_and_a_class_map(result, tmp_path: Path) -> None:
    folder, xyz, *_ = result
    rep = export_training(folder, tmp_path / "t", TrainingParams(
        format="npz", block_m=0, class_map={"kiosk": "wall"}))  # fmt: skip
    assert rep.n_blocks == 1 and rep.unmapped == []
    z = np.load(tmp_path / "t" / "scene" / "scene.npz")
    assert z["xyz"].dtype == np.float32 and z["rgb"].dtype == np.uint8
    assert (z["rgb"].max() <= 255) and z["rgb"].max() > 200  # 16-bit colour scaled
    assert int(np.sum(z["label"] == 5)) == 700  # the kiosk is a wall now
    np.testing.assert_allclose(z["offset"] + z["xyz"].min(axis=0), OFFSET + xyz.min(axis=0),
                               atol=1e-5)  # fmt: skip
    one = np.load(tmp_path / "t" / "objects" / "wall_6.npz")
    assert len(one["xyz"]) == 700 and set(np.unique(one["instance"])) == {6}


def test_s3dis_rooms_and_annotations(result, tmp_path: Path) -> None:
    folder, xyz, *_ = result
    export_training(folder, tmp_path / "s", TrainingParams(format="s3dis", block_m=12.0))
    rooms = sorted((tmp_path / "s" / "Area_1").iterdir())
    assert len(rooms) == 2 * 2
    total = 0
    for room in rooms:
        pts = np.loadtxt(room / f"{room.name}.txt", ndmin=2)
        assert pts.shape[1] == 6
        ann = sorted(p.name for p in (room / "Annotations").iterdir())
        n_ann = sum(len(np.loadtxt(room / "Annotations" / a, ndmin=2)) for a in ann)
        assert n_ann == len(pts)  # every point of the room in exactly one annotation
        assert all(a.split("_")[0] in {*TRAINING_CLASSES.values(), "door"} for a in ann)
        total += len(pts)
    assert total == len(xyz)


def test_cli_and_bad_input(result, tmp_path: Path, capsys) -> None:
    folder, *_ = result
    assert main(["export", "training", str(folder), "-o", str(tmp_path / "c"),
                 "--format", "npz", "--block", "8"]) == 0  # fmt: skip
    assert "6000 points" in capsys.readouterr().out
    assert main(["export", "training", str(folder), "-o", str(tmp_path / "x"),
                 "--format", "las"]) == 2  # fmt: skip
    assert "unknown training format" in capsys.readouterr().err
    assert main(["export", "training", str(tmp_path), "-o", str(tmp_path / "x")]) == 2
    assert "segmented.laz" in capsys.readouterr().err
    bad = tmp_path / "map.json"
    bad.write_text('{"kiosk": "temple"}')
    assert main(["export", "training", str(folder), "-o", str(tmp_path / "x"),
                 "--class-map", str(bad)]) == 2  # fmt: skip
    assert "not a training class" in capsys.readouterr().err
