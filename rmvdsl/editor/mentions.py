"""What a user can point at besides declared names: a field-path segment, a message
type, a retention policy, an import path. Each mention has a key shared by every
mention of the same thing, and where that thing is defined when it is in a file
(a field's line of its .msg file, the retention's name, the imported file).

The editor's go-to-definition, references, hover and semantic tokens read these
beside the model's symbols; they are found from a finished check (the type stage
knows which message each segment belongs to).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rmvdsl.check.msgdefs import MessageDef, canonical
from rmvdsl.grammar import ast
from rmvdsl.lang.source import Span

if TYPE_CHECKING:
    from rmvdsl.check import CheckResult


@dataclass(frozen=True)
class Mention:
    kind: str  # field | message | retention | import
    key: str  # `pkg/msg/Type.field`, `pkg/msg/Type`, the retention's name, the file
    span: Span  # what is pointed at
    target: Span | None  # where it is defined, when that is in a file
    declares: bool = False  # the definition itself (a retention's name)


def mentions(result: CheckResult) -> list[Mention]:
    """Every mention in the checked files, in file order."""
    found: list[Mention] = []
    for spec in result.model.specs:
        for decl in spec.items:
            found += _of_declaration(result, decl)
    return found


def mention_at(found: list[Mention], path: str, offset: int) -> Mention | None:
    for mention in found:
        span = mention.span
        if span.path == path and span.start <= offset <= span.end:
            return mention
    return None


def same(found: list[Mention], mention: Mention) -> list[Mention]:
    return [m for m in found if m.kind == mention.kind and m.key == mention.key]


def _of_declaration(result: CheckResult, decl: ast.Decl) -> list[Mention]:
    match decl:
        case ast.TopicDecl():
            return [_message(result, canonical(decl.msg_type.text), decl.msg_type.span)]
        case ast.VarDecl():
            return _segments(result, decl)
        case ast.DatabaseDecl():
            return _retentions(decl)
        case ast.ImportDecl():
            folder = os.path.dirname(decl.span.path)
            target = os.path.normpath(os.path.join(folder, decl.path.value))
            where = Span(target, 0, 0) if result.model.sources.get(target) else None
            return [Mention("import", os.path.realpath(target), decl.path.span, where)]
    return []


def _definition(result: CheckResult, name: str) -> MessageDef | None:
    types = result.types
    return None if types is None else types.registry.get(name)


def _message(result: CheckResult, name: str, span: Span) -> Mention:
    definition = _definition(result, name)
    target = None
    if definition is not None and result.model.sources.get(definition.origin):
        target = Span(definition.origin, 0, 0)
    return Mention("message", name, span, target)


def _segments(result: CheckResult, decl: ast.VarDecl) -> list[Mention]:
    """One mention per segment whose message the type stage resolved."""
    types = result.types
    topic = types.topics.get(decl.source.topic.name) if types is not None else None
    steps = types.paths.get(decl.name.name, ()) if types is not None else ()
    if topic is None:
        return []
    out, owner = [], topic.name
    for segment, step in zip(decl.source.segments, steps, strict=False):
        name = segment.field_name.name
        out.append(
            Mention("field", f"{owner}.{name}", segment.field_name.span,
                    _field_line(result, owner, name))
        )  # fmt: skip
        owner = step.base
    return out


def _field_line(result: CheckResult, message: str, name: str) -> Span | None:
    definition = _definition(result, message)
    if definition is None or name not in definition.lines:
        return None
    source = result.model.sources.get(definition.origin)
    if source is None:
        return None
    line = definition.lines[name]
    start = source.line_start(line)
    return Span(source.path, start, start + len(source.line_text(line)))


def _retentions(decl: ast.DatabaseDecl) -> list[Mention]:
    declared = {r.name.name: r.name.span for r in decl.retentions}
    out = [Mention("retention", n, s, s, declares=True) for n, s in declared.items()]
    for downsample in decl.downsamples:
        for setting in downsample.settings:
            value = setting.value
            if setting.key.name in ("from", "into") and isinstance(value, ast.NameValue):
                name = value.ident.name
                out.append(Mention("retention", name, value.ident.span, declared.get(name)))
    return out


def describe(result: CheckResult, mention: Mention) -> str:
    """A hover's Markdown: a message's definition, a field's type and line."""
    if mention.kind == "message":
        return _message_text(_definition(result, mention.key), mention.key)
    if mention.kind == "field":
        message, name = mention.key.rsplit(".", 1)
        definition = _definition(result, message)
        kind = definition.fields.get(name) if definition is not None else None
        where = f" ({definition.origin})" if definition is not None else ""
        shown = kind.text() if kind is not None else "a constant"
        return f"**field** `{name}` of `{message}`{where}: `{shown}`"
    if mention.kind == "retention":
        return f"**retention policy** `{mention.key}`"
    return f"**import** `{mention.key}`"


def _message_text(definition: MessageDef | None, name: str) -> str:
    if definition is None:
        return f"**message** `{name}` (not found)"
    fields = "\n".join(f"{kind.text()} {field}" for field, kind in definition.fields.items())
    constants = "\n".join(f"{t} {c}={value}" for c, (t, value) in definition.constants.items())
    body = "\n".join(part for part in (constants, fields) if part)
    return f"**message** `{name}` ({definition.origin})\n\n```\n{body}\n```"
