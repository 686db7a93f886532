"""A spec's checked IR, stored between processes the way `rmv check`'s output is
(rmvdsl.commands.stored): a replay or a build of a spec whose every input is
unchanged loads the IR of its last clean check (the JSON of rmvdsl.runtime.spec,
which a built node loads too) instead of checking the spec again, and imports no
checker.

Only a check with no error is stored, only one `storable` (a missing file, or a
property the solver could not decide in time, checks again next time), and only a
spec that checks something (RMV226: a replay refuses one that does not, a build
warns of it each time). The entry is keyed as a stored check is (the versions,
rmvdsl's own files, the folder, the environment that chooses message folders) and
by the options that change the check (`--ros`, `--messages`); it answers while
every file the check read (the spec, its imports, rmv.toml, each message
definition) has the bytes it had, and every message folder its modification time.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from rmvdsl.commands import say, stored, warn_if_nothing_checked
from rmvdsl.lang.errors import EXIT_ERRORS, UsageError
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult


def checked(
    command: str, path: str, ros: str | None, messages: Sequence[str], refuse_empty: bool
) -> ir.Spec | int:
    """The spec at `path` checked and lowered, or the exit code of a check with
    errors (said on standard error: `rmv build: SPEC: 2 errors: nothing built`,
    `command` being "build" or "replay"). A spec whose every input is as it was at
    its last clean check is not checked again: its IR is loaded. A spec that checks
    nothing is said to (RMV226), and with `refuse_empty` (a replay of it would pass
    any recording) refused."""
    key = entry(path, ros, messages)
    spec = lookup(key)
    if spec is not None:
        return spec
    from rmvdsl.check import check
    from rmvdsl.ir import lower
    from rmvdsl.lang.render import render_text

    result = check(path, ros=ros, messages=tuple(messages))
    if result.errors:
        sys.stderr.write(render_text(result.errors, result.model.sources, False))
        undone = _UNDONE[command]
        say(f"rmv {command}: {path}: {counted(len(result.errors), 'error')}: {undone}")
        return EXIT_ERRORS
    empty = warn_if_nothing_checked(result)
    if empty and refuse_empty:
        raise UsageError(f"{path}: the spec checks nothing: a replay of it would pass "
                         "any recording")  # fmt: skip
    spec = lower(result)
    if not empty:
        store(key, path, result, spec)
    return spec


_UNDONE = {"build": "nothing built", "replay": "nothing replayed"}


def entry(spec: str, ros: str | None, messages: Sequence[str]) -> str:
    """The key of the check a replay or a build makes of `spec` with these options."""
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
