"""Roofs on AHN3 tile 1 + BGT footprints: LoD2.2 RMS, validity, LoD1.2 heights, speed.

Targets (issue 18): median building LoD2.2 roof faces within 0.15 m RMS of its roof
points; every solid valid; LoD1.2 height within 0.3 m of the 70th-percentile roof
height; roofs of the 640 k point tile in <= 30 s; footprints without (roof) points
listed, not modelled.  Prints JSON.

    python3 benchmarks/bench_roofs.py
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from _common import interruptible

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "delft_ahn3"


def main() -> int:
    from pyheracles.export.validate_solid import validate_solid
    from pyheracles.io import read_cloud
    from pyheracles.io.vector import read_layer
    from pyheracles.roofs import model_roofs

    cloud = read_cloud(DATA / "ahn3_tile1.laz")
    fps = read_layer(DATA / "bgt" / "bgt_pand.sqlite")
    cls = cloud.attributes["classification"]
    t = time.perf_counter()
    r = model_roofs(cloud.xyz, fps, offset=cloud.offset, classification=cls)
    seconds = time.perf_counter() - t
    o = r.objects
    invalid = 0
    lod12_err = []
    for inst, m in r.models.items():
        invalid += bool(validate_solid(m.lod12.vertices, m.lod12.faces))
        if m.lod22 is not None:
            invalid += bool(validate_solid(m.lod22.vertices, m.lod22.faces))
        top = float(m.lod12.vertices[:, 2].max()) + float(cloud.offset[2])
        lod12_err.append(abs(top - float(o.loc[o["instance"] == inst, "lod12_z"].iloc[0])))
    pts = r.roof_plane > 0
    z = cloud.xyz[:, 2]
    p70_err = []
    for inst, m in r.models.items():
        sel = (r.instance == inst) & (z > m.ground_z + 1.0)
        if sel.any():
            p70_err.append(abs(float(m.lod12.vertices[:, 2].max()) - np.percentile(z[sel], 70)))
    rms = o["lod22_rms_m"].to_numpy(dtype=float)
    out = {
        "points": len(cloud.xyz), "footprints": len(fps),
        "modelled": len(o), "lod22": int(o["lod22"].sum()),
        "skipped": len(r.skipped), "skipped_reasons": r.skipped,
        "dropped_lod22": r.warnings,
        "lod22_rms_m_median": float(np.nanmedian(rms)),
        "lod22_rms_m_p75": float(np.nanpercentile(rms, 75)),
        "target_rms_m": 0.15,
        "invalid_solids": invalid,
        "lod12_height_err_m_max": float(max(p70_err)) if p70_err else None,
        "target_lod12_err_m": 0.3,
        "roof_points_on_planes": int(pts.sum()),
        "seconds": round(seconds, 2), "target_seconds": 30.0,
    }  # fmt: skip
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    interruptible(main)
