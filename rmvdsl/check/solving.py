"""Asking z3: `solve` answers a question about conditions (each answer cached by
its question, in a context of its own when only the verdict is wanted), and
`witness` writes the values of a model as the runtime would print them, round
where that serves.
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Iterable
from fractions import Fraction
from typing import Any

import z3
from z3 import z3core

from rmvdsl.check.operators import number
from rmvdsl.logic.terms import Z3_VERSION
from rmvdsl.util.cache import default_cache, digest
from rmvdsl.util.cancel import checkpoint

SOLVER_TIMEOUT_MS = 2000
PRESENT = "present "  # the prefix of a value's presence flag (rmvdsl.check.conditions)


def value_text(value: Any) -> str:
    """A model's value as the runtime would print it."""
    if z3.is_bv_value(value):
        return str(value.as_signed_long())
    if z3.is_fp_value(value):
        number = as_python_float(value)
        return "NaN" if number != number else repr(number)
    if z3.is_rational_value(value):
        from rmvdsl.lang.numbers import decimal

        return decimal(Fraction(value.numerator_as_long(), value.denominator_as_long()))
    if z3.is_string_value(value):
        return f'"{value.as_string()}"'
    return str(value)


def as_python_float(value: Any) -> float:
    """A z3 double numeral as a Python float, read from its fields. Not through
    z3's simplifier: `simplify(fpToIEEEBV(1.0))` gave the bits of 4.000000000000001
    in a context where 5.0 had been translated first (z3 4.12-5.4; the solver and
    `Model.eval` were right), so a witness could name a value it did not hold."""
    if value.isNaN():
        return float("nan")
    if value.isInf():
        return float("-inf") if value.sign() else float("inf")
    bits = (int(value.sign()) << 63) | (value.exponent_as_long(True) << 52)
    bits |= value.significand_as_long()
    return float(struct.unpack("<d", bits.to_bytes(8, "little"))[0])


def names_in(terms: list[Any]) -> set[str]:
    """The names of the free constants in z3 terms (each shared subterm once)."""
    return set(free_constants(terms))


def free_constants(terms: list[Any]) -> dict[str, int]:
    """The free constants in z3 terms, each name with its sort's kind (z3's
    Z3_*_SORT), each shared subterm visited once. Walked with z3's C API on the
    terms' pointers: the Python objects `children()` makes for every subterm cost
    6x the walk (0.87 s against 0.14 s for the conditions of 1,000 events)."""
    found: dict[str, int] = {}
    if not terms:
        return found
    context = terms[0].ctx_ref()
    seen: set[int] = set()
    stack = [term.as_ast() for term in terms]
    while stack:
        node = stack.pop()
        key = z3core.Z3_get_ast_id(context, node)
        if key in seen:
            continue
        seen.add(key)
        kind = z3core.Z3_get_ast_kind(context, node)
        if kind == z3.Z3_QUANTIFIER_AST:
            stack.append(z3core.Z3_get_quantifier_body(context, node))
        elif kind == z3.Z3_APP_AST:
            count = z3core.Z3_get_app_num_args(context, node)
            if count:
                stack.extend([z3core.Z3_get_app_arg(context, node, i) for i in range(count)])
                continue
            decl = z3core.Z3_get_app_decl(context, node)
            if z3core.Z3_get_decl_kind(context, decl) == z3.Z3_OP_UNINTERPRETED:
                name = z3core.Z3_get_symbol_string(context, z3core.Z3_get_decl_name(context, decl))
                sort = z3core.Z3_get_sort_kind(context, z3core.Z3_get_sort(context, node))
                found[name] = sort
    return found


_BIT_BLASTED = {z3.Z3_BOOL_SORT, z3.Z3_BV_SORT, z3.Z3_FLOATING_POINT_SORT}


def condition_solver(terms: list[Any], context: Any = None) -> Any:
    """The solver every question over conditions is asked with, its time limit
    set. Over booleans, integers and floats (bit-vectors and floating point), it is
    z3's tactic for that logic, `qffpbv`, which bit-blasts each question afresh.
    z3's default solver (4.12-5.4) was slow on these small questions two ways:
    asked with assumptions or after a push, it answers with its incremental core,
    which took 9.4 s to show one float event possible (0.09 s bit-blasted;
    tests/differential.py, seed 223); asked once, it picks the `qfbv` tactic,
    which took 2.8 s to find `V1 = 2147483647` for `V1 >= 2147483647 or abs(V1) >
    2147483647` (seed 241; 0.008 s). Strings take the default solver."""
    sorts = set(free_constants(terms).values())
    if sorts <= _BIT_BLASTED:
        solver = z3.Tactic("qffpbv", ctx=context).solver()
        solver.set("unsat_core", True)  # the tactic's cores are off by default
    else:
        solver = z3.Solver(ctx=context)
    solver.set("timeout", SOLVER_TIMEOUT_MS)
    return solver


def solve(
    constraints: Iterable[Any], domains: list[Any], symbols: dict[str, Any], values: bool = True
) -> tuple[str, str]:
    """("sat", the values that make the constraints hold), ("unsat", "") or
    ("unknown", ""). Cached by the constraints' text: re-checking an unchanged spec
    asks z3 nothing (not even to build a solver). Without `values` the values are
    not looked for ("" for "sat"): rounding them costs up to 8 more solver calls a
    variable."""
    constraints = list(constraints)
    declared = sorted(f"{name}: {symbol.sort()}" for name, symbol in symbols.items())
    terms = [c.sexpr() for c in [*domains, *constraints]]
    key = digest("conditions", "5", Z3_VERSION, declared, terms)
    cache = default_cache()
    cached = cache.get(key)
    if cached is not None and isinstance(cached.get("answer"), str):
        known = cached.get("values")
        if not values or cached["answer"] != "sat" or isinstance(known, str):
            return cached["answer"], str(known or "")
    if not values:
        result = verdict([*domains, *constraints])
        if result != "unknown":  # a time limit: not an answer to keep
            cache.put(key, {"answer": result, "values": None})
        return result, ""
    # In a context of its own, made for this question, which holds its terms alone.
    # z3's model still varies with what the process asked before (the same spec
    # checked after others gave `V2 has no value` for `V2 = 0.0`): round_values
    # makes the values shown the same.
    context = z3.Context()
    question = [term.translate(context) for term in [*domains, *constraints]]
    symbols = {name: symbol.translate(context) for name, symbol in symbols.items()}
    solver = condition_solver(question, context)  # rounding asks it again
    solver.add(*question)
    checkpoint()
    answer = solver.check()
    if answer == z3.unknown:
        return "unknown", ""
    result = "sat" if answer == z3.sat else "unsat"
    found = witness(round_values(solver, symbols), symbols) if answer == z3.sat else ""
    cache.put(key, {"answer": result, "values": found})
    return result, found


def verdict(constraints: list[Any]) -> str:
    """ "sat", "unsat" or "unknown" (the time limit) for these constraints together,
    asked once and not cached. In a context of its own: z3's check slows with every
    term alive in its context (0.8 ms beside none, 140 ms beside 100,000), and a
    large spec's conditions keep tens of thousands alive. (A question that wants
    values is asked in a new context of its own, by `solve`.)"""
    context = _scratch_context()
    terms = [term.translate(context) for term in constraints]
    solver = condition_solver(terms, context)
    solver.add(*terms)
    checkpoint()
    answer = solver.check()
    return "sat" if answer == z3.sat else "unsat" if answer == z3.unsat else "unknown"


_SCRATCH = threading.local()
SCRATCH_QUESTIONS = 1000  # then a new context: nothing of the old one can pile up


def _scratch_context() -> Any:
    """The context verdict-only questions are asked in: one per thread, renewed
    now and then. Only a question's own terms live in it while it is asked, and
    making a context costs 5 ms (as much as the question itself), so it is kept."""
    asked = getattr(_SCRATCH, "asked", SCRATCH_QUESTIONS)
    if asked >= SCRATCH_QUESTIONS:
        _SCRATCH.context, asked = z3.Context(), 0
    _SCRATCH.asked = asked + 1
    return _SCRATCH.context


def round_values(solver: Any, symbols: dict[str, Any]) -> Any:
    """A model with round values where they serve (0, 1, the constants written in
    the conditions), and values present where they may be: easier to read, and
    the same whatever z3 happened to find (which differs with what the process
    asked z3 before, even in a new context).
    A candidate is first tried on the model itself (the assertions evaluated with
    it in place: no search); z3 is asked only when that fails, within
    ROUNDING_RLIMIT of its resource units, which count the same on every machine,
    where a time limit would make the message depend on the machine's load (a
    candidate over floats could take the whole 2 s limit, eight per value)."""
    found = solver.model()
    assertions = list(solver.assertions())
    for name, flag in sorted(symbols.items()):  # values there where they may be
        if name.startswith(PRESENT) and not z3.is_true(found.eval(flag)):
            found = _kept_by(found, assertions, flag, z3.BoolVal(True, flag.ctx)) or found
    constants = sorted({str(c) for c in _constants(assertions)}, key=lambda t: (len(t), t))
    for _, symbol in sorted(symbols.items()):
        if not (z3.is_fp(symbol) or z3.is_bv(symbol)) or found.eval(symbol).eq(symbol):
            continue
        for text in list(dict.fromkeys(["0", "1", *constants]))[:8]:
            candidate = number(Fraction(text), "int" if z3.is_bv(symbol) else "float")
            candidate = candidate.translate(symbol.ctx)
            if not candidate.sort().eq(symbol.sort()):
                continue  # a float constant is no round value of an integer
            rounded = _kept_by(found, assertions, symbol, candidate)
            if rounded is None:
                rounded = _solved_with(solver, symbol == candidate)
            if rounded is not None:
                found = rounded
                solver.add(symbol == candidate)
                assertions.append(symbol == candidate)
                break
    return found


ROUNDING_RLIMIT = 2_000_000  # z3's resource units for one rounding question


def _kept_by(model: Any, assertions: list[Any], symbol: Any, value: Any) -> Any:
    """A copy of `model` with `symbol` set to `value`, if every assertion still
    holds in it; None otherwise. Evaluated on a copy of that: completing a model
    gives its unassigned constants default values (a presence flag `false`), and
    which constants z3 leaves unassigned varies from process to process."""
    changed = model.__copy__()
    changed.update_value(symbol, value)
    probe = changed.__copy__()
    for assertion in assertions:
        if not z3.is_true(probe.eval(assertion, model_completion=True)):
            return None
    return changed


def _solved_with(solver: Any, constraint: Any) -> Any:
    """A model of the solver's assertions and `constraint`, if z3 finds one within
    ROUNDING_RLIMIT; None otherwise. The solver is left as it was."""
    solver.push()
    try:
        solver.add(constraint)
        solver.set("rlimit", ROUNDING_RLIMIT)
        checkpoint()
        return solver.model() if solver.check() == z3.sat else None
    finally:
        solver.set("rlimit", 0)
        solver.pop()


def _constants(terms: Iterable[Any]) -> set[Fraction]:
    out: set[Fraction] = set()
    stack = list(terms)
    while stack:
        term = stack.pop()
        if z3.is_fp_value(term):
            value = as_python_float(term)
            if value == value and abs(value) != float("inf"):
                out.add(Fraction(value).limit_denominator(10**6))
        elif z3.is_bv_value(term):
            out.add(Fraction(term.as_signed_long()))
        else:
            stack.extend(term.children())
    return out


def witness(model: Any, symbols: dict[str, Any]) -> str:
    """`BrakePedal = 0.9, Velocity = 6` from a z3 model (`Velocity has no value`
    where the model needs it absent)."""
    parts = []
    for name, symbol in sorted(symbols.items()):
        if name.startswith(("event ", PRESENT)):
            continue
        flag = symbols.get(PRESENT + name)
        presence = None if flag is None else model.eval(flag, model_completion=False)
        if presence is not None and z3.is_false(presence):
            parts.append(f"{name} has no value")
            continue
        # A value that must be there, whatever it is, is named with one that works.
        needed = presence is not None and z3.is_true(presence)
        value = model.eval(symbol, model_completion=needed)
        if value.eq(symbol):
            continue
        parts.append(f"{name} = {value_text(value)}")
    return ", ".join(parts) or "any values"
