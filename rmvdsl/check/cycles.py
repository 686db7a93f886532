"""Events and transducers that read each other in a cycle (RMV220; names stage).

An event reading what a transducer emits depends on the transducer, and a
transducer on the events of its transitions: the runtime computes each once per
instant, after what it reads, so a cycle has no order to compute it in.
"""

from __future__ import annotations

from collections.abc import Sequence

from rmvdsl.check.model import Model
from rmvdsl.grammar import ast
from rmvdsl.lang.diagnostics import Diagnostic, error


def event_cycles(
    model: Model, reads: dict[int, Sequence[ast.Ident]], moved: dict[int, int]
) -> list[Diagnostic]:
    """Each cycle through the events and transducers of `model`, reported where
    it closes. `reads`: the names each event reads, by id() of its declaration;
    `moved`: how far the reads of a reused declaration moved since they were found
    (an incremental check's: only a reported cycle's span is moved)."""
    emitter = {
        transition.output.name: owner
        for owner, decl in model.transducers.items()
        for transition in decl.transitions
        if transition.output is not None
    }

    events = model.events

    def nodes_of(idents: Sequence[ast.Ident]) -> list[ast.Ident]:
        """The events and transducers that names read stand for (an emitted
        event for its transducer)."""
        nodes = []
        for ident in idents:
            if ident.name in events:
                nodes.append(ident)
            else:
                owner = emitter.get(ident.name)
                if owner is not None:
                    nodes.append(ast.Ident(owner, ident.span))
        return nodes

    dependencies = {name: nodes_of(reads[id(decl)]) for name, decl in events.items()}
    for name, decl in model.transducers.items():
        # What it emits itself it reads within its own steps (docs/semantics.md).
        found = nodes_of([t.input for t in decl.transitions])
        dependencies[name] = [n for n in found if n.name != name]
    distances = {name: moved[id(decl)] for name, decl in model.events.items() if id(decl) in moved}
    search = _Search(dependencies, distances)
    for name in dependencies:
        search.visit(name, [name])
    return search.found


class _Search:
    """A depth-first walk of the dependencies, reporting each edge that closes a
    cycle (each name walked once: a chain of 10,000 events is one walk)."""

    def __init__(self, dependencies: dict[str, list[ast.Ident]], moved: dict[str, int]) -> None:
        self.dependencies = dependencies
        self.moved = moved
        self.state: dict[str, int] = {}  # 1: on the current path, 2: done
        self.found: list[Diagnostic] = []

    def visit(self, name: str, path: list[str]) -> None:
        """`path`: the names from the first visited to `name`."""
        state = self.state
        if state.get(name) == 2:
            return
        state[name] = 1
        for ident in self.dependencies[name]:
            if state.get(ident.name) == 1:
                cycle = [*path[path.index(ident.name) :], ident.name]
                self.found.append(
                    error(
                        "RMV220",
                        "events defined in a cycle: " + " -> ".join(cycle),
                        ident.span.shifted(self.moved.get(name, 0)),
                        label=f"`{name}` uses `{ident.name}`, which depends on `{name}`",
                        help="an event or transducer can only use what is defined without it",
                    )
                )
            elif state.get(ident.name) is None:
                self.visit(ident.name, [*path, ident.name])
        state[name] = 2
