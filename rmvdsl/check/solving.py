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
    bits = z3.simplify(z3.fpToIEEEBV(value))
    if not z3.is_bv_value(bits):  # NaN has no single encoding
        return float("nan")
    return float(struct.unpack("<d", bits.as_long().to_bytes(8, "little"))[0])


def names_in(terms: list[Any]) -> set[str]:
    """The names of the free constants in z3 terms (each shared subterm once).
    Walked with z3's C API on the terms' pointers: the Python objects `children()`
    makes for every subterm cost 6x the walk (0.87 s against 0.14 s for the
    conditions of 1,000 events)."""
    names: set[str] = set()
    if not terms:
        return names
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
                symbol = z3core.Z3_get_decl_name(context, decl)
                names.add(z3core.Z3_get_symbol_string(context, symbol))
    return names


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
    key = digest("conditions", "5", z3.get_version_string(), declared, terms)
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
    solver = z3.Solver()
    solver.add(*domains, *constraints)
    solver.set("timeout", SOLVER_TIMEOUT_MS)
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
    large spec's conditions keep tens of thousands alive. (Reading values from a
    model of another context hung in z3's numeral printing: values are read from
    the main one, and only a few questions want them.)"""
    context = _scratch_context()
    solver = z3.Solver(ctx=context)
    solver.add(*(term.translate(context) for term in constraints))
    solver.set("timeout", SOLVER_TIMEOUT_MS)
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
    the conditions): easier to read, and the same whatever z3 happened to find."""
    found = solver.model()
    constants = sorted(
        {str(c) for c in _constants(solver.assertions())}, key=lambda text: (len(text), text)
    )
    for _, symbol in sorted(symbols.items()):
        if not (z3.is_fp(symbol) or z3.is_bv(symbol)) or found.eval(symbol).eq(symbol):
            continue
        for text in ["0", "1", *constants][:8]:
            candidate = number(Fraction(text), "int" if z3.is_bv(symbol) else "float")
            if not candidate.sort().eq(symbol.sort()):
                continue  # a float constant is no round value of an integer
            solver.push()
            solver.add(symbol == candidate)
            checkpoint()
            if solver.check() == z3.sat:
                found = solver.model()
                solver.pop()
                solver.add(symbol == candidate)
                break
            solver.pop()
    return found


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
