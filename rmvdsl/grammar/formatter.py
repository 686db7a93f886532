"""`rmv fmt`: the canonical layout of a spec, comments kept.

Each output line is anchored to the source offset of what it prints. A comment
alone on its line goes before the first output line anchored after it; a comment
at the end of a line stays at the end of the output line printing that code.
Formatting is idempotent and never changes the tree (the tests check both).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass, field

from rmvdsl.grammar import ast
from rmvdsl.grammar import printer as p
from rmvdsl.lang.diagnostics import Diagnostic
from rmvdsl.lang.source import SourceFile

INDENT = "    "


@dataclass
class _Line:
    text: str
    depth: int
    anchor: int  # source offset of what this line prints
    closing: bool = False
    trailing: list[str] = field(default_factory=list)
    # Comments alone on their lines before this one, each with "a blank line
    # stood above it in the source".
    leading: list[tuple[str, bool]] = field(default_factory=list)


# A member of a block: one line, or (a list with a comment inside it) one line per
# item, the items after the first indented once more.
Member = tuple[str, int] | list[tuple[str, int]]


class _Printer:
    def __init__(self, comments: tuple[ast.Comment, ...] = ()) -> None:
        self.lines: list[_Line] = []
        self.comment_starts = sorted(c.span.start for c in comments)

    def emit(self, text: str, depth: int, anchor: int) -> None:
        self.lines.append(_Line(text, depth, anchor))

    def block(self, head: str, anchor: int, end: int, members: Sequence[Member]) -> None:
        if not members:
            self.emit(head + " {}", 0, anchor)
            return
        self.emit(head + " {", 0, anchor)
        for member in members:
            pieces = member if isinstance(member, list) else [member]
            for index, (text, member_anchor) in enumerate(pieces):
                self.emit(text, 1 if index == 0 else 2, member_anchor)
        self.close(0, end)

    def commented(self, start: int, end: int) -> bool:
        """A comment stands between these offsets (inside a list being printed)."""
        index = bisect.bisect_left(self.comment_starts, start)
        return index < len(self.comment_starts) and self.comment_starts[index] < end

    def listed(self, head: str, items: list[tuple[str, int]], tail: str = "") -> Member:
        """`head item, item, ...tail` on one line; one item per line when a comment
        stands between the items, so that each comment stays after its item."""
        if len(items) > 1 and self.commented(items[0][1], items[-1][1]):
            pieces = [(text + ",", anchor) for text, anchor in items]
            pieces[0] = (head + pieces[0][0], pieces[0][1])
            pieces[-1] = (items[-1][0] + tail, items[-1][1])
            return pieces
        return (head + ", ".join(text for text, _ in items) + tail, items[0][1] if items else -1)

    def close(self, depth: int, end: int) -> None:
        self.lines.append(_Line("}", depth, max(0, end - 1), closing=True))


def format_spec(spec: ast.Spec, source: SourceFile) -> str:
    printer = _Printer(spec.comments)
    for decl in spec.items:
        _print_decl(decl, printer)
    return _render(printer.lines, spec.comments, source)


def _blank_line_before(source: SourceFile, offset: int) -> bool:
    """Whether the source line above the one holding `offset` is blank."""
    line = source.position(offset).line
    return line > 1 and not source.line_text(line - 1).strip()


def _print_decl(decl: ast.Decl, out: _Printer) -> None:
    start, end = decl.span.start, decl.span.end
    match decl:
        case ast.SystemDecl():
            title = f" {p.quote(decl.title.value)}" if decl.title else ""
            out.emit(f"system {decl.name.name}{title}", 0, start)
        case ast.ImportDecl():
            out.emit(f"import {p.quote(decl.path.value)}", 0, start)
        case ast.TimeUnitDecl():
            out.emit(f"time unit {decl.unit.name}", 0, start)
        case ast.RosDecl():
            out.emit(f"ros {decl.distro.name}", 0, start)
        case ast.MessagesDecl():
            out.emit(f"messages {p.quote(decl.path.value)}", 0, start)
        case ast.DatabaseDecl():
            _print_database(decl, out)
        case ast.TopicDecl():
            head = f"topic {decl.name.name}: {decl.msg_type.text} = {p.quote(decl.path.value)}"
            if decl.qos:
                out.block(head + " qos", start, end, _settings(decl.qos))
            else:
                out.emit(head, 0, start)
        case ast.VarDecl():
            source = (
                f"{decl.source.topic.name}.{decl.source.text}"
                if decl.source.segments
                else decl.source.topic.name
            )
            if decl.aggregate is not None:
                source = f"{decl.aggregate.name}({source})"
            out.emit(f"var {decl.name.name} = {source}", 0, start)
        case ast.EventDecl():
            _print_event(decl, out)
        case ast.AlertDecl():
            _print_alert(decl, out)
        case ast.TransducerDecl():
            _print_transducer(decl, out)
        case ast.PropertyDecl():
            _print_property(decl, out)
        case ast.WhitelistDecl():
            target = (
                decl.target.name
                if isinstance(decl.target, ast.Ident)
                else p.quote(decl.target.value)
            )
            members = _pattern_members(
                out, ("publishers", decl.publishers), ("subscribers", decl.subscribers)
            )
            out.block(f"whitelist {target}", start, end, members + _actions(decl.actions, out))
        case ast.NodeDecl():
            members = _pattern_members(
                out, ("publishes", decl.publishes), ("subscribes", decl.subscribes)
            )
            out.block(
                f"node {p.quote(decl.name.value)}",
                start,
                end,
                members + _actions(decl.actions, out),
            )
        case ast.IntrusionDecl():
            members = [*_settings(decl.settings), *_actions(decl.actions, out)]
            out.block("intrusion", start, end, members)


def _settings(settings: tuple[ast.Setting, ...]) -> list[tuple[str, int]]:
    return [(p.setting(s), s.span.start) for s in settings]


def _actions(actions: tuple[ast.Action, ...], out: _Printer) -> list[Member]:
    members: list[Member] = []
    for action in actions:
        if not action.args:
            members.append((p.action(action), action.span.start))
            continue
        args = [(p.argument(arg), arg.span.start) for arg in action.args]
        head = f"action {action.kind.name}("
        members.append(out.listed(head, args, ")"))
        if isinstance(members[-1], tuple):
            members[-1] = (members[-1][0], action.span.start)
    return members


def _pattern_members(
    out: _Printer, *lists: tuple[str, tuple[ast.StringLit, ...] | None]
) -> list[Member]:
    members: list[Member] = []
    for keyword, patterns in lists:
        if patterns is None:
            continue
        if not patterns:
            members.append((f"{keyword}: none", -1))
            continue
        items = [(p.quote(s.value), s.span.start) for s in patterns]
        members.append(out.listed(f"{keyword}: ", items))
    return members


def _print_database(decl: ast.DatabaseDecl, out: _Printer) -> None:
    name = f" {decl.name.name}" if decl.name else ""
    out.emit(f"database{name} {{", 0, decl.span.start)
    for text, anchor in _settings(decl.settings):
        out.emit(text, 1, anchor)
    for kind, blocks in (("retention", decl.retentions), ("downsample", decl.downsamples)):
        for block in blocks:
            out.emit(f"{kind} {block.name.name} {{", 1, block.span.start)
            for text, anchor in _settings(block.settings):
                out.emit(text, 2, anchor)
            out.close(1, block.span.end)
    out.close(0, decl.span.end)


def _print_event(decl: ast.EventDecl, out: _Printer) -> None:
    keyword = "when" if decl.boolean else "="
    out.emit(f"event {decl.name.name} {keyword} {p.expression(decl.expr)}", 0, decl.span.start)
    for clause in decl.clauses:
        out.emit(_clause(clause), 1, clause.span.start)


def _clause(clause: ast.Clause) -> str:
    value = clause.value
    match clause.kind:
        case "where":
            return f"where {p.expression(value)}"
        case "group":
            assert isinstance(value, ast.GroupBy)
            items = []
            if value.interval is not None:
                offset = f", {value.offset.time.text}" if value.offset else ""
                items.append(f"time({value.interval.time.text}{offset})")
            items += [t.name if isinstance(t, ast.Ident) else p.quote(t.value) for t in value.tags]
            return "group by " + ", ".join(items)
        case "resample":
            assert isinstance(value, ast.Resample)
            parts = []
            if value.every is not None:
                parts.append(f"every {value.every.time.text}")
            if value.for_ is not None:
                parts.append(f"for {value.for_.time.text}")
            return "resample " + " ".join(parts)
    return f"{clause.kind} {p.value(value)}"


def _print_alert(decl: ast.AlertDecl, out: _Printer) -> None:
    members: list[Member] = []
    for level in decl.levels:
        text = f"{level.severity.name} when {p.expression(level.condition)}"
        if level.reset is not None:
            text += f" reset when {p.expression(level.reset)}"
        members.append((text, level.span.start))
    if decl.message is not None:
        members.append((f"message {p.quote(decl.message.value)}", decl.message.span.start))
    members += [*_settings(decl.settings), *_actions(decl.actions, out)]
    out.block(f"alert {decl.name.name}", decl.span.start, decl.span.end, members)


def _print_transducer(decl: ast.TransducerDecl, out: _Printer) -> None:
    members: list[Member] = []
    if decl.states:
        members.append(out.listed("states ", [(s.name, s.span.start) for s in decl.states]))
    if decl.initial is not None:
        members.append((f"initial {decl.initial.name}", decl.initial.span.start))
    if decl.finals:
        members.append(out.listed("final ", [(s.name, s.span.start) for s in decl.finals]))
    if decl.complete:
        members.append(("complete", -1))
    for transition in decl.transitions:
        text = f"{transition.source.name} -> {transition.dest.name} on {transition.input.name}"
        if transition.output is not None:
            text += f" emit {transition.output.name}"
        members.append((text, transition.span.start))
    out.block(f"transducer {decl.name.name}", decl.span.start, decl.span.end, members)


def _print_property(decl: ast.PropertyDecl, out: _Printer) -> None:
    if isinstance(decl.body, ast.LatexFormula):
        body = f"latex {p.quote(decl.body.source.value)}"
    else:
        body = p.formula(decl.body.formula)
    head = f"property {decl.name.name}: {body}"
    members = [*_settings(decl.settings), *_actions(decl.actions, out)]
    if members:
        out.block(head, decl.span.start, decl.span.end, members)
    else:
        out.emit(head, 0, decl.span.start)


def _render(lines: list[_Line], comments: tuple[ast.Comment, ...], source: SourceFile) -> str:
    # Lines anchored at -1 (printed without a source position) take their
    # predecessor's anchor, so that anchors never decrease.
    anchors: list[int] = []
    blank_before: list[bool] = []
    for line in lines:
        printed_from_source = line.anchor >= 0 and not line.closing
        if line.anchor < 0 or (anchors and line.anchor < anchors[-1]):
            line.anchor = anchors[-1] if anchors else 0
        anchors.append(line.anchor)
        blank_before.append(printed_from_source and _blank_line_before(source, line.anchor))
    tail: list[tuple[str, bool]] = []
    for comment in comments:
        text = comment.text.rstrip()
        position = bisect.bisect_right(anchors, comment.span.start)
        own_line = not source.text[
            source.line_start(source.position(comment.span.start).line) : comment.span.start
        ].strip()
        if not own_line and position > 0:
            lines[position - 1].trailing.append(text)
        elif position < len(lines):
            lines[position].leading.append((text, _blank_line_before(source, comment.span.start)))
        else:
            tail.append((text, _blank_line_before(source, comment.span.start)))
    out: list[str] = []
    for line, blank in zip(lines, blank_before, strict=True):
        indent = INDENT * line.depth
        comment_indent = INDENT * (line.depth + 1) if line.closing else indent
        for text, blank_above in line.leading:
            _blank(out, blank_above)
            out.append(comment_indent + text)
        _blank(out, blank)
        trailing = "  " + "  ".join(line.trailing) if line.trailing else ""
        out.append(indent + line.text + trailing)
    for text, blank_above in tail:
        _blank(out, blank_above)
        out.append(text)
    return "\n".join(out) + "\n"


def _blank(out: list[str], wanted: bool) -> None:
    """One blank line, never at the start, after a `{` or twice in a row."""
    if wanted and out and out[-1] and not out[-1].endswith("{"):
        out.append("")


def format_source(source: SourceFile) -> tuple[str | None, list[Diagnostic]]:
    """`rmv fmt` of a file: its formatted text, or None and the syntax errors that
    keep it from being formatted (`rmv fmt` and the editor both call this)."""
    from rmvdsl.grammar.parser import parse_source

    parsed = parse_source(source)
    errors = [d for d in parsed.diagnostics if d.is_error]
    return (None, errors) if errors else (format_spec(parsed.spec, source), [])
