"""`rmv replay --report`: one picture of a replay on a shared time axis.

Rows, top to bottom: each property's verdict (true green, false red, unknown
grey), each transducer's state, each boolean event, and the numeric variables and
value events as lines; alerts and intrusions as marks on the top axis. PNG through
matplotlib; HTML embeds that PNG and lists the same records, so it opens with no
network.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Record

COLOURS = {"true": "#2e7d32", "false": "#c62828", "unknown": "#9e9e9e"}


def _figure(spec: ir.Spec, records: Sequence[Record]) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    origin: Any = min((_when(r) for r in records if "time" in r or "from" in r), default=0)
    records = [_shifted(r, origin) for r in records]
    verdicts = [r for r in records if r["kind"] == "verdict"]
    states = [r for r in records if r["kind"] == "state"]
    events = [r for r in records if r["kind"] == "event"]
    series: dict[str, list[tuple[float, float]]] = {}
    for r in records:
        if r["kind"] in ("variable", "event") and _numeric(r["value"]):
            series.setdefault(r["name"], []).append((float(r["time"]), float(r["value"])))
    booleans = [e.name for e in spec.events if e.kind == "boolean"]
    bands = [p.name for p in spec.properties] + [t.name for t in spec.transducers] + booleans
    timed = [r for r in records if r["kind"] in ("verdict", "state", "event", "variable")]
    end = max((float(r["to"] if "to" in r else r["time"]) for r in timed), default=1.0)
    lines = [name for name in series if name not in booleans][:6]
    figure, axes = plt.subplots(
        1 + len(lines), 1, sharex=True, squeeze=False,
        figsize=(12, 1.2 + 0.35 * len(bands) + 1.3 * len(lines)),
        gridspec_kw={"height_ratios": [max(2, 0.35 * len(bands))] + [1.3] * len(lines)},
    )  # fmt: skip
    top = axes[0][0]
    row = {name: len(bands) - 1 - i for i, name in enumerate(bands)}
    for r in verdicts:
        start, stop = float(r["from"]), float(r["to"])
        top.broken_barh(
            [(start, max(stop - start, end * 1e-4))], (row[r["property"]] - 0.4, 0.8),
            color=COLOURS[r["verdict"]],
        )  # fmt: skip
    _steps(top, row, states, "transducer", "state", end)
    _booleans(top, row, events, set(booleans), end)
    for r in records:
        # An alert is marked where its level changes (not at every point at a level);
        # an intrusion where it starts.
        if r["kind"] == "alert" and r["level"] != r["previous"]:
            top.axvline(float(r["time"]), color="#ef6c00", linewidth=0.8, alpha=0.6)
        elif r["kind"] == "intrusion" and r["phase"] == "start":
            top.axvline(float(r["time"]), color="#6a1b9a", linewidth=0.8, alpha=0.6)
    top.set_yticks(range(len(bands)), list(reversed(bands)))
    top.set_ylim(-0.6, len(bands) - 0.4)
    top.set_title(f"{spec.system.name}: verdicts (green true, red false, grey unknown), states, "
                  "events; alert level changes orange, intrusions purple", fontsize=9)  # fmt: skip
    for axis, name in zip((a[0] for a in axes[1:]), lines, strict=False):
        xs, ys = zip(*series[name], strict=True)
        axis.step(xs, ys, where="post", linewidth=1)
        axis.set_ylabel(name, rotation=0, ha="right", fontsize=8)
    axes[-1][0].set_xlabel(f"seconds after {float(origin):.3f} on the recording's clock")
    figure.tight_layout()
    return figure


def _when(record: Record) -> Any:
    return record["from"] if "from" in record else record["time"]


def _shifted(record: Record, origin: Any) -> Record:
    """The record with its times counted from the start of the replay."""
    out = dict(record)
    for key in ("time", "from", "to"):
        if key in out:
            out[key] = out[key] - origin
    return out


def _numeric(value: Any) -> bool:
    if isinstance(value, bool | str):
        return False
    return isinstance(value, int | float) or hasattr(value, "denominator")


def _steps(axis: Any, row: dict[str, int], states: list[Record], key: str, value: str,
           end: float) -> None:  # fmt: skip
    """Each transducer's states as labelled bars."""
    by_owner: dict[str, list[Record]] = {}
    for r in states:
        by_owner.setdefault(r[key], []).append(r)
    for owner, changes in by_owner.items():
        for i, r in enumerate(changes):
            start = float(r["time"])
            stop = float(changes[i + 1]["time"]) if i + 1 < len(changes) else end
            axis.broken_barh([(start, stop - start)], (row[owner] - 0.4, 0.8),
                             color="#bbdefb", edgecolor="#1565c0", linewidth=0.5)  # fmt: skip
            axis.text(start, row[owner], f" {r[value]}", va="center", fontsize=7, clip_on=True)


def _booleans(axis: Any, row: dict[str, int], events: list[Record], names: set[str],
              end: float) -> None:  # fmt: skip
    since: dict[str, float] = {}
    for r in events:
        if r["name"] not in names:
            continue
        if r["value"] is True:
            since[r["name"]] = float(r["time"])
        elif r["name"] in since:
            start = since.pop(r["name"])
            axis.broken_barh([(start, max(float(r["time"]) - start, end * 1e-4))],
                             (row[r["name"]] - 0.3, 0.6), color="#ffb300")  # fmt: skip
    for name, start in since.items():
        axis.broken_barh([(start, end - start)], (row[name] - 0.3, 0.6), color="#ffb300")


def write(path: str, spec: ir.Spec, records: Sequence[Record]) -> None:
    figure = _figure(spec, records)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    png = buffer.getvalue()
    if path.endswith(".png"):
        with open(path, "wb") as handle:
            handle.write(png)
        return
    from rmvdsl.replay import text_line

    rows = "\n".join(
        f"<tr><td>{html.escape(line)}</td></tr>"
        for line in (text_line(r) for r in records if r["kind"] != "variable")
        if line is not None
    )
    page = (
        "<!doctype html><meta charset='utf-8'>"
        f"<title>{html.escape(spec.system.name)}: replay</title>"
        "<style>body{font-family:sans-serif}td{font-family:monospace;font-size:12px}</style>"
        f"<h1>{html.escape(spec.system.name)}</h1>"
        f"<img alt='timeline' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
        f"<table>{rows}</table>"
    )
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(page)
