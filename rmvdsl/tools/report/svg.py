"""The timeline as SVG, written with the standard library alone (the HTML report
inlines it, so it opens anywhere with no network and no plotting package)."""

from __future__ import annotations

import html
import math
import re

from rmvdsl.tools.report.layout import Line, Timeline

WIDTH = 1100
LEFT, RIGHT = 170, 24  # the label column; room for the last tick label
TITLE = 30  # the title's band
ROW = 24  # one verdict, state or event row
PANEL, GAP = 80, 16  # one line's panel, and the space above it
AXIS = 44  # tick labels and the axis label
CHAR = 6.2  # a character's width at font-size 11, to fit labels in their bars


def text(value: object) -> str:
    """Any text as SVG/HTML character data or attribute value (the one quoting
    function for both): escaped, with the characters XML 1.0 forbids removed."""
    return html.escape(re.sub(r"[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]", "", str(value)))


def render(timeline: Timeline) -> str:
    plot = WIDTH - LEFT - RIGHT
    top_height = max(2, len(timeline.rows)) * ROW
    height = TITLE + top_height + len(timeline.lines) * (GAP + PANEL) + AXIS

    def x(time: float) -> float:
        return LEFT + min(max(time / timeline.end, 0.0), 1.0) * plot

    bottom = height - AXIS
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
        f'viewBox="0 0 {WIDTH} {height}" font-family="sans-serif" font-size="11">',
        f'<rect width="{WIDTH}" height="{height}" fill="white"/>',
        f'<text x="{LEFT}" y="18" font-size="12">{text(timeline.title)}</text>',
    ]
    for tick in ticks(timeline.end):
        out.append(f'<line x1="{x(tick):.1f}" y1="{TITLE}" x2="{x(tick):.1f}" y2="{bottom}" '
                   'stroke="#e0e0e0"/>')  # fmt: skip
        out.append(f'<text x="{x(tick):.1f}" y="{bottom + 16}" text-anchor="middle">'
                   f"{_number(tick)}</text>")  # fmt: skip
    out.append(f'<text x="{LEFT + plot / 2}" y="{height - 8}" text-anchor="middle">'
               f"{text(timeline.axis_label)}</text>")  # fmt: skip
    for i, name in enumerate(timeline.rows):
        out.append(f'<text x="{LEFT - 8}" y="{TITLE + (i + 0.5) * ROW + 4}" '
                   f'text-anchor="end">{text(name)}</text>')  # fmt: skip
    for bar in timeline.bars:
        left, right = x(bar.start), max(x(bar.stop), x(bar.start) + 0.5)
        y = TITLE + (bar.row + 0.5 - bar.height / 2) * ROW
        edge = f' stroke="{bar.edge}" stroke-width="0.5"' if bar.edge else ""
        out.append(f'<rect x="{left:.1f}" y="{y:.1f}" width="{right - left:.1f}" '
                   f'height="{bar.height * ROW:.1f}" fill="{bar.fill}"{edge}/>')  # fmt: skip
        label = _fitted(bar.label or "", right - left)
        if label:
            out.append(f'<text x="{left + 3:.1f}" y="{TITLE + (bar.row + 0.5) * ROW + 4:.1f}">'
                       f"{text(label)}</text>")  # fmt: skip
    for mark in timeline.marks:
        out.append(f'<line x1="{x(mark.time):.1f}" y1="{TITLE}" x2="{x(mark.time):.1f}" '
                   f'y2="{TITLE + top_height}" stroke="{mark.colour}" '
                   'stroke-opacity="0.6"/>')  # fmt: skip
    for i, line in enumerate(timeline.lines):
        out += _panel(line, TITLE + top_height + GAP + i * (GAP + PANEL), x, plot)
    out.append("</svg>")
    return "\n".join(out) + "\n"


def _panel(line: Line, top: float, x: object, plot: int) -> list[str]:
    """One variable's step line in its own panel, with its range on the left."""
    assert callable(x)
    points = decimated(line.points, plot)
    low = min(v for _, v in points)
    high = max(v for _, v in points)
    if high == low:
        low, high = low - 1, high + 1

    def y(value: float) -> float:
        return top + PANEL - (value - low) / (high - low) * PANEL

    steps = [f"M{x(points[0][0]):.1f},{y(points[0][1]):.1f}"]
    for time, value in points[1:]:
        steps.append(f"H{x(time):.1f}V{y(value):.1f}")
    steps.append(f"H{x(float('inf')):.1f}")
    return [
        f'<rect x="{LEFT}" y="{top}" width="{plot}" height="{PANEL}" fill="none" '
        'stroke="#bdbdbd"/>',
        f'<text x="{LEFT - 8}" y="{top + PANEL / 2 + 4}" text-anchor="end">'
        f"{text(line.name)}</text>",
        f'<text x="{LEFT + 3}" y="{top + 11}" fill="#757575">{_number(high)}</text>',
        f'<text x="{LEFT + 3}" y="{top + PANEL - 3}" fill="#757575">{_number(low)}</text>',
        f'<path d="{"".join(steps)}" fill="none" stroke="#1f77b4" stroke-width="1"/>',
    ]


def decimated(points: tuple[tuple[float, float], ...], columns: int) -> list[tuple[float, float]]:
    """At most about four points a pixel column: each column's first, lowest,
    highest and last, in time order, so no peak is lost and the file stays small
    whatever the recording's length."""
    if len(points) <= 4 * columns:
        return list(points)
    start, stop = points[0][0], points[-1][0]
    span = (stop - start) or 1.0
    kept: list[tuple[float, float]] = []
    column: list[tuple[float, float]] = []
    current = 0
    for point in points:
        index = min(int((point[0] - start) / span * columns), columns - 1)
        if index != current and column:
            kept += _extremes(column)
            column = []
        current = index
        column.append(point)
    return kept + _extremes(column)


def _extremes(column: list[tuple[float, float]]) -> list[tuple[float, float]]:
    chosen = {0, len(column) - 1}
    chosen.add(min(range(len(column)), key=lambda i: column[i][1]))
    chosen.add(max(range(len(column)), key=lambda i: column[i][1]))
    return [column[i] for i in sorted(chosen)]


def ticks(end: float, most: int = 10) -> list[float]:
    """Round times from 0 to `end`: steps of 1, 2 or 5 times a power of ten."""
    raw = end / most
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    return [i * step for i in range(int(end / step + 1e-9) + 1)]


def _number(value: float) -> str:
    return f"{value:.6g}"


def _fitted(label: str, width: float) -> str:
    """The label cut to the bar's width (with an ellipsis), or nothing."""
    room = int((width - 6) / CHAR)
    if room >= len(label):
        return label
    return label[: room - 1] + "…" if room >= 2 else ""
