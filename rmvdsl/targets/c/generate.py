"""`rmv build --target c`: each property's formula compiled to node tables
(model.py), rendered with the engine into `rmv_<system>.h` / `.c`, a replay driver,
a Makefile and a CMakeLists.txt (docs/c.md)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import jinja2

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted
from rmvdsl.targets.c.dataflow import Flow, flow_of
from rmvdsl.targets.c.model import (
    BATCH,
    KINDS,
    LIMIT,
    SETS,
    TICKS_PER_SECOND,
    Formula,
    Unsupported,
    changes_bound,
    compile_formula,
    scratch_size,
    sized,
)
from rmvdsl.targets.rendering import template_environment

__all__ = [
    "CProperty",
    "CSystem",
    "build",
    "c_identifier",
    "c_string",
    "files",
    "identifiers",
    "system_of",
]

_C_KEYWORDS = frozenset(
    {
        "auto", "break", "case", "char", "const", "continue", "default", "do", "double",
        "else", "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long",
        "register", "restrict", "return", "short", "signed", "sizeof", "static", "struct",
        "switch", "typedef", "union", "unsigned", "void", "volatile", "while", "_Bool",
        "_Complex", "_Imaginary",
    }
)  # fmt: skip


def c_string(text: str) -> str:
    """Any text as a C string literal (the one quoting function for C): printable
    ASCII as is, everything else as octal escapes of its UTF-8 bytes (an octal
    escape takes at most three digits, so a digit after one reads as itself)."""
    out = []
    for byte in str(text).encode("utf-8"):
        char = chr(byte)
        if char in '"\\':
            out.append("\\" + char)
        elif 0x20 <= byte < 0x7F and char != "?":  # `?` could start a trigraph
            out.append(char)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def c_identifier(name: str) -> str:
    """A spec name as a C identifier: a plain identifier as is (a C keyword with a
    trailing `_`), anything else with each other character as `_xHH` of its UTF-8
    bytes. Two names that meet this way are told apart by `identifiers`."""
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", str(name)):
        return f"{name}_" if name in _C_KEYWORDS else str(name)
    text = "".join(
        char if char.isascii() and (char.isalnum() or char == "_") else
        "".join(f"_x{b:02X}" for b in char.encode("utf-8"))
        for char in str(name)
    )  # fmt: skip
    return text if text and not text[0].isdigit() else "_" + text


def identifiers(names: Iterable[str]) -> dict[str, str]:
    """Each name's C identifier, distinct: a later name whose identifier is taken
    gets `_2`, `_3`, ..."""
    taken: set[str] = set()
    out: dict[str, str] = {}
    for name in names:
        base = candidate = c_identifier(name)
        count = 1
        while candidate in taken:
            count += 1
            candidate = f"{base}_{count}"
        taken.add(candidate)
        out[name] = candidate
    return out


def comment(text: str) -> str:
    """Any text inside a one-line C comment (or a Makefile's, or CMake's): one line,
    printable ASCII, no `*/` or `/*`, no `??` to start a trigraph."""
    flat = re.sub(r"\s+", " ", str(text))
    flat = "".join(c if " " <= c <= "~" else "?" for c in flat)
    for sequence, safe in (("*/", "* /"), ("/*", "/ *"), ("??", "? ?"), ("??", "? ?")):
        flat = flat.replace(sequence, safe)
    return flat.rstrip("\\")  # a backslash at the end would join the next line


@dataclass(frozen=True)
class CProperty:
    name: str
    text: str
    formula: Formula
    period: int  # ticks; 0: every change
    first_node: int = 0
    prop_first: int = 0
    indexes: tuple[int, ...] = ()  # its propositions' system indexes
    words: int = 1
    bits_offset: int = 0
    held_offset: int = 0
    pool_offset: int = 0
    trigger: int = -1  # the system proposition that starts and stops it; -1: always


PROPERTIES_ONLY = Flow(reason="a system of properties alone")


@dataclass(frozen=True)
class CSystem:
    name: str
    properties: tuple[CProperty, ...]
    propositions: tuple[str, ...]
    flow: Flow = PROPERTIES_ONLY  # the events and transducers, in C

    @property
    def identifier(self) -> str:
        return c_identifier(self.name)


def laid_out(
    name: str,
    compiled: list[tuple[str, str, Formula, int]],
    triggers: dict[str, str] | None = None,
) -> CSystem:
    """Properties (name, text, sized formula, period) placed in the pools;
    `triggers`: a triggered property's trigger (a state or a boolean event)."""
    propositions: dict[str, int] = {}
    properties = []
    nodes = pool = bits = held = slots = 0
    for prop_name, text, formula, period in compiled:
        indexes = tuple(propositions.setdefault(p, len(propositions)) for p in formula.propositions)
        words = max(1, -(-len(indexes) // 32))
        trigger = (triggers or {}).get(prop_name)
        where = -1 if trigger is None else propositions.setdefault(trigger, len(propositions))
        properties.append(
            CProperty(
                prop_name,
                text,
                formula,
                period,
                nodes,
                slots,
                indexes,
                words,
                bits,
                held,
                pool,
                where,
            )
        )
        nodes += len(formula.nodes)
        pool += sum(n.cap for n in formula.nodes)
        bits += (SETS + 2 * BATCH) * words  # the engine's sets and the held changes
        held += BATCH
        slots += len(indexes)
    return CSystem(name, tuple(properties), tuple(propositions))


def system_of(spec: ir.Spec, max_rate: Fraction | None = None) -> CSystem:
    """The spec's properties, compiled; Unsupported names what cannot be.
    `max_rate` (Hz) bounds how often the input of a property without `rate`
    changes."""
    problems = problems_of(spec, max_rate)
    if problems:
        raise Unsupported(
            "\n".join(f"{origin}: {message}" if origin else message for origin, message in problems)
        )
    compiled = [_compiled_property(p, max_rate) for p in spec.properties]
    triggers = {p.name: p.trigger for p in spec.properties if p.trigger != "always"}
    system = laid_out(spec.system.name, compiled, triggers)
    return replace(system, flow=flow_of(spec, system.propositions))


def left_to_host(spec: ir.Spec) -> list[tuple[str, str, str]]:
    """What the C monitor leaves to its host, (where, what, the fix) each: the
    propositions, or the points of value events it does not compute."""
    try:
        flow = system_of(spec, Fraction(1)).flow  # any rate: the flow does not depend on it
    except Unsupported:
        return []
    if not flow.compiled:
        return [(flow.where, f"the host gives the propositions: {flow.reason}", "")]
    rate = "declare how often the topic publishes: `max_rate = 20Hz` in its qos block"
    return [
        (origin, f"the host gives the points of {name}: {why}", rate if "max_rate" in why else "")
        for name, why, origin in flow.hosted
    ]


def problems_of(spec: ir.Spec, max_rate: Fraction | None = None) -> list[tuple[str, str]]:
    """What the C target cannot build: (where, why) each."""
    if not spec.properties:
        return [("", "the spec has no property: the C target compiles properties")]
    problems = []
    for prop in spec.properties:
        try:
            _compiled_property(prop, max_rate)
        except Unsupported as error:
            problems.append((prop.origin, str(error)))
    return problems


def _compiled_property(
    prop: ir.Property, max_rate: Fraction | None
) -> tuple[str, str, Formula, int]:
    where = f"property {prop.name}"
    if prop.lateness:
        raise Unsupported(f"{where}: `lateness` (the C monitor takes samples in time order)")
    if prop.rate is None and max_rate is None:
        raise Unsupported(
            f"{where}: no `rate`: the C monitor's memory is sized from how often its input"
            " can change; give the property a `rate = ...Hz`, or build with `--max-rate`"
        )
    try:
        formula = compile_formula(prop.formula)
    except Unsupported as error:
        raise Unsupported(f"{where}: {error}") from None
    if prop.rate is None:  # every change, at most max_rate a second
        assert max_rate is not None
        return prop.name, prop.text, sized(formula, changes_bound(max_rate, formula.horizon)), 0
    period = _period_ticks(prop.rate)
    if not 0 < period <= LIMIT:
        raise Unsupported(
            f"{where}: `rate` {float(prop.rate)!r} Hz is below one sample in 18 years"
        )
    bound = changes_bound(Fraction(TICKS_PER_SECOND, period), formula.horizon)
    return prop.name, prop.text, sized(formula, bound), period


def _period_ticks(rate: Fraction) -> int:
    """The period the Python runtime samples at (influx.nanoseconds(1 / rate)), in ticks."""
    from rmvdsl.runtime import influx

    return 2 * int(influx.nanoseconds(1 / rate))


def environment() -> jinja2.Environment:
    filters = {"c": c_string, "comment": comment}
    return template_environment((__package__ or "rmvdsl.targets.c",), filters)


def memory_bytes(system: CSystem) -> int:
    """An upper bound of sizeof(the monitor struct): each array padded to 8 bytes."""

    def padded(size: int) -> int:
        return -(-size // 8) * 8

    count = len(system.properties)
    nodes = sum(len(p.formula.nodes) for p in system.properties)
    pool = sum(sum(n.cap for n in p.formula.nodes) for p in system.properties)
    bits = sum((SETS + 2 * BATCH) * p.words for p in system.properties)
    scratch = max(scratch_size(p.formula) for p in system.properties)
    run = 96  # sizeof(rmv_run) is 88 on LP64 targets
    tail = 40  # the callback, its context, the base time and the counters
    arrays = padded(4 * nodes) + padded(8 * pool) + 2 * padded(pool) + padded(4 * bits)
    total = padded(run * count) + arrays + padded(8 * BATCH * count) + padded(8 * scratch) + tail
    return total + (_flow_bytes(system.flow, padded) if system.flow.compiled else 0)


def _flow_bytes(flow: Flow, padded: Callable[[int], int]) -> int:
    """The monitor's fields that compute from values (monitor.h.j2), each padded."""
    values = max(1, len(flow.sources))
    flags = max(1, len(flow.flags))
    transducers = max(1, len(flow.transducers))
    transitions = max(1, sum(len(t.transitions) for t in flow.transducers))
    row = 8 + padded(values) + 8 * values
    queries = max(1, len(flow.windowed_queries))
    windowed = (
        flow.pending * row + 8 + flow.rows * row + 2 * padded(4 * queries) + 8 * flow.written * 2
        + padded(4 * queries) + 8 * queries + padded(queries)
        + flow.series * (padded(flow.slots) + 8 * flow.slots)
        + 3 * 8 * flow.slots + 2 * 8 * flow.outs + padded(flow.slots)
        + (20 * flow.row_most if "keep" in flow.helpers else 0)
    ) if flow.windowed_queries else 0  # fmt: skip
    raw = 32 * flow.streams if flow.raw_queries else 0
    return (
        2 * padded(8 * values) + 2 * padded(values) + 3 * padded(flags) + padded(transitions)
        + 2 * padded(4 * transducers) + 3 * padded(4 * flow.log) + 56
        + windowed + raw
    )  # fmt: skip


def files(system: CSystem, source: str = "") -> dict[str, str]:
    """Every file of the build, by name."""
    identifier = system.identifier
    header, source_file = f"rmv_{identifier}.h", f"rmv_{identifier}.c"
    context: dict[str, Any] = {
        "system": system,
        "id": identifier,
        "ID": identifier.upper(),
        "header": header,
        "source_file": source_file,
        "driver": f"rmv_{identifier}_replay.c",
        "program": f"rmv_{identifier}_replay",
        "library": f"rmv_{identifier}",
        "source": source or "a spec",
        "propositions": system.propositions,
        "proposition_ids": identifiers(system.propositions),
        "property_ids": identifiers(p.name for p in system.properties),
        "properties": system.properties,
        "proposition_slots": sum(len(p.indexes) for p in system.properties),
        "kinds": KINDS,
        "batch": BATCH,
        "bytes": memory_bytes(system),
        "nodes": sum(len(p.formula.nodes) for p in system.properties),
        "pool": sum(sum(n.cap for n in p.formula.nodes) for p in system.properties),
        "bits": sum((SETS + 2 * BATCH) * p.words for p in system.properties),
        "held": BATCH * len(system.properties),
        "scratch": max(scratch_size(p.formula) for p in system.properties),
        "flow": system.flow,
        "value_ids": identifiers(s.name for s in system.flow.sources),
        "transitions": sum(len(t.transitions) for t in system.flow.transducers),
    }
    env = environment()
    return {
        header: env.get_template("monitor.h.j2").render(context),
        source_file: env.get_template("monitor.c.j2").render(context),
        context["driver"]: env.get_template("replay.c.j2").render(context),
        "Makefile": env.get_template("Makefile.j2").render(context),
        "CMakeLists.txt": env.get_template("CMakeLists.txt.j2").render(context),
    }


def build(spec: ir.Spec, out: Path, max_rate: Fraction | None = None) -> tuple[list[Path], CSystem]:
    """Write the build into `out`; the paths written and what was built."""
    system = system_of(spec, max_rate)
    written = []
    origin = spec.properties[0].origin.rsplit(":", 2)[0]  # the spec file that declares them
    for name, text in files(system, origin).items():
        path = out / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written, system


def flow_summary(flow: Flow) -> str:
    """What `rmv build` says of the events and transducers."""
    if not flow.compiled:
        where = f" (at {flow.where})" if flow.where else ""
        return f"the host gives the propositions: {flow.reason}{where}"
    events = counted(len(flow.conditions), "event")
    transducers = counted(len(flow.transducers), "transducer")
    given = len(flow.sources) - len(flow.queries)
    computed = f", {counted(len(flow.queries), 'query', 'queries')}" if flow.queries else ""
    text = f"it computes {events}{computed} and {transducers} from {counted(given, 'value')}"
    for name, why, origin in flow.hosted:
        text += f"; the host gives the points of {name}: {why} (at {origin})"
    return text
