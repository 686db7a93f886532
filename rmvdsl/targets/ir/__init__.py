"""`rmv build --target ir`: the resolved spec as versioned JSON (docs/ir.md), the
input of every other tool."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from rmvdsl.runtime.wording import os_words
from rmvdsl.targets import Built, Target, TargetError

if TYPE_CHECKING:
    from rmvdsl.runtime import spec as ir


def _build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
    from rmvdsl.runtime.spec import dump

    text = dump(spec) + "\n"
    if out is None:
        return Built((), "", text=text)
    try:
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise TargetError(f"{out}: cannot write: {os_words(exc)}") from None
    return Built((out,), "")  # quiet, as a compiler writing one file is


TARGET = Target(
    name="ir",
    summary="the resolved spec as versioned JSON",
    docs="docs/ir.md",
    output="file",
    build=_build,
)
