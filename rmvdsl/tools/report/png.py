"""The timeline as a PNG, painted by matplotlib (the `report` extra)."""

from __future__ import annotations

import io
from typing import Any

from rmvdsl.tools.report.layout import Timeline

DPI = 110


def render(timeline: Timeline) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    count = len(timeline.rows)
    lines = timeline.lines
    figure, axes = plt.subplots(
        1 + len(lines), 1, sharex=True, squeeze=False,
        figsize=(12, 1.2 + 0.35 * count + 1.3 * len(lines)),
        gridspec_kw={"height_ratios": [max(2, 0.35 * count)] + [1.3] * len(lines)},
    )  # fmt: skip
    top = axes[0][0]
    _bands(top, timeline)
    for axis, line in zip((a[0] for a in axes[1:]), lines, strict=True):
        xs, ys = zip(*line.points, strict=True)
        axis.step(xs, ys, where="post", linewidth=1)
        axis.set_ylabel(line.name, rotation=0, ha="right", fontsize=8)
    axes[-1][0].set_xlabel(timeline.axis_label)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    plt.close(figure)
    return buffer.getvalue()


def _bands(axis: Any, timeline: Timeline) -> None:
    count = len(timeline.rows)
    for bar in timeline.bars:
        y = count - 1 - bar.row  # row 0 at the top
        axis.broken_barh(
            [(bar.start, bar.stop - bar.start)], (y - bar.height / 2, bar.height),
            color=bar.fill, edgecolor=bar.edge or bar.fill, linewidth=0.5,
        )  # fmt: skip
        if bar.label:
            axis.text(bar.start, y, f" {bar.label}", va="center", fontsize=7, clip_on=True)
    for mark in timeline.marks:
        axis.axvline(mark.time, color=mark.colour, linewidth=0.8, alpha=0.6)
    axis.set_yticks(range(count), list(reversed(timeline.rows)))
    axis.set_ylim(-0.6, count - 0.4)
    axis.set_xlim(0, timeline.end)
    axis.set_title(timeline.title, fontsize=9)
