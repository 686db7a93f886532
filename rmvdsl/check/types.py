"""Types (stage 3): every variable against real ROS message definitions, then
events, alerts and properties, with time units and property horizons.

Value types are in vtypes.py, the resolution of field paths in fieldpaths.py.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar, cast

from rmvdsl.check.memo import Entry
from rmvdsl.check.model import EVENT_KINDS, Kind, Model
from rmvdsl.check.msgdefs import FieldType, environment_folders
from rmvdsl.check.msgtypes import DEFAULT_DISTRO, DISTROS, TypeRegistry
from rmvdsl.check.proptypes import PropertyTypes
from rmvdsl.check.typeinfo import Horizon, TypeInfo
from rmvdsl.check.vtypes import (
    BOOL,
    DURATION,
    FLOAT,
    INT,
    NUMERIC,
    STRING,
    UNKNOWN,
    VType,
    from_ros,
)
from rmvdsl.grammar import ast
from rmvdsl.grammar.shift import findings
from rmvdsl.lang.diagnostics import Diagnostic, did_you_mean, error
from rmvdsl.lang.source import Span

# A declaration typed under rmvdsl.check.memo (a variable, an event, an alert, a property).
_Typeable = TypeVar("_Typeable", bound=ast.Node)

__all__ = [
    "BOOL", "DURATION", "FLOAT", "INT", "NUMERIC", "STRING", "UNKNOWN",
    "Horizon", "TypeChecker", "TypeConfig", "TypeInfo", "VType", "check_types", "from_ros",
]  # fmt: skip


@dataclass(frozen=True)
class Typed:
    """What typing one declaration found when it found nothing wrong: what it
    looked up then (the type of each name it read; a variable's topic definition,
    message definitions and ROS distribution), its nodes' types (ast.walk's order),
    its result."""

    lookups: tuple[tuple[str, str, Any], ...]  # what was looked up (TypeChecker.noted)
    types: tuple[VType | None, ...]
    result: Any


@dataclass
class TypeConfig:
    """Where the ROS distribution and message folders come from (the command line
    wins over the spec, the spec over rmv.toml)."""

    ros: str | None = None
    messages: tuple[str, ...] = ()
    use_environment: bool = True


class TypeChecker(PropertyTypes):
    def __init__(
        self,
        model: Model,
        config: TypeConfig,
        spec_folder: str,
        incremental: bool = False,
        info: TypeInfo | None = None,
    ) -> None:
        """`info`: what an earlier check of the model found, to type one more
        declaration in (rmvdsl.check.edit); else a new one, with the spec's ROS."""
        self.model = model
        self.config = config
        self.spec_folder = spec_folder
        self.incremental = incremental
        self.diagnostics: list[Diagnostic] = []
        self.info = info or TypeInfo(TypeRegistry(self._distro()))
        self._event_stack: set[str] = set()
        # What each declaration being typed looked up (innermost last), remembered.
        self._reads: list[list[tuple[str, str, Any]]] = []
        self._entry: Entry = ("types", model.time_unit)  # of this check's findings

    # ---- configuration ----

    def _distro(self) -> str:
        if self.config.ros:
            return self.config.ros
        ros = self.model.ros
        if ros is not None:
            name = ros.distro.name
            if name in DISTROS:
                return name
            self.report(
                error(
                    "RMV305",
                    f"unknown ROS distribution `{name}`",
                    ros.distro.span,
                    label="not a distribution rmvdsl has message definitions for",
                    help=did_you_mean(name, DISTROS) or "known: " + ", ".join(DISTROS),
                )
            )
        return DEFAULT_DISTRO

    def load_messages(self) -> None:
        registry = self.info.registry
        for folder in self.config.messages:
            registry.add_folder(folder, None)
            if not os.path.isdir(folder):
                self.report(
                    error(
                        "RMV306",
                        f"message folder `{folder}` does not exist",
                        Span("<command line>", 0, 0),
                    )
                )
        for decl in self.model.messages:
            base = os.path.dirname(decl.span.path)
            registry.add_folder(
                os.path.normpath(os.path.join(base, decl.path.value)), decl.path.span
            )
        if self.config.use_environment:
            for folder in environment_folders():
                registry.add_folder(folder)
        self.diagnostics.extend(registry.diagnostics)
        for source in registry.sources:
            self.model.sources.add(source)

    # ---- driver ----

    def run(self) -> tuple[TypeInfo, list[Diagnostic]]:
        model = self.model
        self.load_messages()
        for name, topic in model.topics.items():
            self.info.topics[name] = self.resolve_topic(topic)
        for name, variable in model.variables.items():
            self.info.variables[name] = self.typed_variable(variable)
        for name in model.events:
            self.event_type(name)
        for alert in model.alerts.values():
            self.check_alert(alert)
        for prop in model.properties.values():
            self.check_property(prop)
        return self.info, self.diagnostics

    # ---- expressions ----

    def event_type(self, name: str) -> VType:
        if name in self.info.events:
            return self.info.events[name]
        decl = self.model.events.get(name)
        if decl is None:
            return BOOL if name in self.model.emitted else UNKNOWN
        if name in self._event_stack:
            return UNKNOWN  # a cycle, reported by the names stage
        self._event_stack.add(name)
        value = self.remembered(decl, self.type_event)
        self._event_stack.discard(name)
        self.info.events[name] = value
        return value

    def typed_variable(self, variable: ast.VarDecl) -> VType:
        value, path = self.remembered(variable, self._typed_variable)
        if path is not None:
            self.info.paths[variable.name.name] = path
        return cast("VType", value)

    def _typed_variable(self, variable: ast.VarDecl) -> tuple[VType, tuple[FieldType, ...] | None]:
        self.noted("distro", "", self.info.registry.distro)
        value = self.type_variable(variable)
        return value, self.info.paths.get(variable.name.name)

    def type_event(self, decl: ast.EventDecl) -> VType:
        value = self.expression(decl.expr)
        where = decl.clause("where")
        if where is not None:
            self.condition(where.value, "a `where` clause")
        if decl.boolean:
            self.condition(decl.expr, f"the condition of `{decl.name.name}`", value)
            value = BOOL
        return value

    def remembered(self, decl: _Typeable, typed: Callable[[_Typeable], Any]) -> Any:
        """typed(decl), or what it found the last time this text was typed, when
        every lookup it made still gives the same answer (an incremental check's)."""
        kept = findings(decl) if self.incremental else None
        if kept is None:
            return typed(decl)
        entry = self._entry
        known = kept.get(entry)
        if known is not None and self.still_holds(known):
            if known.types:
                self.info.unplaced.append((decl, known.types))
            return known.result
        found = len(self.diagnostics)
        self._reads.append([])
        try:
            result = typed(decl)
        finally:
            reads = self._reads.pop()
        if len(self.diagnostics) == found:
            expressions = self.info.expressions
            types = tuple([expressions.get(id(node)) for node in ast.walk(decl)])
            nodes = types if any(t is not None for t in types) else ()
            kept[entry] = Typed(tuple(reads), nodes, result)
        return result

    def still_holds(self, known: Typed) -> bool:
        """Whether every lookup of an earlier typing gives what it gave then (the
        same type of a name; the very same definition, read once per file)."""
        registry = self.info.registry
        for what, name, value in known.lookups:
            if what == "name":
                now = self._name_type(name)
                if now is not value and now != value:  # mostly the very type kept
                    return False
            elif what == "topic":
                if self.info.topics.get(name) is not value:
                    return False
            elif what == "message":
                if registry.get(name) is not value:
                    return False
            elif registry.distro is not value:
                return False
        return True

    def noted(self, what: str, name: str, value: Any) -> None:
        """Remember a lookup of the declaration being typed (an incremental check's)."""
        if self._reads:
            self._reads[-1].append((what, name, value))

    def name_type(self, name: str) -> VType:
        value = self._name_type(name)
        self.noted("name", name, value)
        return value

    def _name_type(self, name: str) -> VType:
        symbol = self.model.symbols.get(name)
        if symbol is None:
            return UNKNOWN
        if symbol.kind is Kind.VARIABLE:
            return self.info.variables.get(name, UNKNOWN)
        if symbol.kind in EVENT_KINDS:
            return self.event_type(name)
        return UNKNOWN

    # ---- alerts ----

    # ---- properties ----


def check_types(
    model: Model,
    config: TypeConfig | None = None,
    spec_folder: str = ".",
    incremental: bool = False,
) -> tuple[TypeInfo, list[Diagnostic]]:
    """The types stage; `incremental` reuses what earlier checks found in the
    declarations whose text has not changed (an editor's, rmvdsl.check.memo)."""
    return TypeChecker(model, config or TypeConfig(), spec_folder, incremental).run()
