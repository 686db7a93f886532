"""The resolved model of a spec: what every check and every target reads.

It gathers the declarations of the root file and of everything it imports into one
namespace, with each name's declaration and each use of a name (the editor's
go-to-definition and rename will read `references`).
"""

from __future__ import annotations

import bisect
import enum
from dataclasses import dataclass, field
from typing import cast

from rmvdsl.grammar import ast
from rmvdsl.lang.source import SourceMap, Span


class Kind(enum.Enum):
    TOPIC = "topic"
    VARIABLE = "variable"
    VALUE_EVENT = "event"
    BOOL_EVENT = "boolean event"
    EMITTED_EVENT = "emitted event"
    ALERT = "alert"
    TRANSDUCER = "transducer"
    STATE = "state"
    PROPERTY = "property"

    # Members are singletons, equal only to themselves: the identity's hash (in C)
    # serves as well as Enum's (a Python call), at thousands of lookups a keystroke.
    __hash__ = object.__hash__

    @property
    def article(self) -> str:
        return "an" if self.value[0] in "aeiou" else "a"

    def described(self) -> str:
        return f"{self.article} {self.value}"


EVENT_KINDS = frozenset({Kind.VALUE_EVENT, Kind.BOOL_EVENT, Kind.EMITTED_EVENT})
BOOLEAN_KINDS = frozenset({Kind.BOOL_EVENT, Kind.EMITTED_EVENT})
PROPOSITION_KINDS = frozenset({Kind.STATE, Kind.BOOL_EVENT, Kind.EMITTED_EVENT})
MEASUREMENT_KINDS = frozenset({Kind.VARIABLE, Kind.VALUE_EVENT, Kind.BOOL_EVENT})


@dataclass
class Symbol:
    name: str
    kind: Kind
    span: Span  # the name where it is declared
    decl: ast.Node
    owner: str | None = None  # the transducer of a state, or of an emitted event

    def __hash__(self) -> int:
        return id(self)


@dataclass(frozen=True)
class Reference:
    name: str
    span: Span
    symbol: Symbol


@dataclass(frozen=True)
class ReusedReferences:
    """The references of a declaration an incremental check reused (rmvdsl.check.memo),
    made into `Reference`s when first read: an editor's keystroke never reads them."""

    found: tuple[tuple[str, Span], ...]  # each name and its span where it stood then
    delta: int  # how far the declaration moved since
    symbols: dict[str, Symbol]  # the check's symbols

    def made(self) -> list[Reference]:
        symbols, delta = self.symbols, self.delta
        return [
            Reference(name, span.shifted(delta) if delta else span, symbols[name])
            for name, span in self.found
        ]


@dataclass
class Model:
    sources: SourceMap
    specs: list[ast.Spec] = field(default_factory=list)  # root first
    system: ast.SystemDecl | None = None
    time_unit: str | None = None
    database: ast.DatabaseDecl | None = None
    topics: dict[str, ast.TopicDecl] = field(default_factory=dict)
    variables: dict[str, ast.VarDecl] = field(default_factory=dict)
    events: dict[str, ast.EventDecl] = field(default_factory=dict)
    # Events produced by transducers (`emit X`): name -> the transitions emitting it.
    emitted: dict[str, list[ast.Transition]] = field(default_factory=dict)
    alerts: dict[str, ast.AlertDecl] = field(default_factory=dict)
    transducers: dict[str, ast.TransducerDecl] = field(default_factory=dict)
    properties: dict[str, ast.PropertyDecl] = field(default_factory=dict)
    whitelists: list[ast.WhitelistDecl] = field(default_factory=list)
    nodes: list[ast.NodeDecl] = field(default_factory=list)
    intrusion: ast.IntrusionDecl | None = None
    ros: ast.RosDecl | None = None
    # Offsets of declarations with syntax errors, by file: later stages say
    # nothing about them (their trees may be partial).
    damaged_ranges: dict[str, list[tuple[int, int]]] = field(default_factory=dict)
    messages: list[ast.MessagesDecl] = field(default_factory=list)
    symbols: dict[str, Symbol] = field(default_factory=dict)
    # Names looked up and not declared (reported or not: a name in a declaration
    # with a syntax error is not): an edit that quiets or unquiets "undefined name"
    # reads them (rmvdsl.check.edit).
    unresolved: set[str] = field(default_factory=set, repr=False)
    # Each use of a name, in the order of the declarations (read `references`).
    uses: list[Reference | ReusedReferences] = field(default_factory=list, repr=False)
    _reads: dict[str, set[str]] | None = field(default=None, repr=False, compare=False)

    @property
    def references(self) -> list[Reference]:
        """Each use of a name, in the order of the declarations."""
        uses = self.uses
        if any(type(use) is ReusedReferences for use in uses):
            made: list[Reference] = []
            for use in uses:
                if isinstance(use, ReusedReferences):
                    made.extend(use.made())
                else:
                    made.append(use)
            uses[:] = made
        return cast("list[Reference]", uses)

    @property
    def root(self) -> ast.Spec | None:
        return self.specs[0] if self.specs else None

    def declarations(self) -> list[ast.Decl]:
        return [item for spec in self.specs for item in spec.items]

    def in_damaged(self, span: Span) -> bool:
        ranges = self.damaged_ranges.get(span.path, ())
        return any(start <= span.start < end for start, end in ranges)

    def uses_of(self, symbol: Symbol) -> list[Reference]:
        return [r for r in self.references if r.symbol is symbol]

    def declaration_spans(self) -> dict[str, Span]:
        """Where each named declaration a name can read stands (variables, events,
        transducers, properties, alerts)."""
        groups = (self.variables, self.events, self.transducers, self.properties, self.alerts)
        return {name: decl.span for group in groups for name, decl in group.items()}

    def reads(self) -> dict[str, set[str]]:
        """The declarations each declaration reads, from the references inside it (a
        state or an emitted event stands for its transducer). Found once a check:
        three stages ask (the transducer and property analyses, RMV224)."""
        if self._reads is None:
            self._reads = self._find_reads()
        return self._reads

    def _find_reads(self) -> dict[str, set[str]]:
        starts: dict[str, list[tuple[int, int, str]]] = {}
        for name, span in self.declaration_spans().items():
            starts.setdefault(span.path, []).append((span.start, span.end, name))
        for spans in starts.values():
            spans.sort()
        reads: dict[str, set[str]] = {}
        for reference in self.references:
            spans = starts.get(reference.span.path, [])
            index = bisect.bisect_right(spans, (reference.span.start, _END, "")) - 1
            if index < 0 or reference.span.start >= spans[index][1]:
                continue
            symbol = reference.symbol
            owned = symbol.kind in (Kind.STATE, Kind.EMITTED_EVENT)
            target = symbol.owner if owned else symbol.name
            if target is not None and target != spans[index][2]:
                reads.setdefault(spans[index][2], set()).add(target)
        return reads

    def state_owner(self, name: str) -> str | None:
        symbol = self.symbols.get(name)
        return symbol.owner if symbol is not None and symbol.kind is Kind.STATE else None


_END = 1 << 62  # past any offset
