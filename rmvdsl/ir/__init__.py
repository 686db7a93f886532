"""Lowering: from a checked spec (syntax tree, symbols, types) to the resolved spec
of rmvdsl.runtime.spec, which every target, the runtime and the editor read.

Nothing here decides what a spec means beyond filling in what the checker already
established: names resolved, field paths typed, defaults (from rmvdsl.lang.builtins)
filled, times in seconds, formulas compiled, events ordered by dependency.
"""

from __future__ import annotations

from rmvdsl.check import CheckResult
from rmvdsl.ir.conversions import LowerError
from rmvdsl.ir.lowering import Lowering
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.spec import dump, load
from rmvdsl.runtime.wording import counted

__all__ = ["LowerError", "dump", "load", "lower"]


def lower(result: CheckResult) -> ir.Spec:
    if result.errors or result.types is None:
        raise LowerError(f"the spec has {counted(len(result.errors), 'error')}: fix them first")
    return Lowering(result.model, result.types).spec()
