"""A spec's checked IR, stored between processes the way `rmv check`'s output is
(rmvdsl.commands.stored): a replay of a spec whose every input is unchanged loads
the IR it ran last time (the JSON of rmvdsl.runtime.spec, which a built node
loads too) instead of checking the spec again, and imports no checker.

Only a check with no error is stored, and only one `storable` (a missing file, or
a property the solver could not decide in time, checks again next time). The
entry is keyed as a stored check is (the versions, rmvdsl's own files, the
folder, the environment that chooses message folders) and by the options that
change the check (`--ros`, `--messages`); it answers while every file the check
read (the spec, its imports, rmv.toml, each message definition) has the bytes it
had, and every message folder its modification time.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from rmvdsl.commands import stored
from rmvdsl.runtime import spec as ir

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult


def entry(spec: str, ros: str | None, messages: Sequence[str]) -> str:
    """The key of the check `rmv replay` makes of `spec` with these options."""
    return stored.key(["checked spec", f"spec={spec!r}", f"ros={ros!r}",
                       f"messages={list(messages)!r}"])  # fmt: skip


def lookup(key: str) -> ir.Spec | None:
    """The IR stored under `key`, if every input of its check is unchanged."""
    found = stored.lookup(key)
    if found is None:
        return None
    try:
        return ir.load(found.stdout)
    except ir.FormatError:
        return None  # written by another format: checked again, and replaced


def store(key: str, path: str, result: CheckResult, spec: ir.Spec) -> None:
    """Keep `spec`, lowered from `result` (the check of the spec at `path`), for the
    next run of the same check: only a check with no error that may answer later,
    and only a spec its JSON gives back exactly."""
    from rmvdsl.check.msgfolders import folders_read

    codes = [d.code for d in result.diagnostics]
    if result.errors or not stored.storable(codes):
        return
    text = ir.dump(spec, indent=None)
    if ir.load(text) != spec:
        return  # a value its JSON does not give back: never answered from the store
    read = stored.inputs([path], result.model.sources)
    stored.store(key, stored.Stored(text, "", 0), read, folders_read())
