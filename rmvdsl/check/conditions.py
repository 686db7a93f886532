"""Boolean events as z3 formulas, with the runtime's operator semantics.

Every operator means what `rmvdsl.runtime.values` computes (InfluxQL's semantics):
integers are 64-bit bit-vectors (wrapping `+ - *`, Go's `%`, bitwise operators),
floats are IEEE doubles (z3's floating-point theory: rounding, NaN and infinities
included), `/` divides as floats and gives 0 for a zero divisor. A variable ranges
over its ROS type (an `int8` over -128..127, a `float64` over every double,
NaN included), and may have no value yet: each value has a presence flag, and a
condition is three-valued as in the runtime (Kleene's `and`/`or`, an event holds
where its condition is true; docs/semantics.md, "Absent values"). What z3 cannot
model exactly — a function of the data (`mean(V)`), a value event, a
regular-expression match — is a free value of its sort, so an answer "can hold" is
a possibility the spec leaves open and "never holds" is exact.

`solve` asks z3 (each answer cached by its question), with round values in the
witnesses it returns.
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import z3

from rmvdsl.cache import default_cache, digest
from rmvdsl.check.lowering import NotLowered, lower_expr
from rmvdsl.check.model import Model
from rmvdsl.check.types import TypeInfo
from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.values import INT_BITS, INTEGER_RANGES, literal

SOLVER_TIMEOUT_MS = 2000
FLOAT = z3.Float64()
ROUNDING = z3.RNE()  # IEEE's default, and Go's
_ORDERS = ("<", "<=", ">", ">=")


ALWAYS = z3.BoolVal(True)


@dataclass(frozen=True)
class Term:
    """A value as the runtime holds it: `value` where `present`, else absent (the
    runtime's MISSING: a topic not yet published). A boolean term is three-valued:
    true where `present and value`, false where `present and not value`, unknown
    elsewhere (docs/semantics.md, "Absent values")."""

    value: Any
    present: Any = ALWAYS

    @property
    def true(self) -> Any:
        """Where the term is `True`: where a condition holds."""
        if z3.is_true(self.present):
            return as_bool(self.value)
        return z3.And(self.present, as_bool(self.value))

    @property
    def false(self) -> Any:
        if z3.is_true(self.present):
            return z3.Not(as_bool(self.value))
        return z3.And(self.present, z3.Not(as_bool(self.value)))


def _both(left: Term, right: Term) -> Any:
    if z3.is_true(left.present):
        return right.present
    if z3.is_true(right.present):
        return left.present
    return z3.And(left.present, right.present)


def kleene(op: str, left: Term, right: Term) -> Term:
    """`and`/`or` over three values, as rmvdsl.runtime.influx.kleene_and/or: false
    (true) decides an `and` (an `or`) whatever the other side is."""
    if op == "and":
        holds, fails = z3.And(left.true, right.true), z3.Or(left.false, right.false)
    else:
        holds, fails = z3.Or(left.true, right.true), z3.And(left.false, right.false)
    present = _both(left, right)
    if z3.is_true(present):
        return Term(holds)
    return Term(holds, z3.Or(holds, fails))


class Conditions:
    """The z3 formula of each boolean event; `symbols` names the free values."""

    def __init__(self, model: Model, types: TypeInfo | None) -> None:
        self.model = model
        self.types = types
        self.symbols: dict[str, Any] = {}
        self.domains: dict[str, list[Any]] = {}  # a variable's range, by its name
        self._inlining: set[str] = set()

    def of_event(self, name: str) -> Any:
        """Where the boolean event `name` holds: where its condition (and `where`)
        is true. An unknown condition does not hold, as in the runtime."""
        decl = self.model.events.get(name)
        if decl is None or not decl.boolean or name in self._inlining or self.types is None:
            return self.free(f"event {name}", "bool", may_be_absent=False).true
        self._inlining.add(name)
        try:
            # The typed trees the runtime evaluates (rmvdsl.check.lowering).
            condition = self.expr(lower_expr(self.model, self.types, decl.expr)).true
            where = decl.clause("where")
            if where is not None:
                lowered = lower_expr(self.model, self.types, where.value)
                condition = z3.And(condition, self.expr(lowered).true)
            return condition
        except (z3.Z3Exception, TypeError, AttributeError, NotLowered):
            # Sorts that do not fit (the types stage reports why): no claim at all.
            return self.free(f"event {name}", "bool", may_be_absent=False).true
        finally:
            self._inlining.discard(name)

    def solve(self, constraints: list[Any], values: bool = True) -> tuple[str, str]:
        """`solve` of these constraints, with the ranges of the
        variables they mention (only those: a question's cache key and its cost do
        not grow with the rest of the spec). Without `values`, only the verdict."""
        used = _names_in(constraints)
        domains = [c for name in sorted(used & self.domains.keys()) for c in self.domains[name]]
        symbols = {name: self.symbols[name] for name in sorted(used) if name in self.symbols}
        return solve(constraints, domains, symbols, values)

    def present(self, constraints: list[Any]) -> Any:
        """Every value these constraints read has a value (each topic has published):
        true after the start, whatever state a transducer is in."""
        flags = [self.symbols[n] for n in sorted(_names_in(constraints)) if n.startswith(PRESENT)]
        return z3.And(*flags) if flags else z3.BoolVal(True)

    def names_of_event(self, name: str) -> set[str]:
        """The variables and values an event's condition reads (two conditions that
        share none are independent)."""
        return {_value_name(n) for n in _names_in([self.of_event(name)])}

    def free(self, key: str, kind: str, may_be_absent: bool = True) -> Term:
        """A value of its own, one per key (the same text means the same value),
        absent where its own presence flag is false."""
        if key not in self.symbols:
            self.symbols[key] = _constant(key, kind)
        if not may_be_absent:
            return Term(self.symbols[key])
        flag = PRESENT + key
        if flag not in self.symbols:
            self.symbols[flag] = z3.Bool(flag)
        return Term(self.symbols[key], self.symbols[flag])

    def variable(self, name: str, vtype: ir.ValueType) -> Term:
        if name not in self.symbols:
            symbol = self.symbols[name] = _constant(name, _sort_kind(vtype.kind))
            if vtype.ros in INTEGER_RANGES:
                least, most = INTEGER_RANGES[vtype.ros]
                self.domains[name] = [symbol >= least, symbol <= most]
        return self.free(name, "")

    def expr(self, node: ir.Expr) -> Term:
        """A lowered expression as z3 computes it, with where it has a value."""
        match node:
            case ir.Number():
                kind = "int" if isinstance(literal(node.text), int) else "float"
                return Term(number(node.value, kind))
            case ir.Boolean():
                return Term(z3.BoolVal(node.value))
            case ir.String():
                return Term(z3.StringVal(node.value))
            case ir.Time():
                return Term(number(node.seconds, "float"))
            case ir.Ref():
                return self.name(node)
            case ir.Unary():
                operand = self.expr(node.operand)
                if node.op == "not":
                    return Term(z3.Not(as_bool(operand.value)), operand.present)
                return Term(negate(operand.value), operand.present)
            case ir.Binary():
                return self.binary(node)
        # A function of the data: a value of its own, of its type's sort.
        return self.free(text(node), _sort_kind(node.type.kind))

    def name(self, ref: ir.Ref) -> Term:
        name = ref.name
        if ref.kind == "variable":
            return self.variable(name, ref.type)
        if ref.kind == "emitted":
            return self.free(f"event {name}", "bool", may_be_absent=False)
        decl = self.model.events.get(name)
        if decl is not None and decl.boolean:
            # An event holds or does not: never unknown (its unknown condition
            # does not hold), so `not E` holds where E's condition is unknown.
            return Term(self.of_event(name))
        return self.free(name, _sort_kind(ref.type.kind))  # a value event: its newest value

    def binary(self, node: ir.Binary) -> Term:
        left, right = self.expr(node.left), self.expr(node.right)
        op = node.op
        if op in ("and", "or"):
            return kleene(op, left, right)
        if op in ("=~", "!~"):
            return self.free(text(node), "bool")
        try:
            return Term(apply(op, left.value, right.value), _both(left, right))
        except (z3.Z3Exception, TypeError, KeyError):
            kind = "bool" if op in ("=", "!=", *_ORDERS) else "float"
            return self.free(text(node), kind)


def text(node: ir.Expr) -> str:
    """An expression's text, the name of its free value: the same text, the same
    value (`mean(V)` in two events)."""
    match node:
        case ir.Number() | ir.Time():
            return node.text
        case ir.String():
            return repr(node.value)
        case ir.Boolean():
            return "true" if node.value else "false"
        case ir.Ref():
            return node.name
        case ir.Unary():
            return (
                f"{node.op} ({text(node.operand)})"
                if node.op == "not"
                else f"-({text(node.operand)})"
            )
        case ir.Binary():
            return f"({text(node.left)}) {node.op} ({text(node.right)})"
        case ir.Call():
            return f"{node.function}({', '.join(text(a) for a in node.args)})"
    return repr(node)


PRESENT = "present "  # the prefix of a value's presence flag


def _value_name(name: str) -> str:
    return name.removeprefix(PRESENT)


def _sort_kind(kind: str) -> str:
    """The z3 sort of a value of this kind: times and durations are seconds."""
    return kind if kind in ("bool", "int", "string") else "float"


def _constant(name: str, kind: str) -> Any:
    if kind == "bool":
        return z3.Bool(name)
    if kind == "string":
        return z3.String(name)
    if kind == "int":
        return z3.BitVec(name, INT_BITS)
    return z3.FP(name, FLOAT)  # floats, times and durations (seconds)


def number(value: Fraction, kind: str) -> Any:
    """A constant: an integer literal as a 64-bit integer, anything else as the
    double nearest to it (as InfluxQL parses it)."""
    if kind == "int" and value.denominator == 1 and -(2**63) <= value < 2**63:
        return z3.BitVecVal(int(value), INT_BITS)
    return z3.FPVal(float(value), FLOAT)


def is_int(value: Any) -> bool:
    return z3.is_bv(value)


def is_float(value: Any) -> bool:
    return z3.is_fp(value)


def to_float(value: Any) -> Any:
    if is_float(value):
        return value
    if z3.is_bool(value):
        value = z3.If(value, z3.BitVecVal(1, INT_BITS), z3.BitVecVal(0, INT_BITS))
    return z3.fpSignedToFP(ROUNDING, value, FLOAT)


def as_bool(value: Any) -> Any:
    if z3.is_bool(value):
        return value
    if is_float(value):
        return z3.Not(z3.fpIsZero(value))
    return value != 0


def negate(value: Any) -> Any:
    if is_float(value):
        return z3.fpNeg(value)
    if is_int(value):
        return -value
    raise TypeError("`-` needs a number")


def apply(op: str, left: Any, right: Any) -> Any:
    """`op` on two z3 values, as `rmvdsl.runtime.values.binary` computes it."""
    if op in ("&", "|", "^"):
        if not (is_int(left) and is_int(right)):
            raise TypeError(f"`{op}` needs integers")
        return {"&": left & right, "|": left | right, "^": left ^ right}[op]
    if z3.is_string(left) or z3.is_string(right):
        if op not in ("=", "!="):
            raise TypeError("strings are only compared for equality")
        return left == right if op == "=" else left != right
    if z3.is_bool(left) and z3.is_bool(right) and op in ("=", "!="):
        return left == right if op == "=" else left != right
    if op == "/":
        return _divide(to_float(left), to_float(right))
    if is_int(left) and is_int(right):
        return _integers(op, left, right)
    return _floats(op, to_float(left), to_float(right))


def _divide(left: Any, right: Any) -> Any:
    return z3.If(z3.fpIsZero(right), z3.FPVal(0.0, FLOAT), z3.fpDiv(ROUNDING, left, right))


def _integers(op: str, left: Any, right: Any) -> Any:
    zero = z3.BitVecVal(0, INT_BITS)
    return {
        "+": lambda: left + right,
        "-": lambda: left - right,
        "*": lambda: left * right,
        "%": lambda: z3.If(right == zero, zero, z3.SRem(left, right)),
        "=": lambda: left == right,
        "!=": lambda: left != right,
        "<": lambda: left < right,  # signed, as z3py's operators on bit-vectors are
        "<=": lambda: left <= right,
        ">": lambda: left > right,
        ">=": lambda: left >= right,
    }[op]()


def _floats(op: str, left: Any, right: Any) -> Any:
    return {
        "+": lambda: z3.fpAdd(ROUNDING, left, right),
        "-": lambda: z3.fpSub(ROUNDING, left, right),
        "*": lambda: z3.fpMul(ROUNDING, left, right),
        "%": lambda: _fmod(left, right),
        "=": lambda: z3.fpEQ(left, right),
        "!=": lambda: z3.Not(z3.fpEQ(left, right)),
        "<": lambda: z3.fpLT(left, right),
        "<=": lambda: z3.fpLEQ(left, right),
        ">": lambda: z3.fpGT(left, right),
        ">=": lambda: z3.fpGEQ(left, right),
    }[op]()


def _fmod(left: Any, right: Any) -> Any:
    """C's fmod from IEEE's remainder: the same value moved by |right| to the
    dividend's sign (exact: fmod's result is a double)."""
    rem = z3.fpRem(left, right)
    size = z3.fpAbs(right)
    moved = z3.If(
        z3.And(z3.fpIsPositive(left), z3.fpIsNegative(rem), z3.Not(z3.fpIsZero(rem))),
        z3.fpAdd(ROUNDING, rem, size),
        z3.If(
            z3.And(z3.fpIsNegative(left), z3.fpIsPositive(rem), z3.Not(z3.fpIsZero(rem))),
            z3.fpSub(ROUNDING, rem, size),
            rem,
        ),
    )
    nan = z3.fpNaN(FLOAT)
    return z3.If(z3.Or(z3.fpIsZero(right), z3.fpIsInf(left)), nan, moved)


def value_text(value: Any) -> str:
    """A model's value as the runtime would print it."""
    if z3.is_bv_value(value):
        return str(value.as_signed_long())
    if z3.is_fp_value(value):
        number = as_python_float(value)
        return "NaN" if number != number else repr(number)
    if z3.is_rational_value(value):
        from rmvdsl.numbers import decimal

        return decimal(Fraction(value.numerator_as_long(), value.denominator_as_long()))
    if z3.is_string_value(value):
        return f'"{value.as_string()}"'
    return str(value)


def as_python_float(value: Any) -> float:
    bits = z3.simplify(z3.fpToIEEEBV(value))
    if not z3.is_bv_value(bits):  # NaN has no single encoding
        return float("nan")
    return float(struct.unpack("<d", bits.as_long().to_bytes(8, "little"))[0])


def _names_in(terms: list[Any]) -> set[str]:
    """The names of the free constants in z3 terms (each shared subterm once)."""
    names: set[str] = set()
    seen: set[int] = set()
    stack = list(terms)
    while stack:
        term = stack.pop()
        key = term.get_id()
        if key in seen:
            continue
        seen.add(key)
        if z3.is_const(term) and term.decl().kind() == z3.Z3_OP_UNINTERPRETED:
            names.add(term.decl().name())
        else:
            stack.extend(term.children())
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
    if values:
        solver = z3.Solver()
        solver.add(*domains, *constraints)
    else:
        # In a context of its own: z3's check slows with every term alive in its
        # context (0.8 ms beside none, 140 ms beside 100,000), and a large spec's
        # conditions keep tens of thousands alive. (Reading values from a model
        # of another context hung in z3's numeral printing: values are read from
        # the main one, and only a few questions want them.)
        context = _scratch_context()
        solver = z3.Solver(ctx=context)
        solver.add(*(term.translate(context) for term in [*domains, *constraints]))
    solver.set("timeout", SOLVER_TIMEOUT_MS)
    answer = solver.check()
    if answer == z3.unknown:
        return "unknown", ""  # a time limit: not an answer to keep
    result = "sat" if answer == z3.sat else "unsat"
    if answer == z3.sat and not values:
        cache.put(key, {"answer": result, "values": None})
        return result, ""
    found = witness(round_values(solver, symbols), symbols) if answer == z3.sat else ""
    cache.put(key, {"answer": result, "values": found})
    return result, found


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
