"""A condition's expression as C99 statements that compute what
rmvdsl.runtime.expressions computes (docs/runtime.md, "Operators"): every value
with a presence flag (the runtime's MISSING: docs/semantics.md, "Absent values"),
integers as int64 with InfluxQL's wrapping done in uint64 (no undefined
behaviour), floats as IEEE doubles, Kleene's `and`/`or`. The transformations of
one value are libm's, which Python's math module calls too; a result that is NaN,
or infinite from finite arguments, has no value, as where Python's math raises.

What C cannot compute as the runtime does (strings, times, regular expressions,
functions of a series) raises Unsupported with the reason."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.functions import ELEMENTWISE
from rmvdsl.runtime.values import literal
from rmvdsl.targets.c.model import Unsupported

NUMERIC = ("int", "float")
_COMPARE = {"=": "==", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">="}
_INT_ARITHMETIC = {"+": "add", "-": "sub", "*": "mul", "%": "rem"}
_INT_HELPERS = frozenset({"neg", "iabs", *_INT_ARITHMETIC.values()})
_BITWISE = {"&": "&", "|": "|", "^": "^"}
_LIBM = {"sqrt": "sqrt", "exp": "exp", "ln": "log", "log2": "log2", "log10": "log10",
         "sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos",
         "atan": "atan"}  # fmt: skip
_ROUNDING = {"ceil": "ceil", "floor": "floor", "round": "round"}


@dataclass(frozen=True)
class Value:
    present: str  # a C expression: 1 where the value is there
    value: str  # a C expression of the kind's type
    kind: str  # bool | int | float


def c_int(value: int) -> str:
    """An int64 constant (INT64_MIN has no literal of its own)."""
    if value == -(2**63):
        return "INT64_MIN"
    return f"INT64_C({value})"


def c_double(value: float) -> str:
    """A double, exactly: C99's hexadecimal floating constants."""
    if value != value:
        raise Unsupported("a NaN constant")
    if value in (float("inf"), float("-inf")):
        return "HUGE_VAL" if value > 0 else "(-HUGE_VAL)"
    return f"({value.hex()})"


@dataclass
class Compiler:
    """One condition's statements. `sources`: each value's index among the
    monitor's inputs (a variable or a value event) and its kind; `flag_ids`: each
    boolean name's index (a boolean event, or one a transducer emits)."""

    sources: Mapping[str, tuple[int, str]]
    flag_ids: Mapping[str, int]
    lines: list[str] = field(default_factory=list)
    helpers: set[str] = field(default_factory=set)  # the engine's helper functions used
    floats: bool = False  # whether the condition computes with doubles
    libm: bool = False  # whether it calls <math.h>
    flags: list[int] = field(default_factory=list)  # the boolean names it reads
    # Where a value and its presence are read: "m->" the monitor's newest, "r->" a
    # query's row, or a series' slot.
    has_at: str = "m->has[{}]"
    value_at: str = "m->val[{}]"
    count: int = 0  # temporaries so far

    def helper(self, name: str) -> str:
        """The engine's helper `rmv_<name>`, marked as used (the integer ones read
        their result's bits through `rmv_i64`)."""
        self.helpers.add(name)
        if name in _INT_HELPERS:
            self.helpers.add("i64")
        return f"rmv_{name}"

    def temporary(self, kind: str, present: str, value: str) -> Value:
        index = self.count
        self.count += 1
        ctype = {"bool": "uint8_t", "int": "int64_t", "float": "double"}[kind]
        if kind == "float":
            self.floats = True
        self.lines.append(f"const uint8_t p{index} = (uint8_t)({present});")
        self.lines.append(f"const {ctype} v{index} = {value};")
        return Value(f"p{index}", f"v{index}", kind)

    def expr(self, node: ir.Expr) -> Value:
        match node:
            case ir.Number():
                number = literal(node.text)
                if isinstance(number, int):
                    return Value("1", c_int(number), "int")
                self.floats = True
                return Value("1", c_double(number), "float")
            case ir.Boolean():
                return Value("1", "1" if node.value else "0", "bool")
            case ir.Ref():
                return self.ref(node)
            case ir.Unary():
                return self.unary(node)
            case ir.Binary():
                return self.binary(node)
            case ir.Call():
                return self.call(node)
            case ir.String():
                raise Unsupported("a string (the C monitor computes numbers and bools)")
            case ir.Time():
                raise Unsupported(f"the time {node.text} (the C monitor computes numbers)")
        raise Unsupported(f"an expression of kind {type(node).__name__}")

    def ref(self, node: ir.Ref) -> Value:
        flag = self.flag_ids.get(node.name)
        if flag is not None:
            self.flags.append(flag)
            return self.temporary("bool", "1", f"(uint8_t)(on == {flag} ? 1 : m->flag[{flag}])")
        found = self.sources.get(node.name)
        if found is None:
            raise Unsupported(f"`{node.name}` (neither a value nor a boolean event)")
        index, kind = found
        member = {"bool": "b", "int": "i", "float": "f"}[kind]
        return self.temporary(
            kind, self.has_at.format(index), f"{self.value_at.format(index)}.{member}"
        )

    def unary(self, node: ir.Unary) -> Value:
        operand = self.expr(node.operand)
        if node.op == "not":
            return self.temporary("bool", operand.present, f"(uint8_t)!{operand.value}")
        if operand.kind == "int":
            return self.temporary("int", operand.present, f"{self.helper('neg')}({operand.value})")
        return self.temporary("float", operand.present, f"-{self.as_double(operand)}")

    def binary(self, node: ir.Binary) -> Value:
        left, right = self.expr(node.left), self.expr(node.right)
        both = f"{left.present} && {right.present}"
        op = node.op
        if op in ("and", "or"):
            return self.kleene(op, left, right)
        if op in _COMPARE:
            return self.temporary("bool", both, self.compare(op, left, right))
        if op in _BITWISE:
            if left.kind == "bool":
                return self.temporary("bool", both, f"(uint8_t)({left.value} {op} {right.value})")
            value = f"{self.helper('i64')}((uint64_t){left.value} {op} (uint64_t){right.value})"
            return self.temporary("int", both, value)
        if op == "/":
            value = f"{self.helper('div')}({self.as_double(left)}, {self.as_double(right)})"
            return self.temporary("float", both, value)
        if op in _INT_ARITHMETIC and left.kind == right.kind == "int":
            function = self.helper(_INT_ARITHMETIC[op])
            return self.temporary("int", both, f"{function}({left.value}, {right.value})")
        if op == "%":  # C's fmod is NaN for a zero divisor or an infinite dividend
            self.libm = True
            value = f"fmod({self.as_double(left)}, {self.as_double(right)})"
            return self.temporary("float", both, value)
        if op in ("+", "-", "*"):
            value = f"{self.as_double(left)} {op} {self.as_double(right)}"
            return self.temporary("float", both, value)
        raise Unsupported(f"the operator `{op}`" + (" (regular expressions)" if "~" in op else ""))

    def kleene(self, op: str, left: Value, right: Value) -> Value:
        """Kleene's `and` (false wins, then unknown) and `or` (true wins)."""
        if op == "and":
            decided = f"({left.present} && !{left.value}) || ({right.present} && !{right.value})"
            return self.temporary(
                "bool", f"({decided}) || ({left.present} && {right.present})", f"!({decided})"
            )
        decided = f"({left.present} && {left.value}) || ({right.present} && {right.value})"
        return self.temporary(
            "bool", f"({decided}) || ({left.present} && {right.present})", f"({decided})"
        )

    def compare(self, op: str, left: Value, right: Value) -> str:
        """`values.compare`: numbers of mixed kinds as doubles (a bool meets only a
        bool: the checker's types stage)."""
        c_op = _COMPARE[op]
        if left.kind == right.kind:
            return f"(uint8_t)({left.value} {c_op} {right.value})"
        if left.kind in NUMERIC and right.kind in NUMERIC:
            return f"(uint8_t)({self.as_double(left)} {c_op} {self.as_double(right)})"
        raise Unsupported(f"comparing a {left.kind} with a {right.kind}")

    def call(self, node: ir.Call) -> Value:
        name = node.function
        if name not in ELEMENTWISE:
            raise Unsupported(f"`{name}` (a function of a series of points)")
        arguments = [self.expr(a) for a in node.args]
        first = arguments[0]
        present = " && ".join(a.present for a in arguments)
        if name == "abs" and first.kind == "int":
            return self.temporary("int", present, f"{self.helper('iabs')}({first.value})")
        if name in _ROUNDING and first.kind == "int":
            return first
        self.libm = True
        doubles = [self.as_double(a) for a in arguments]
        if name == "abs":
            result = f"fabs({doubles[0]})"
        elif name in _ROUNDING:
            result = f"{_ROUNDING[name]}({doubles[0]})"
        elif name == "log":
            result = f"{self.helper('log_base')}({doubles[0]}, {doubles[1]})"
        elif name in ("pow", "atan2"):
            result = f"{name}({doubles[0]}, {doubles[1]})"
        else:
            result = f"{_LIBM[name]}({doubles[0]})"
        value = self.temporary("float", present, result)
        finite = " && ".join(f"isfinite({d})" for d in doubles)
        defined = f"{value.present} && {self.helper('defined')}({value.value}, {finite})"
        return self.temporary("float", defined, value.value)

    def statements(self, result: str) -> list[str]:
        """The lines, then a cast to void of each temporary nothing reads (a
        comparison of a bool with a number is decided by the kinds alone)."""
        uses = Counter(re.findall(r"\b[pv]\d+\b", "\n".join([*self.lines, result])))
        unread = []
        for k in range(self.count):
            for name in (f"p{k}", f"v{k}"):
                if uses[name] < 2:  # its declaration only
                    unread.append(f"(void){name};")
        return [*self.lines, *unread]

    def as_double(self, value: Value) -> str:
        self.floats = True
        return value.value if value.kind == "float" else f"(double){value.value}"
