"""Plan view of a labelled cloud: every object in its own colour and labelled by its name.

Written as SVG: the points as one embedded raster (one pixel per point, objects
drawn over the ground), the GIS outlines, labels, axes and legend as vector
elements.  It prints sharply and takes milliseconds; the matplotlib version
spent about 1.5 s laying out 30 labels and a 30-entry legend.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pyheracles.io.atomic import atomic_write_text
from pyheracles.report.colours import GROUND, REMAINDER, hex_colour, object_colours
from pyheracles.report.folder import CloudSample

__all__ = ["nice_ticks", "plan_svg", "plot_plan"]


def plot_plan(sample: CloudSample, labels: Mapping[int, str], path: str | Path, **kw: Any) -> Path:
    """Write :func:`plan_svg` to an ``.svg`` file, atomically."""
    return atomic_write_text(Path(path), plan_svg(sample, labels, **kw))


def nice_ticks(lo: float, hi: float, n: int = 6) -> np.ndarray:
    """About ``n`` round tick values (steps of 1, 2 or 5 x 10^k) within ``[lo, hi]``.

    Examples
    --------
    >>> nice_ticks(215003.2, 215071.9).tolist()
    [215010.0, 215020.0, 215030.0, 215040.0, 215050.0, 215060.0, 215070.0]
    """
    span = max(hi - lo, 1e-9)
    raw = span / max(n, 1)
    mag = 10.0 ** np.floor(np.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    return np.arange(np.ceil(lo / step) * step, hi + step * 1e-9, step)


def _raster_png(
    layers: Sequence[tuple[np.ndarray, np.ndarray]],
    lo: np.ndarray,
    cell: float,
    shape: tuple[int, int],
) -> bytes:
    """PNG (transparent, row 0 = north) of points as 2 x 2 pixel dots, each layer over the last.

    ``layers`` are ``(xy, rgb 0-1)`` pairs in drawing order (ground, remainder, objects).
    """
    from PIL import Image

    h, w = shape
    img = np.zeros(h * w, np.uint32)  # RGBA packed, little-endian
    for xy, colours in layers:
        col = np.clip(((xy[:, 0] - lo[0]) / cell).astype(np.int64), 0, w - 2)
        row = np.clip(h - 1 - ((xy[:, 1] - lo[1]) / cell).astype(np.int64), 1, h - 1)
        rgb = np.round(255 * np.asarray(colours)).astype(np.uint32)
        packed = rgb[:, 0] | (rgb[:, 1] << 8) | (rgb[:, 2] << 16) | np.uint32(255 << 24)
        at = row * w + col
        for off in (0, 1, -w, 1 - w):
            img[at + off] = packed
    img = img.view(np.uint8).reshape(h, w, 4)
    buf = io.BytesIO()
    Image.fromarray(img, "RGBA").save(buf, format="PNG", compress_level=3)
    return buf.getvalue()


def plan_svg(
    sample: CloudSample,
    labels: Mapping[int, str],
    *,
    footprints: Any = None,
    missing: Sequence[str] = (),
    title: str = "",
    max_legend: int = 40,
    map_px: tuple[int, int] = (760, 720),
) -> str:
    """A plan as an ``<svg>`` element: ground light grey, remainder dark grey, objects named.

    Parameters
    ----------
    sample
        The (subsampled) labelled cloud.
    labels
        Instance -> name shown on the map and in the legend.
    footprints
        GeoDataFrame of the objects' polygons (world coordinates), drawn as outlines.
    missing
        Features that got no points (warnings), listed under the map.
    title
        First line of the title; the number of objects and the CRS follow.
    max_legend
        Objects listed in the legend at most (every object stays labelled on the map).
    map_px
        Largest width and height of the map, pixels (one raster pixel per screen pixel).
    """
    import shapely

    esc = html.escape
    xy = sample.xyz[:, :2].astype(float)
    inst = sample.instance
    ids = [int(i) for i in np.unique(inst) if i > 0]
    cols = object_colours(max(ids, default=0))
    o = sample.origin[:2]
    lo, hi = (xy.min(0), xy.max(0)) if len(xy) else (np.zeros(2), np.ones(2))
    span = np.maximum(hi - lo, 1e-6)
    cell = float(max(span[0] / map_px[0], span[1] / map_px[1]))
    shape = (int(span[1] / cell) + 1, int(span[0] / cell) + 1)
    w, h = shape[1], shape[0]
    left, top, legend_w = 78, 52, 300
    width, height = left + w + 24 + legend_w, top + h + 58 + (16 if missing else 0)

    def sx(e: np.ndarray | float) -> np.ndarray | float:
        return left + (np.asarray(e) - o[0] - lo[0]) / cell

    def sy(n: np.ndarray | float) -> np.ndarray | float:
        return top + h - (np.asarray(n) - o[1] - lo[1]) / cell

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" class="chart plan" width="{width}" '
        f'height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" '
        'font-size="11">'
    ]
    crs = sample.crs or "no CRS (local coordinates)"
    out.append(
        f'<text x="{left}" y="18" font-size="13" font-weight="bold">{esc(title)}</text>'
        f'<text x="{left}" y="36" font-size="12">{len(ids)} objects; CRS: {esc(crs)}</text>'
    )
    if len(xy):
        g = sample.ground & (inst == 0)
        rest = (inst == 0) & ~sample.ground
        m = inst > 0
        layers = [
            (xy[g], np.broadcast_to(GROUND, (int(g.sum()), 3))),
            (xy[rest], np.broadcast_to(REMAINDER, (int(rest.sum()), 3))),
            (xy[m], cols[inst[m] - 1]),
        ]
        png = _raster_png(layers, lo, cell, shape)
        uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
        out.append(
            f'<image x="{left}" y="{top}" width="{w}" height="{h}" href="{uri}" '
            'style="image-rendering:pixelated"/>'
        )
    out.append(f'<rect x="{left}" y="{top}" width="{w}" height="{h}" fill="none" stroke="#888"/>')
    for t in nice_ticks(lo[0] + o[0], hi[0] + o[0]):
        x = float(sx(t))
        out.append(
            f'<line x1="{x:.1f}" y1="{top + h}" x2="{x:.1f}" y2="{top + h + 4}" stroke="#444"/>'
            f'<text x="{x:.1f}" y="{top + h + 16}" text-anchor="middle">{t:.10g}</text>'
        )
    for t in nice_ticks(lo[1] + o[1], hi[1] + o[1]):
        y = float(sy(t))
        out.append(
            f'<line x1="{left - 4}" y1="{y:.1f}" x2="{left}" y2="{y:.1f}" stroke="#444"/>'
            f'<text x="{left - 6}" y="{y + 4:.1f}" text-anchor="end">{t:.10g}</text>'
        )
    out.append(
        f'<text x="{left + w / 2:.1f}" y="{top + h + 34}" text-anchor="middle">E (m)</text>'
        f'<text x="16" y="{top + h / 2:.1f}" text-anchor="middle" '
        f'transform="rotate(-90 16 {top + h / 2:.1f})">N (m)</text>'
    )
    if footprints is not None and len(footprints):
        d = []
        for b in shapely.get_parts(shapely.boundary(np.asarray(footprints.geometry.values))):
            if b is None or b.is_empty:
                continue
            c = shapely.get_coordinates(b)
            pts = " ".join(
                f"{a:.1f},{q:.1f}" for a, q in zip(sx(c[:, 0]), sy(c[:, 1]), strict=True)
            )
            d.append(f"M{pts}")
        out.append(f'<path d="{" ".join(d)}" fill="none" stroke="black" stroke-width="0.7"/>')
    world = xy + o
    order = np.argsort(inst, kind="stable")
    starts = np.searchsorted(inst[order], ids)
    ends = np.searchsorted(inst[order], ids, side="right")
    for i, s0, e0 in zip(ids, starts, ends, strict=True):
        p = world[order[s0:e0]]
        x, y = float(sx(np.median(p[:, 0]))), float(sy(np.median(p[:, 1])))
        colour = hex_colour(cols[i - 1])
        out.append(
            f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3.5" fill="{colour}" stroke="black" '
            'stroke-width="0.6"/>'
            f'<text x="{x + 5:.1f}" y="{y + 3.5:.1f}" font-size="10" stroke="white" '
            'stroke-width="3" paint-order="stroke" stroke-linejoin="round">'
            f"{esc(labels.get(i, f'object {i}'))}</text>"
        )
    entries = [("ground", hex_colour(GROUND)), ("remainder", hex_colour(REMAINDER))]
    entries += [(labels.get(i, f"object {i}"), hex_colour(cols[i - 1])) for i in ids[:max_legend]]
    lx, ly = left + w + 24, top + 4
    for k, (name, colour) in enumerate(entries):
        y = ly + 15 * k
        out.append(
            f'<rect x="{lx}" y="{y}" width="10" height="10" fill="{colour}"/>'
            f'<text x="{lx + 15}" y="{y + 9}">{esc(name)}</text>'
        )
    y = ly + 15 * len(entries)
    if footprints is not None and len(footprints):
        out.append(
            f'<line x1="{lx}" y1="{y + 5}" x2="{lx + 10}" y2="{y + 5}" stroke="black"/>'
            f'<text x="{lx + 15}" y="{y + 9}">GIS outline</text>'
        )
        y += 15
    if len(ids) > max_legend:
        out.append(f'<text x="{lx}" y="{y + 9}">... {len(ids) - max_legend} more (on map)</text>')
    if missing:
        text = "features with no points: " + ", ".join(missing[:30])
        if len(missing) > 30:
            text += f" ... ({len(missing)} in all)"
        out.append(
            f'<text x="{left}" y="{height - 8}" fill="crimson" font-size="11">{esc(text)}</text>'
        )
    out.append("</svg>")
    return "".join(out)
