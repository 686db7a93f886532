"""`rmv build --target c`: the spec's properties as C99 monitors, static memory
sized from the spec, with a replay driver (docs/c.md). The generator is
`generate`, imported when first used."""

from __future__ import annotations

import importlib
import re
from collections.abc import Mapping
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING

from rmvdsl.runtime.wording import counted
from rmvdsl.targets import Built, Finding, Option, Target, TargetError, folder_output

if TYPE_CHECKING:
    from rmvdsl.runtime import spec as ir

_HELP = "docs/c.md lists what the C target compiles"


def _rate(text: str | None) -> Fraction | None:
    """`--max-rate 100Hz` (or `100`, `2.5kHz`) in Hz."""
    if text is None:
        return None
    found = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*(Hz|kHz)?\s*", text)
    rate = Fraction(found[1]) * (1000 if found[2] == "kHz" else 1) if found else Fraction(0)
    if rate <= 0:
        raise TargetError(f"--max-rate {text}: expected a positive rate such as 100Hz")
    return rate


def _build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
    generate = importlib.import_module("rmvdsl.targets.c.generate")
    folder = folder_output("c", out)
    rate = _rate(options.get("max_rate"))
    try:
        written, system = generate.build(spec, folder, rate)
    except generate.Unsupported as exc:
        raise TargetError(f"the c target cannot build this spec:\n{exc}") from None
    summary = (
        f"wrote the c target to {folder} ({counted(len(written), 'file')}; the monitor"
        f" holds at most {counted(generate.memory_bytes(system), 'byte')};"
        f" {generate.flow_summary(system.flow)})"
    )
    return Built(tuple(written), summary)


def _findings(spec: ir.Spec) -> list[Finding]:
    generate = importlib.import_module("rmvdsl.targets.c.generate")
    errors = [
        Finding("error", origin, message, _HELP) for origin, message in generate.problems_of(spec)
    ]
    notes = [
        Finding("note", origin, what, fix or _HELP)
        for origin, what, fix in generate.left_to_host(spec)
    ]
    return [*errors, *notes]


TARGET = Target(
    name="c",
    summary="C99 monitors of the properties and the events and transducers they read: static"
    " memory, no malloc, a replay driver",
    docs="docs/c.md",
    output="folder",
    build=_build,
    options=(
        Option(
            "max_rate",
            "HZ",
            "how often the input of a property without `rate` can change (e.g. 100Hz):"
            " sizes its memory",
        ),
    ),
    findings=_findings,
)
