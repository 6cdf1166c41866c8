"""Walls on the church family and IFC checks on the roof family; prints JSON.

Walls (interior + exterior TLS brought into the scene frame with ``sim.transforms``):
every true wall face found (a detected wall within 5 cm of its outer plane, both faces),
face RMS <= 1 cm, openings per wall matching the true windows + doors in count and,
matched by centre, within 5 cm in width and height.  IFC: ``heracles beams`` on a roof
draw, exported; one element per beam, dimensions = objects table (1 mm), valid.

    python benchmarks/bench_walls.py --sweep 3
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np


def church(seed: int) -> dict:
    from pyheracles.synthetic.families import simulate
    from pyheracles.walls import segment_walls

    sim = simulate("church", seed, exterior_kind="tls")
    xyz = []
    for k, c in sim.clouds.items():
        T = sim.transforms[k]
        xyz.append(c.xyz @ T[:3, :3].T + T[:3, 3])
    t = time.perf_counter()
    r = segment_walls(np.vstack(xyz))
    secs = time.perf_counter() - t
    objs = sim.scene.objects
    truth = [o for o in objs if o["class"] == "wall"]
    ops = [o for o in objs if o["class"] in ("window", "door")]
    found, count_ok, size_ok, n_sizes = 0, 0, 0, 0
    for tw in truth:
        n, d = np.asarray(tw["outer_plane"]["normal"]), tw["outer_plane"]["d"]
        match = None
        for w in r.walls:
            for f in w.faces:
                s = np.sign(f.normal @ n)
                if abs(f.normal @ n) > 0.999 and abs(s * f.d - d) < 0.05:
                    match = w
        if match is None:
            continue
        found += int(len(match.faces) == 2)
        mine = [o for o in ops if o["wall"] == tw["name"]]
        count_ok += int(len(mine) == len(match.openings))
        for o in mine:
            uc = float((np.asarray(o["box_corners_m"]).mean(axis=0) - match.origin)
                       @ match.u_axis)  # fmt: skip
            best = min(match.openings, key=lambda q: abs(0.5 * (q.u_min + q.u_max) - uc),
                       default=None)  # fmt: skip
            n_sizes += 1
            if (
                best is not None
                and abs(best.width_m - o["width_m"]) <= 0.05
                and abs(best.height_m - o["height_m"]) <= 0.05
            ):
                size_ok += 1
    return {"seed": seed, "walls_true": len(truth), "walls_found_both_faces": found,
            "walls_detected": len(r.walls), "max_face_rms_m": max(
                (f.rms_m for w in r.walls for f in w.faces), default=None),
            "walls_opening_count_ok": count_ok, "openings_size_ok": size_ok,
            "openings_true": n_sizes, "seconds": secs, "notes": list(r.notes)}  # fmt: skip


def ifc_roof(seed: int) -> dict:
    import subprocess

    import ifcopenshell
    import ifcopenshell.validate
    import pandas as pd

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        run = ["heracles", "-q", "--no-report"]
        subprocess.run([*run, "simulate", "-f", "roof", "--seed", str(seed), "-o",
                        str(d / "sim")], check=True, capture_output=True)  # fmt: skip
        subprocess.run([*run, "beams", str(d / "sim/cloud.laz"), "-o", str(d / "res")],
                       check=True, capture_output=True)  # fmt: skip
        from pyheracles.export.ifc import export_ifc

        rep = export_ifc(d / "res", d / "m.ifc")
        ifc = ifcopenshell.open(str(d / "m.ifc"))
        log = ifcopenshell.validate.json_logger()
        ifcopenshell.validate.validate(ifc, log)
        tab = pd.read_csv(d / "res/objects.csv")
        worst = 0.0
        for _, row in tab.iterrows():
            solid = ifc.by_guid(rep.guids[int(row["instance"])])
            item = solid.Representation.Representations[0].Items[0]
            worst = max(worst, abs(item.Depth - row["length_m"]),
                        abs(item.SweptArea.XDim - row["width_m"]),
                        abs(item.SweptArea.YDim - row["height_m"]))  # fmt: skip
        return {
            "seed": seed,
            "beams": len(tab),
            "elements": sum(rep.elements.values()),
            "validate_errors": len(log.statements),
            "max_dim_error_m": worst,
        }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sweep", type=int, default=1)
    args = ap.parse_args()
    out = {
        "church_walls": [church(s) for s in range(args.sweep)],
        "ifc_roof": [ifc_roof(s) for s in range(args.sweep)],
    }
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main()
