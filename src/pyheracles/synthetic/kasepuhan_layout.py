"""The layout of the Kasepuhan complex: its buildings, walls, gates and fixed trees.

Tables in local metres read by :mod:`pyheracles.synthetic.complex_scene`
(Murtiyoso 2020, chapter 5, for the complex it imitates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Wing:
    """One wing of a building: wall/platform rectangle and roof rectangle (local metres)."""

    rect: tuple[float, float, float, float]
    eave_height_m: float = 3.0
    roof: str = "hipped"
    eaves_m: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8)  # W, S, E, N


@dataclass(frozen=True)
class Building:
    """One building of the ``building`` layer: feature id, attributes and wings."""

    fid: str
    name: str
    function: str
    period: str
    kind: str  # "pendopo" (open, columns), "closed", "round", "demolished"
    parts: tuple[Wing, ...]


def wing(
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    h: float = 3.0,
    roof: str = "hipped",
    eaves: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8),
) -> Wing:
    """A :class:`Wing` from its rectangle's corners (the layout table's short form)."""
    return Wing((x0, y0, x1, y1), h, roof, eaves)


# fmt: off
BUILDINGS: tuple[Building, ...] = (
    # Siti Inggil terrace: five open pavilions (mande)
    Building("B01", "Mande Malang Semirang", "pavilion", "15th c.", "pendopo",
              (wing(67.0, 165.0, 73.0, 171.0, 2.6, "joglo"),)),
    Building("B02", "Mande Pendawa Lima", "pavilion", "15th c.", "pendopo",
              (wing(53.5, 167.0, 58.5, 173.0, 2.5, "hipped"),)),
    Building("B03", "Mande Semar Tinandu", "pavilion", "15th c.", "pendopo",
              (wing(81.5, 167.5, 86.5, 172.5, 2.5, "pyramid"),)),
    Building("B04", "Mande Pangiring", "pavilion", "15th c.", "pendopo",
              (wing(54.0, 155.5, 58.0, 160.5, 2.4, "hipped"),)),
    Building("B05", "Mande Karasemen", "pavilion", "15th c.", "pendopo",
              (wing(81.5, 156.0, 86.5, 160.0, 2.4, "hipped"),)),
    # outside the north wall, on the alun-alun side
    Building("B06", "Pancaratna", "audience pavilion", "16th c.", "pendopo",
              (wing(36.0, 192.5, 44.0, 196.5, 2.8, "hipped"),)),
    Building("B07", "Pancaniti", "audience pavilion", "16th c.", "pendopo",
              (wing(24.0, 134.0, 36.0, 144.0, 3.0, "joglo"),)),
    # twin pavilions: one feature, two parts (MultiPolygon)
    Building("B08", "Bale Kembar", "guard pavilions", "18th c.", "pendopo",
              (wing(98.0, 138.0, 102.0, 142.0, 2.4, "pyramid"),
               wing(110.0, 138.0, 114.0, 142.0, 2.4, "pyramid"))),
    Building("B09", "Langgar Alit", "prayer house", "16th c.", "closed",
              (wing(26.5, 76.5, 33.5, 83.5, 3.2, "tumpang"),)),
    Building("B10", "Bangsal Prabayaksa", "audience hall", "17th c.", "pendopo",
              (wing(63.0, 98.0, 77.0, 106.0, 3.2, "joglo"),)),
    # main building around an inner courtyard (polygon with a hole)
    Building("B11", "Dalem Arum Kedaton", "residence", "17th c.", "closed",
              (wing(50.0, 81.0, 90.0, 90.0, 3.6), wing(50.0, 60.0, 90.0, 69.0, 3.6),
               wing(50.0, 69.0, 60.0, 81.0, 3.4), wing(80.0, 69.0, 90.0, 81.0, 3.4))),
    Building("B12", "Bangsal Pringgandani", "reception hall", "18th c.", "closed",
              (wing(96.0, 30.0, 116.0, 40.0, 3.4), wing(106.0, 40.0, 116.0, 52.0, 3.4))),
    # a row of rooms sharing party walls (touching polygons)
    Building("B13", "Gedong Jinem", "storeroom", "18th c.", "closed",
              (wing(16.0, 30.0, 24.0, 36.5, 2.8, eaves=(0.8, 0.8, 0.8, 0.0)),)),
    Building("B14", "Kaputran 1", "residence", "18th c.", "closed",
              (wing(16.0, 36.5, 24.0, 43.0, 3.2, eaves=(0.8, 0.0, 0.8, 0.0)),)),
    Building("B15", "Kaputran 2", "residence", "18th c.", "closed",
              (wing(16.0, 43.0, 24.0, 49.5, 3.0, eaves=(0.8, 0.0, 0.8, 0.0)),)),
    Building("B16", "Kaputran 3", "residence", "19th c.", "closed",
              (wing(16.0, 49.5, 24.0, 56.0, 3.4, eaves=(0.8, 0.0, 0.8, 0.8)),)),
    Building("B17", "Museum Pusaka", "museum", "20th c.", "closed",
              (wing(30.0, 22.0, 46.0, 30.0, 3.6),)),
    Building("B18", "Bale Bundar", "pavilion", "19th c.", "round",
              (wing(102.0, 77.0, 108.0, 83.0, 2.4),)),
    # cut by the eastern edge of the survey (partly outside the cloud)
    Building("B19", "Gedong Lonceng", "warehouse", "20th c.", "closed",
              (wing(132.0, 55.0, 146.0, 67.0, 3.4),)),
    # demolished, still in the GIS; today a pond (no returns)
    Building("B20", "Bangsal Kaputren", "residence (demolished)", "17th c.", "demolished",
              (wing(97.5, 158.0, 109.5, 166.0, 3.0),)),
)
# fmt: on


@dataclass(frozen=True)
class WallRun:
    """One wall of the ``wall`` layer: a polyline of constant thickness and height."""

    fid: str
    name: str
    function: str
    material: str
    period: str
    line: tuple[tuple[float, float], ...]
    thickness_m: float
    height_m: float
    free_ends: bool = False


PERIM_T, PERIM_H = 0.5, 2.5
INNER_T, INNER_H = 0.4, 1.8
# fmt: off
WALLS: tuple[WallRun, ...] = (
    WallRun("W01", "Benteng lor-wetan", "perimeter wall", "red brick", "16th c.",
             ((73.0, 188.0), (128.0, 188.0), (128.0, 102.0)), PERIM_T, PERIM_H),
    WallRun("W02", "Benteng kidul-wetan", "perimeter wall", "red brick", "16th c.",
             ((128.0, 98.0), (128.0, 12.0), (72.0, 12.0)), PERIM_T, PERIM_H),
    WallRun("W03", "Benteng kulon", "perimeter wall", "red brick", "16th c.",
             ((68.0, 12.0), (12.0, 12.0), (12.0, 188.0), (67.0, 188.0)), PERIM_T, PERIM_H),
    WallRun("W04", "Tembok Buk Bacem kulon", "internal wall", "plastered brick", "17th c.",
             ((12.25, 120.0), (68.0, 120.0)), INNER_T, 2.2),
    WallRun("W05", "Tembok Buk Bacem wetan", "internal wall", "plastered brick", "17th c.",
             ((72.0, 120.0), (127.75, 120.0)), INNER_T, 2.2),
    WallRun("W06", "Tembok Siti Inggil", "terrace wall", "red brick", "15th c.",
             ((73.0, 150.0), (95.0, 150.0), (95.0, 182.0), (45.0, 182.0), (45.0, 150.0),
              (67.0, 150.0)), INNER_T, INNER_H),
    WallRun("W07", "Kelir", "screen wall", "plastered brick", "18th c.",
             ((67.0, 115.0), (73.0, 115.0)), 0.3, 2.0, free_ends=True),
)
# fmt: on


@dataclass(frozen=True)
class Gate:
    """One gate of the ``gate`` layer: split (candi bentar) or roofed (paduraksa)."""

    fid: str
    name: str
    function: str
    gate_type: str  # "candi bentar" | "paduraksa"
    period: str
    centre: tuple[float, float]
    along_x: bool  # the wall runs along x at this gate
    opening_m: float = 2.8
    depth_m: float = 2.2
    width_m: float = 4.0  # paduraksa: size along the wall


# fmt: off
GATES: tuple[Gate, ...] = (
    Gate("G01", "Gapura Adi", "main gate", "candi bentar", "15th c.", (70.0, 188.0), True),
    Gate("G02", "Regol Pengada", "south gate", "paduraksa", "16th c.", (70.0, 12.0), True,
          depth_m=3.0),
    Gate("G03", "Lawang Sanga", "river gate", "paduraksa", "16th c.", (128.0, 100.0), False,
          depth_m=3.0),
    Gate("G04", "Pintu Buk Bacem", "inner gate", "paduraksa", "17th c.", (70.0, 120.0), True,
          depth_m=2.6),
    Gate("G05", "Gapura Banteng", "terrace gate", "candi bentar", "15th c.", (70.0, 150.0),
          True, depth_m=1.8),
)
# fmt: on

# Trees placed so that their crowns overhang roofs and walls: (x, y, crown radius, trunk height)
TREES_FIXED = np.array(
    [
        [50.5, 92.5, 5.0, 4.0],  # over the NW corner of B11
        [20.0, 185.0, 4.0, 3.0],  # over the perimeter wall
        [42.0, 176.0, 3.5, 3.0],  # over the Siti Inggil wall
        [62.0, 113.0, 4.0, 3.5],  # over the inner wall W04 and the kelir
        [27.0, 63.0, 3.5, 3.0],  # over the row buildings
        [118.0, 45.0, 4.5, 3.5],  # over B12
        [92.0, 150.0, 3.5, 3.0],  # over the terrace wall corner
        [126.0, 150.0, 4.0, 3.0],  # over the east perimeter wall
        [38.0, 146.5, 3.5, 3.5],  # over Pancaniti B07
        [110.0, 85.0, 3.0, 3.0],  # over the round pavilion B18
    ]
)
