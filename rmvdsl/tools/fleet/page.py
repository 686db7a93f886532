"""`rmv replay ... --report fleet.html` over several recordings: one self-contained
page (no network): the totals, per property the recordings it failed in and the
time it was false, a table of every recording sortable by any column, and the
timelines of the worst runs, drawn as `--report` draws one recording."""

from __future__ import annotations

from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted
from rmvdsl.tools.fleet.summary import FleetSummary, false_time, records, worst
from rmvdsl.tools.report import layout, svg

WORST = 5  # timelines drawn

_STYLE = """body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}
td,th{padding:2px 8px;border-bottom:1px solid #ddd;font-size:13px;text-align:left}
th{cursor:pointer;background:#f3f3f3}td.n{text-align:right;font-family:monospace}
.pass{color:#1a7f37}.violations,.failed,.unreadable{color:#cf222e}.intrusions{color:#9a6700}
.incomplete{color:#6e7781}"""

# Sorts the table by the clicked column, numbers as numbers; again: the other way.
_SCRIPT = """document.querySelectorAll('th').forEach((th, col) => th.onclick = () => {
  const body = th.closest('table').tBodies[0], rows = [...body.rows];
  const up = th.dataset.up !== '1'; th.dataset.up = up ? '1' : '0';
  const key = r => { const t = r.cells[col].dataset.v ?? r.cells[col].textContent;
                     const n = parseFloat(t); return isNaN(n) ? t : n; };
  rows.sort((a, b) => { const x = key(a), y = key(b);
                        return (x < y ? -1 : x > y ? 1 : 0) * (up ? 1 : -1); });
  rows.forEach(r => body.appendChild(r)); });"""


def page(spec: ir.Spec, results: list[dict[str, Any]], summary: FleetSummary) -> str:
    name = svg.text(spec.system.name)
    drawn = worst(results, WORST)
    anchors = {r["path"]: f"run-{i}" for i, r in enumerate(drawn)}
    parts = [
        "<!doctype html>\n<html lang='en'><meta charset='utf-8'>",
        f"<title>{name}: {counted(summary.done, 'recording', grouped=True)}</title>",
        f"<style>{_STYLE}</style>",
        f"<h1>{name}: fleet replay</h1>",
        *(f"<p>{svg.text(line.strip())}</p>" for line in summary.lines()[:1]),
        _properties(summary),
        "<h2>Recordings</h2>",
        _recordings(results, anchors),
    ]
    if drawn:
        parts.append("<h2>The worst runs</h2>")
        for result in drawn:
            timeline = layout.layout(spec, records(result))
            parts.append(f"<h3 id='{anchors[result['path']]}'>{svg.text(result['path'])}</h3>")
            parts.append(svg.render(timeline))
    parts.append(f"<script>{_SCRIPT}</script>\n</html>\n")
    return "\n".join(parts)


def _properties(summary: FleetSummary) -> str:
    if not summary.properties:
        return "<p>No property was false in any recording.</p>"
    rows = "\n".join(
        f"<tr><td>{svg.text(name)}</td><td class='n'>{total.recordings:,}</td>"
        f"<td class='n'>{total.false_seconds:g}</td></tr>"
        for name, total in sorted(summary.properties.items())
    )
    head = "<th>property</th><th>recordings false</th><th>seconds false in all</th>"
    return f"<h2>Properties</h2>\n{_table(head, rows)}"


def _recordings(results: list[dict[str, Any]], anchors: dict[str, str]) -> str:
    rows = []
    for result in results:
        path = svg.text(result["path"])
        if result["path"] in anchors:
            path = f"<a href='#{anchors[result['path']]}'>{path}</a>"
        status = result["status"]
        seconds_false = sum(false_time(result).values())
        cells = [
            f"<td>{path}</td>",
            f"<td class='{status}'>{status}</td>",
            *(f"<td class='n'>{result[k]:,}</td>" for k in ("violations", "intrusions",
                                                          "warnings", "messages")),
            f"<td class='n'>{seconds_false:g}</td>",
            f"<td class='n'>{result['seconds']:g}</td>",
            f"<td>{svg.text(result.get('error', ''))}</td>",
        ]  # fmt: skip
        rows.append("<tr>" + "".join(cells) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("recording", "status", "violations", "intrusions",
                                           "warnings", "messages", "seconds false",
                                           "replay seconds", "why"))  # fmt: skip
    return _table(head, "\n".join(rows))


def _table(head: str, rows: str) -> str:
    return f"<table><thead><tr>{head}</tr></thead><tbody>\n{rows}\n</tbody></table>"
