"""Properties that read several topics timed by their header stamps with no
`lateness` (RMV224): stamps of two publishers arrive interleaved out of order, and
a message stamped before one already read is dropped as late, so the property is
decided on less data than was sent (measured: 3 of 600 messages at 10x playback).
"""

from __future__ import annotations

from rmvdsl.check.model import Model
from rmvdsl.lang.diagnostics import Diagnostic, warning
from rmvdsl.runtime.wording import counted


def lateness_warnings(model: Model) -> list[Diagnostic]:
    stamped = {
        name
        for name, decl in model.topics.items()
        if decl.time_setting is not None and decl.time_setting.ident.name == "header"
    }
    if len(stamped) < 2:
        return []
    reads = model.reads()
    found = []
    for name, decl in model.properties.items():
        if any(s.key.name == "lateness" for s in decl.settings):
            continue
        topics = sorted(_topics_read(model, reads, name) & stamped)
        if len(topics) < 2:
            continue
        listed = ", ".join(f"`{t}`" for t in topics)
        found.append(
            warning(
                "RMV224",
                f"property `{name}` reads {counted(len(topics), 'topic')} timed by their "
                f"header stamps ({listed}) and has no `lateness`",
                decl.name.span,
                label="a message stamped before one already read is dropped: unknown there",
                help="give it the most the stamps of two topics can disagree, e.g. "
                "`lateness = 100ms` in its settings (docs/runtime.md)",
            )
        )
    return found


def _topics_read(model: Model, reads: dict[str, set[str]], root: str) -> set[str]:
    """The topics a declaration reads, through events, transducers and variables."""
    topics: set[str] = set()
    seen = {root}
    stack = [root]
    while stack:
        name = stack.pop()
        variable = model.variables.get(name)
        if variable is not None:
            topics.add(variable.source.topic.name)
        for read in reads.get(name, ()):
            if read not in seen:
                seen.add(read)
                stack.append(read)
    return topics
