"""Small charts of a report written directly as SVG (vector, prints sharply, costs milliseconds).

matplotlib took about a second to lay out and encode a bar chart of 30 labelled
bars; a bar chart is simple enough to write as SVG elements.

Examples
--------
>>> svg = bar_chart_svg(["a", "b"], [0.5, 0.99], target=0.95, target_label="target")
>>> svg.startswith("<svg") and svg.count("<rect") >= 2
True
"""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np

__all__ = ["bar_chart_svg"]


def bar_chart_svg(
    labels: Sequence[str],
    values: Sequence[float],
    *,
    xmax: float = 1.0,
    target: float | None = None,
    target_label: str = "",
    xlabel: str = "",
    colour: str = "#4682b4",
    below_colour: str = "#d98c1f",
    width: int = 720,
    bar_px: int = 16,
) -> str:
    """A horizontal bar chart as an ``<svg>`` element.

    Parameters
    ----------
    labels, values
        One bar per label; NaN values get no bar and the text "NaN".
    xmax
        Value at the right end of the axis.
    target
        Dashed vertical line at this value; bars below it are drawn in ``below_colour``.
    target_label, xlabel
        Legend text of the line, and the axis title.
    width, bar_px
        Width of the chart and height of a bar row, pixels.
    """
    esc = html.escape
    n = len(labels)
    left = min(260, 12 + 6.5 * max((len(str(s)) for s in labels), default=4))
    right, top, bottom = 60, 26 if target is not None else 8, 44
    plot_w = width - left - right
    height = top + n * bar_px + bottom

    def x(v: float) -> float:
        return left + plot_w * min(max(v, 0.0), xmax) / xmax

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" class="chart" width="{width}" '
        f'height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" '
        'font-size="11">'
    ]
    for t in np.linspace(0, xmax, 6):
        xt = x(float(t))
        out.append(
            f'<line x1="{xt:.1f}" y1="{top}" x2="{xt:.1f}" y2="{top + n * bar_px}" '
            'stroke="#e4e8ec"/>'
            f'<text x="{xt:.1f}" y="{top + n * bar_px + 14}" text-anchor="middle">{t:.2g}</text>'
        )
    for k, (lab, v) in enumerate(zip(labels, values, strict=True)):
        y = top + k * bar_px
        out.append(
            f'<text x="{left - 6}" y="{y + bar_px * 0.72:.1f}" text-anchor="end">'
            f"{esc(str(lab))}</text>"
        )
        if v is None or not np.isfinite(v):
            out.append(
                f'<text x="{left + 4}" y="{y + bar_px * 0.72:.1f}" fill="#b00020">NaN</text>'
            )
            continue
        fill = below_colour if target is not None and v < target else colour
        out.append(
            f'<rect x="{left}" y="{y + 2}" width="{x(v) - left:.1f}" height="{bar_px - 4}" '
            f'fill="{fill}"><title>{esc(str(lab))}: {v:.4f}</title></rect>'
            f'<text x="{x(v) + 4:.1f}" y="{y + bar_px * 0.72:.1f}">{v:.3f}</text>'
        )
    if target is not None:
        xt = x(target)
        out.append(
            f'<line x1="{xt:.1f}" y1="{top - 4}" x2="{xt:.1f}" y2="{top + n * bar_px}" '
            'stroke="crimson" stroke-dasharray="5,3"/>'
            f'<text x="{xt:.1f}" y="{top - 9}" text-anchor="middle" fill="crimson">'
            f"{esc(target_label)}</text>"
        )
    if xlabel:
        out.append(
            f'<text x="{left + plot_w / 2:.1f}" y="{height - 8}" text-anchor="middle">'
            f"{esc(xlabel)}</text>"
        )
    out.append("</svg>")
    return "".join(out)
