"""`rmv replay --report FILE`: one picture of a replay on a shared time axis.

The layout (rmvdsl.tools.report.layout) is computed once; `.svg` and `.html` are painted
with the standard library (the HTML page inlines the SVG and lists the records,
and opens with no network), `.png` by matplotlib, the `report` extra.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.engine import Record
from rmvdsl.tools.report import layout, svg
from rmvdsl.tools.report.text import text_line

FORMATS = (".png", ".svg", ".html")
# The package a format needs beyond rmvdsl's own dependencies, and the extra that brings it.
NEEDS = {".png": ("matplotlib", "report")}


def unavailable(path: str) -> str | None:
    """Why `path` cannot be written here (its format or a missing package), or None."""
    suffix = next((s for s in FORMATS if path.endswith(s)), None)
    if suffix is None:
        return f"--report {path}: the file must end in {', '.join(FORMATS[:-1])} or {FORMATS[-1]}"
    if suffix in NEEDS:
        package, extra = NEEDS[suffix]
        if importlib.util.find_spec(package) is None:
            return f"--report {path} needs {package}: pip install 'rmvdsl[{extra}]'"
    return None


def write(path: str, spec: ir.Spec, records: Sequence[Record]) -> None:
    timeline = layout.layout(spec, records)
    if path.endswith(".png"):
        from rmvdsl.tools.report import png

        with open(path, "wb") as handle:
            handle.write(png.render(timeline))
        return
    drawing = svg.render(timeline)
    if path.endswith(".html"):
        drawing = page(spec, drawing, records)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(drawing)


def page(spec: ir.Spec, drawing: str, records: Sequence[Record]) -> str:
    """A self-contained HTML page: the drawing, then every record as text."""
    rows = "\n".join(
        f"<tr><td>{svg.text(line)}</td></tr>"
        for line in (text_line(r) for r in records if r["kind"] != "variable")
        if line is not None
    )
    name = svg.text(spec.system.name)
    return (
        "<!doctype html>\n<html lang='en'><meta charset='utf-8'>\n"
        f"<title>{name}: replay</title>\n"
        "<style>body{font-family:sans-serif}td{font-family:monospace;font-size:12px}</style>\n"
        f"<h1>{name}</h1>\n{drawing}<table>\n{rows}\n</table>\n</html>\n"
    )
