"""Boolean z3 terms made directly, for the encoders' hot paths.

z3's Python `And`, `Or`, `Implies` and `Solver.add` check and coerce every
argument in Python (its sort, a cast, an equality of sorts), which was most of an
encoding's time (docs/verification.md, "cost"). Where the arguments are known to be
boolean terms of one context, these make the same terms without that.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import z3

Z3_VERSION = z3.get_version_string()  # in every cache key: another z3 may answer otherwise


def conjunction(items: Sequence[Any]) -> Any:
    """`z3.And(*items)` of at least one boolean term."""
    return _made(z3.Z3_mk_and, items)


def disjunction(items: Sequence[Any]) -> Any:
    """`z3.Or(*items)` of at least one boolean term."""
    return _made(z3.Z3_mk_or, items)


def negation(item: Any) -> Any:
    context = item.ctx
    return z3.BoolRef(z3.Z3_mk_not(context.ref(), item.as_ast()), context)


def implication(antecedent: Any, consequent: Any) -> Any:
    context = antecedent.ctx
    made = z3.Z3_mk_implies(context.ref(), antecedent.as_ast(), consequent.as_ast())
    return z3.BoolRef(made, context)


def assert_all(solver: z3.Solver, terms: Iterable[Any]) -> None:
    """`solver.add(*terms)` of boolean terms of the solver's context."""
    context = solver.ctx
    for term in terms:
        z3.Z3_solver_assert(context.ref(), solver.solver, term.as_ast())


def _made(function: Any, items: Sequence[Any]) -> Any:
    context = items[0].ctx
    array = (z3.Ast * len(items))(*(item.as_ast() for item in items))
    return z3.BoolRef(function(context.ref(), len(items), array), context)
