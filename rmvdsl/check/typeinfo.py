"""What the type stage found (stage 3): each topic's message definition, each
variable's, event's and expression's type, each property's horizons and compiled
formula. Read by the later stages, the lowering and the editor."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from rmvdsl.check.msgdefs import FieldType, MessageDef
from rmvdsl.check.msgtypes import TypeRegistry
from rmvdsl.check.vtypes import UNKNOWN, VType
from rmvdsl.grammar import ast


@dataclass
class Horizon:
    """How far a property looks into the future and the past, in seconds."""

    future: Fraction
    past: Fraction | None  # None: back to the trace's start (a past operator with no bound)
    kept: Fraction  # the history a monitor keeps for it: finite even when past is None

    @property
    def total(self) -> Fraction:
        return self.kept


@dataclass
class TypeInfo:
    registry: TypeRegistry
    topics: dict[str, MessageDef | None] = field(default_factory=dict)
    variables: dict[str, VType] = field(default_factory=dict)
    events: dict[str, VType] = field(default_factory=dict)
    horizons: dict[str, Horizon] = field(default_factory=dict)
    # Each variable's field types, one per segment of its path.
    paths: dict[str, tuple[FieldType, ...]] = field(default_factory=dict)
    # Each property's compiled formula (times in seconds), when it compiles: the one
    # compilation the analyses and the lowering read.
    formulas: dict[str, Any] = field(default_factory=dict)
    # The type of every expression node of events and alerts, by id of the node.
    expressions: dict[int, VType] = field(default_factory=dict)
    # Declarations whose types an incremental check reused: their nodes' types in
    # the order of ast.walk, given ids when first asked for (an editor never asks).
    unplaced: list[tuple[ast.Node, tuple[VType | None, ...]]] = field(default_factory=list)

    def type_of(self, node: ast.Node) -> VType:
        if self.unplaced:
            self._place()
        return self.expressions.get(id(node), UNKNOWN)

    def _place(self) -> None:
        for decl, types in self.unplaced:
            for node, value in zip(ast.walk(decl), types, strict=True):
                if value is not None:
                    self.expressions[id(node)] = value
        self.unplaced.clear()
