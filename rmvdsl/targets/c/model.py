"""What the C target compiles: each property's formula as a table of nodes, children
first, with every time in ticks (half nanoseconds: docs/c.md) and every signal's
capacity derived from how often the property's input can change.

The tables are the Python monitor's nodes (rmvdsl.runtime.rmtld3.build) written
as data; the engine in templates/*.c.inc walks them. What the engine cannot
compute exactly is refused here, with the reason, never approximated."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

TICKS_PER_SECOND = 2_000_000_000  # half nanoseconds: midpoints of breakpoints are whole
BATCH = 32  # changes held before the nodes are recomputed (or once they span the horizon)
# The C monitor counts ticks from its first sample in int64 and takes samples within
# 2^61 ticks of it (RMV_SPAN_NS): every bound, window, constant and horizon stays
# within 2^60 ticks (18 years), so no sum of them overflows.
LIMIT = 1 << 60
SETS = 8  # the engine's bit sets of one property (B_SETS in templates/property.c.inc)
SLACK = 6  # the breakpoint at a signal's start, its unknown tail, the one kept at a cut

TEMPORAL_OPS = {"<": "OP_LT", "<=": "OP_LE", "=": "OP_EQ"}
COMPARE_OPS = {
    "<": "OP_LT",
    "<=": "OP_LE",
    "==": "OP_EQ",
    ">": "OP_GT",
    ">=": "OP_GE",
    "!=": "OP_NE",
}
MIRRORED = {"<": ">", ">": "<", "<=": ">=", ">=": "<=", "==": "==", "!=": "!="}
KINDS = {"const": "K_CONST", "prop": "K_PROP", "not": "K_NOT", "and": "K_AND", "or": "K_OR",
         "until": "K_UNTIL", "since": "K_SINCE", "cmp": "K_CMP", "ever": "K_EVER",
         "pending": "K_PENDING"}  # fmt: skip


class Unsupported(ValueError):
    """A formula, or a part of one, the C target cannot compute exactly."""


@dataclass(frozen=True)
class Node:
    kind: str  # a key of KINDS
    op: str = "OP_LT"
    plain: bool = False  # until/since with the constant true on the left
    value: int = 0  # a constant's truth value (0 false, 2 true)
    left: int = -1
    right: int = -1
    prop: int = -1  # a proposition's index within its property
    bound: int = 0  # ticks: a temporal bound, or a duration's window
    constant: int = 0  # ticks: what a duration is compared with
    future: int = 0
    past: int = 0  # how far back its update reads its children: finite under `ever` too
    weight: int = 0  # how many shifted copies of the input's changes it can hold
    offset: int = 0
    cap: int = 0


@dataclass(frozen=True)
class Formula:
    nodes: tuple[Node, ...]  # children first; the root last
    propositions: tuple[str, ...]  # in the order the nodes index them
    future: int  # ticks
    past: int

    @property
    def horizon(self) -> int:
        return self.future + self.past


def ticks(seconds: Any, what: str) -> int:
    """A time in seconds as whole ticks; a time finer than a nanosecond cannot be."""
    exact = Fraction(seconds) * TICKS_PER_SECOND
    if exact.denominator != 1 or exact % 2:
        raise Unsupported(f"{what} {float(seconds)!r} s is not a whole number of nanoseconds")
    if abs(exact) > LIMIT:
        raise Unsupported(f"{what} {float(seconds)!r} s is longer than the C monitor's 18 years")
    return int(exact)


def compile_formula(formula: Any) -> Formula:
    """The node table of a compiled formula (rmvdsl.runtime.formulas nodes or the
    plain tuples they are), walked by a loop: formulas nest deeper than C's or
    Python's stack would allow."""
    nodes: list[Node] = []
    props: dict[str, int] = {}
    prop_nodes: dict[str, int] = {}
    done: dict[int, int] = {}
    # Each distinct node once, by what it is (its children by index): equal
    # subformulas share a node whether or not the formula shares their objects (a
    # spec loaded from its JSON shares none), so a spec builds one table.
    seen: dict[Node, int] = {}
    stack: list[tuple[Any, bool]] = [(formula, False)]
    while stack:
        item, expanded = stack.pop()
        if id(item) in done:
            continue
        children = _children(item)
        if not expanded:
            stack.append((item, True))
            stack.extend((child, False) for child in reversed(children))
            continue
        before = len(nodes)
        index = _add(item, [done[id(c)] for c in children], nodes, props, prop_nodes)
        if index >= before:  # made now (with the pending node before it, for `ever`)
            index = seen.setdefault(nodes[index], index)
            if index < before:
                del nodes[before:]
        done[id(item)] = index
    if any(n.future + n.past > LIMIT for n in nodes):
        raise Unsupported("the formula looks further ahead and back than the C monitor's 18 years")
    root = nodes[done[id(formula)]]
    if done[id(formula)] != len(nodes) - 1:  # a shared proposition came last: the root goes last
        nodes.append(root)
    return Formula(tuple(nodes), tuple(props), root.future, root.past)


def _children(item: Any) -> list[Any]:
    kind = item[0]
    if kind in ("prop", "const"):
        return []
    if kind == "not":
        return [item[1]]
    if kind in ("and", "or"):
        return [item[1], item[2]]
    if kind in ("until", "since"):
        return [item[3], item[4]]
    if kind == "cmp":
        return _duration_bodies(item[2], item[3])
    raise Unsupported(f"unknown formula node {kind!r}")


def _duration_bodies(left: Any, right: Any) -> list[Any]:
    """The formula inside the one duration a comparison reads (none: constants)."""
    found = [t[2] for t in _term_parts(left) + _term_parts(right) if t[0] == "dur"]
    if len(found) > 1:
        raise Unsupported(
            "a comparison may read one duration: with two, the value changes where two"
            " durations cross, between nanoseconds"
        )
    return found


def _term_parts(term: Any) -> list[Any]:
    parts, stack = [], [term]
    while stack:
        item = stack.pop()
        if item[0] in ("add", "sub", "mul"):
            stack.extend((item[1], item[2]))
        else:
            parts.append(item)
    return parts


def _add(item: Any, kids: list[int], nodes: list[Node], props: dict[str, int],
         prop_nodes: dict[str, int]) -> int:  # fmt: skip
    kind = item[0]
    if kind == "prop":
        name = item[1]
        if name not in prop_nodes:
            props.setdefault(name, len(props))
            nodes.append(Node("prop", prop=props[name], weight=1))
            prop_nodes[name] = len(nodes) - 1
        return prop_nodes[name]
    if kind == "const":
        nodes.append(Node("const", value=2 if item[1] else 0))
    elif kind == "not":
        child = nodes[kids[0]]
        nodes.append(Node("not", left=kids[0], future=child.future, past=child.past,
                          weight=child.weight))  # fmt: skip
    elif kind in ("and", "or"):
        a, b = nodes[kids[0]], nodes[kids[1]]
        nodes.append(Node(kind, left=kids[0], right=kids[1], future=max(a.future, b.future),
                          past=max(a.past, b.past), weight=a.weight + b.weight))  # fmt: skip
    elif kind == "since" and item[2] is None:
        # since with no bound: its pending signal is the node just before it
        a, b = nodes[kids[0]], nodes[kids[1]]
        weight, past = a.weight + b.weight, max(a.past, b.past)
        nodes.append(Node("pending", past=past, weight=weight))
        nodes.append(Node("ever", left=kids[0], right=kids[1], future=max(a.future, b.future),
                          past=past, weight=weight))  # fmt: skip
    elif kind in ("until", "since"):
        nodes.append(_temporal(item, kids, nodes))
    else:
        nodes.append(_comparison(item, kids, nodes))
    return len(nodes) - 1


def _temporal(item: Any, kids: list[int], nodes: list[Node]) -> Node:
    kind, op, bound = item[0], item[1], ticks(item[2], "the bound")
    a, b = nodes[kids[0]], nodes[kids[1]]
    future, past = max(a.future, b.future), max(a.past, b.past)
    if kind == "until":
        future += bound
    else:
        past += bound
    plain = a.kind == "const" and a.value == 2
    return Node(kind, op=TEMPORAL_OPS[op], plain=plain, left=kids[0], right=kids[1],
                bound=bound, future=future, past=past,
                weight=2 * (a.weight + b.weight) + 1)  # fmt: skip


def _comparison(item: Any, kids: list[int], nodes: list[Node]) -> Node:
    """`left op right` as `duration op constant`: each side linear in the one
    duration, with slope 1 or -1 (a negative slope mirrors the comparison)."""
    op = item[1]
    (lc, lk, lw), (rc, rk, rw) = _linear(item[2]), _linear(item[3])
    coefficient, window = lc - rc, lw if lc else rw
    constant = rk - lk  # coefficient x D  op  constant
    if coefficient == 0:  # no duration: a constant comparison
        from rmvdsl.runtime.durations import compare

        truth = compare(op, (0, 0), (constant, constant))
        return Node("const", value=truth)
    if coefficient == -1:
        op, constant = MIRRORED[op], -constant
    body = nodes[kids[0]]
    return Node("cmp", op=COMPARE_OPS[op], left=kids[0], bound=window, constant=constant,
                future=window + body.future, past=body.past,
                weight=6 * body.weight + 2)  # fmt: skip


def _linear(term: Any) -> tuple[int, int, int]:
    """A term as (coefficient of its duration, constant in ticks, the duration's
    window in ticks)."""
    kind = term[0]
    if kind == "num":
        return 0, ticks(term[1], "the constant"), 0
    if kind == "dur":
        return 1, 0, ticks(term[1], "the duration's window")
    (a, x, wa), (b, y, wb) = _linear(term[1]), _linear(term[2])
    window = wa or wb
    if kind == "add":
        return a + b, x + y, window
    if kind == "sub":
        return a - b, x - y, window
    if a and b:
        raise Unsupported("a product of two durations is not linear")
    if not (a or b):  # two constants, in seconds
        product = Fraction(x, TICKS_PER_SECOND) * Fraction(y, TICKS_PER_SECOND)
        return 0, ticks(product, "the constant"), 0
    # (a D + x) times a constant factor (in seconds: a plain number here)
    coefficient, constant, factor = (a, x, Fraction(y, TICKS_PER_SECOND)) if a else (
        b, y, Fraction(x, TICKS_PER_SECOND))  # fmt: skip
    if coefficient * factor not in (-1, 0, 1):
        raise Unsupported(
            f"a duration times {float(factor)!r}: the C monitor compares a duration, or its"
            " negation, with a constant (its value then changes on whole nanoseconds)"
        )
    scaled = constant * factor
    if scaled.denominator != 1 or scaled % 2:
        raise Unsupported(
            f"the constant {float(scaled) / TICKS_PER_SECOND!r} s is not a whole number of"
            " nanoseconds"
        )
    return int(coefficient * factor), int(scaled), window if coefficient * factor else 0


def sized(formula: Formula, changes: int) -> Formula:
    """The formula with each node's slice of the pools: `changes` bounds how many
    times the input changes in any stretch of 3 horizons and a nanosecond (a
    node's breakpoints are shifted copies of those), plus a batch held."""
    per_copy = changes + BATCH + SLACK
    out, offset = [], 0
    for node in formula.nodes:
        cap = 2 if node.kind == "const" else node.weight * per_copy + SLACK
        out.append(replace(node, offset=offset, cap=cap))
        offset += cap
    return Formula(tuple(out), formula.propositions, formula.future, formula.past)


def changes_bound(rate_hz: Fraction, horizon_ticks: int) -> int:
    """Samples `rate_hz` at most: how many fit in 3 horizons and a nanosecond. The
    nodes keep breakpoints from 2 horizons and a nanosecond before the newest input
    on; each is an input change shifted by at most a horizon."""
    span = Fraction(3 * horizon_ticks + 2, TICKS_PER_SECOND)
    return math.floor(span * rate_hz) + 1


def scratch_size(formula: Formula) -> int:
    """Breakpoints a node's recomputation gathers at once."""
    need = 1
    for node in formula.nodes:
        if node.kind in ("until", "since"):
            children = formula.nodes[node.left].cap + formula.nodes[node.right].cap
            need = max(need, 6 * children + 8)  # the result, each child's merge, their merge
        elif node.kind == "cmp":
            need = max(need, 12 * formula.nodes[node.left].cap + 8)  # the result, points, crossings
    return need
