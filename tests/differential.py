"""The differential test of whole specs (issue 30): `rmv check`'s exact claims
against the runtime, on random small specs and random recordings.

For each seed: a spec (2-4 topics of Int32, UInt64, Float64 and Bool; events with
and/or/not, arithmetic and comparisons over edge constants, some reading other
events; a transducer; 1-3 properties) and a few recordings (topics that publish
late or never, edge values, NaN and infinities, several messages at one instant).
Every claim the checker makes that a run can contradict is tested on every
recording, and every witness it prints is replayed through the runtime:

- RMV500: the state is never entered.      - RMV502: the input never holds.
- RMV510/RMV511: the property is never true.  - RMV512: it is never false.
- RMV513: the implication's antecedent, monitored alone, is never true.
- RMV514: the properties are never all true at one time.
- RMV515: where the others are all true, the implied one is not false.
- RMV505: at the witness values both events hold.
- RMV506: at the witness values no input of the state holds.
- `--witnesses`: each property's trace where it holds (fails), run through the
  runtime's monitor, is true (false) at the time the checker names.

Properties are sometimes sampled at a `rate` or run under a `trigger`; a value
event over a window (a free value to the solver) is sometimes read by a condition;
InfluxQL's `<>` appears beside `!=`.

    python tests/differential.py --long               # the long run: 10,000 seeds
    python tests/differential.py --seed 1234 --show   # one case, spec and findings
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import random
import re
import sys
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

NS = 10**9
ROS_TYPES = {"Int32": "int32", "UInt64": "uint64", "Float64": "float64", "Bool": "bool"}
EDGE_VALUES: dict[str, list[Any]] = {
    "Int32": [0, 1, -1, 5, 6, 2**31 - 1, -(2**31)],
    "UInt64": [0, 1, 5, 2**63 - 1, 2**63, 2**64 - 1],
    "Float64": [0.0, -0.0, 1.0, 5.0, 5.5, -2.5, math.nan, math.inf, -math.inf, 1e300],
    "Bool": [True, False],
}
CONSTANTS = {
    "Int32": ["0", "1", "5", "-1", "2147483647"],
    "UInt64": ["0", "5", "9223372036854775807", "-1"],
    "Float64": ["0.0", "1.0", "5.0", "-2.5", "5.5"],
}
COMPARISONS = ("=", "!=", "<>", "<", "<=", ">", ">=")


@dataclass
class Case:
    seed: int
    text: str
    topics: dict[str, str]  # ROS name -> message type (Int32, ...)
    variables: dict[str, str]  # variable -> its topic's ROS name
    recordings: list[list[tuple[int, str, Any]]] = field(default_factory=list)


# ---- random specs ----


class SpecMaker:
    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.kinds: dict[str, str] = {}  # variable -> message type
        self.events: list[str] = []
        self.windowed: list[str] = []  # value events over windows (free values to z3)

    def atom(self) -> str:
        rng = self.rng
        name = rng.choice(sorted(self.kinds))
        kind = self.kinds[name]
        if self.windowed and rng.random() < 0.15:
            window = rng.choice(self.windowed)
            return f"{window} {rng.choice(COMPARISONS)} {rng.choice(['0', '1.0', '5.0'])}"
        if kind == "Bool":
            return rng.choice([name, f"not {name}", f"{name} = true", f"{name} != false"])
        if self.events and rng.random() < 0.2:
            return rng.choice(self.events)
        left = name
        if rng.random() < 0.3:
            op = rng.choice(["+", "-", "*"])
            left = f"{name} {op} {rng.choice(CONSTANTS[kind])}"
        if rng.random() < 0.2:  # the transformations z3 computes exactly
            left = f"{rng.choice(['abs', 'floor', 'ceil', 'round'])}({left})"
        same = [v for v, k in self.kinds.items() if k == kind and v != name]
        right = rng.choice(same) if same and rng.random() < 0.25 else rng.choice(CONSTANTS[kind])
        return f"{left} {rng.choice(COMPARISONS)} {right}"

    def condition(self, depth: int) -> str:
        rng = self.rng
        if depth == 0 or rng.random() < 0.35:
            return self.atom()
        roll = rng.random()
        if roll < 0.25:
            return f"not ({self.condition(depth - 1)})"
        op = "and" if roll < 0.65 else "or"
        return f"({self.condition(depth - 1)}) {op} ({self.condition(depth - 1)})"


def make_case(seed: int) -> Case:
    rng = random.Random(seed)
    maker = SpecMaker(rng)
    lines = [f"system diff{seed}", "ros humble"]
    topics, variables = {}, {}
    # Declared rates from a generator of their own: the other choices stay as they were.
    rated = random.Random(seed + 10**6)
    for index in range(rng.randint(2, 4)):
        kind = rng.choice(sorted(ROS_TYPES))
        ros_name = f"/t{index}"
        topics[ros_name] = kind
        qos = f" qos {{ max_rate = {rated.choice(['2Hz', '4Hz', '0.5Hz'])} }}"
        lines.append(f'topic t{index}: std_msgs/{kind} = "{ros_name}"'
                     + (qos if rated.random() < 0.3 else ""))  # fmt: skip
        lines.append(f"var V{index} = t{index}.data")
        maker.kinds[f"V{index}"] = kind
        variables[f"V{index}"] = ros_name
    numeric = sorted(v for v, k in maker.kinds.items() if k in ("Int32", "Float64"))
    if numeric and rng.random() < 0.4:
        function = rng.choice(["max", "min", "mean", "count", "last", "integral"])
        interval = rng.choice(["500ms", "1s"])
        lines.append(f"event W = {function}({rng.choice(numeric)}) group by time({interval})")
        maker.windowed.append("W")
    for index in range(rng.randint(2, 4)):
        lines.append(f"event E{index} when {maker.condition(2)}")
        maker.events.append(f"E{index}")
    states = [f"S{i}" for i in range(rng.randint(2, 3))]
    transitions = []
    for _ in range(rng.randint(2, 4)):
        source, dest = rng.choice(states), rng.choice(states)
        transitions.append(f"    {source} -> {dest} on {rng.choice(maker.events)}")
    lines += ["transducer T {", f"    states {', '.join(states)}", "    initial S0"]
    lines += [*sorted(set(transitions)), "}"]
    names = [*maker.events, *states]
    for index in range(rng.randint(1, 3)):
        a, b = rng.choice(names), rng.choice(names)
        formula = rng.choice([
            f"not ({a} and {b})", f"always[<=1s] not {a}", f"{a} -> {b}", f"not {a}",
            f"eventually[<=1s] {a}", f"duration[1s]({a}) < 0.5s", f"{a} or not {b}",
            f"{a} -> once {b}", f"historically not {a}", f"{a} since {b}",
        ])  # fmt: skip
        settings = []
        if rng.random() < 0.2:
            settings.append(f"rate = {rng.choice(['10Hz', '4Hz'])}")
        if rng.random() < 0.2:
            settings.append(f"trigger = {rng.choice(names)}")
        block = "".join(f"\n    {line}" for line in settings)
        block = f" {{{block}\n}}" if settings else ""
        lines.append(f"property P{index}: {formula}{block}")
    text = "\n".join(lines) + "\n"
    case = Case(seed, text, topics, variables)
    case.recordings = [make_recording(rng, topics) for _ in range(3)]
    return case


def make_recording(rng: random.Random, topics: dict[str, str]) -> list[tuple[int, str, Any]]:
    """Messages in time order (several may share an instant): each topic publishes
    from the start, late, or never, at times on a 0.1 s grid in [1 s, 4 s)."""
    messages = []
    for ros_name, kind in topics.items():
        mode = rng.random()
        if mode < 0.15:
            continue  # never published
        first = 10 if mode < 0.6 else rng.randint(11, 30)
        for tick in range(first, 40):
            if rng.random() < 0.5:
                value = rng.choice(EDGE_VALUES[kind])
                messages.append((tick * NS // 10, ros_name, {"data": value}))
    rng.shuffle(messages)
    messages.sort(key=lambda m: m[0])
    return messages


# ---- running and judging ----


def check_case(case: Case, folder: Path) -> Any:
    from rmvdsl.check import check

    path = folder / f"diff{case.seed}.rmv"
    path.write_text(case.text, encoding="utf-8")
    return check(str(path), use_environment=False)


def runnable_spec(case: Case, folder: Path) -> Any:
    """The case's spec lowered (`runnable`), or None where it has errors of its own."""
    result = check_case(case, folder)
    if any(e.code not in ANALYSIS_ERRORS for e in result.errors):
        return None
    return runnable(result)


def runnable(result: Any) -> Any:
    """A checked spec lowered without the analyses' own errors (a state never
    entered, ...): the claims under test, which leave a spec that runs."""
    from rmvdsl.ir import lower

    kept = [d for d in result.diagnostics if d.code not in ANALYSIS_ERRORS]
    return lower(dataclasses.replace(result, diagnostics=kept))


def write_recording(path: Path, kind: str, messages: list[tuple[int, str, Any]],
                    topics: dict[str, str]) -> Path:  # fmt: skip
    """A random case's messages (std_msgs), as a .bag, a .db3 or an .mcap."""
    from rosbags.rosbag1 import Writer as Bag1Writer
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Bag2Writer
    from rosbags.typesys import Stores, get_typestore

    ros1 = kind == "bag"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    types = {name: f"std_msgs/msg/{kind_}" for name, kind_ in topics.items()}

    def data(name: str, message: dict[str, Any]) -> bytes:
        made = store.types[types[name]](data=message["data"])
        if ros1:
            return store.serialize_ros1(made, types[name])
        return store.serialize_cdr(made, types[name])

    if ros1:
        target = path.with_suffix(".bag")
        with Bag1Writer(target) as writer:
            connections = {n: writer.add_connection(n, t, typestore=store, callerid="/player")
                           for n, t in types.items()}  # fmt: skip
            for t, name, message in messages:
                writer.write(connections[name], t, data(name, message))
        return target
    target = path.with_name(f"{path.name}_{kind}")
    plugin = StoragePlugin.SQLITE3 if kind == "db3" else StoragePlugin.MCAP
    with Bag2Writer(target, version=9, storage_plugin=plugin) as writer:
        connections = {n: writer.add_connection(n, t, typestore=store) for n, t in types.items()}
        for t, name, message in messages:
            writer.write(connections[name], t, data(name, message))
    return target


def run(
    spec: Any, messages: Iterable[tuple[int, str, Any]], end: int = 4 * NS, early: bool = True
) -> list[dict]:
    """The records of the runtime, started at 0.5 s (before any message) when
    `early`, else at the first message, as `rmv replay` starts."""
    from rmvdsl.runtime import engine

    runtime = engine.Runtime(spec)
    if early:
        runtime.start(NS // 2)
    for time, topic, message in messages:
        runtime.message(time, topic, message)
    runtime.end(end)
    return runtime.records()


def _named(message: str) -> list[str]:
    return re.findall(r"`([^`]+)`", message)


Segment = tuple[Fraction, bool, Fraction, bool]  # low, low closed, high, high closed


def _verdicts(records: list[dict], name: str) -> list[tuple[Segment, str]]:
    """The property's verdicts, points (`[]`) included."""
    return [
        ((r["from"], r["bounds"][0] == "[", r["to"], r["bounds"][1] == "]"), r["verdict"])
        for r in records
        if r["kind"] == "verdict" and r["property"] == name
    ]


def _during(records: list[dict], name: str, verdict: str) -> list[Segment]:
    return [segment for segment, value in _verdicts(records, name) if value == verdict]


def _intersect(first: list[Segment], second: list[Segment]) -> list[Segment]:
    out = []
    for a, a_closed, b, b_closed in first:
        for c, c_closed, d, d_closed in second:
            low = max(a, c)
            low_closed = (a_closed or a < c) and (c_closed or c < a)
            high = min(b, d)
            high_closed = (b_closed or b > d) and (d_closed or d > b)
            if low < high or (low == high and low_closed and high_closed):
                out.append((low, low_closed, high, high_closed))
    return out


def contradictions(case: Case, result: Any) -> list[str]:
    """Each claim of the check that a recording or a witness contradicts."""
    spec = runnable(result)
    runs = [run(spec, r, early=index > 0) for index, r in enumerate(case.recordings)]
    found = []
    for diagnostic in result.diagnostics:
        for problem in _judge(case, spec, diagnostic, runs):
            found.append(f"{diagnostic.code} ({diagnostic.message}): {problem}")
    return found + list(_property_witnesses(result))


def _property_witnesses(result: Any) -> Iterable[str]:
    """Each trace `rmv check --witnesses` would write, run through the runtime's
    monitor: the property has the verdict the checker says at the time it says."""
    from rmvdsl.runtime.rmtld3 import Monitor

    for name, facts in result.properties.facts.items() if result.properties else ():
        for verdict, answer in (("true", facts.satisfiable), ("false", facts.valid)):
            if (
                answer is None
                or answer.witness is None
                or (verdict == "true") != (answer.value == "yes")
            ):
                continue
            witness = answer.witness
            monitor = Monitor(facts.formula)
            for time, state in zip(witness.times, witness.states, strict=True):
                monitor.step(time, state)
            monitor.end(witness.end)
            found = _value_at([*monitor.verdicts(), *monitor.beyond()], witness.at)
            if found != verdict:
                yield f"the witness of `{name}` {verdict} at {witness.at} reads {found}"


def _value_at(segments: list[Any], at: Fraction) -> str:
    value = "unknown"
    for low, high, low_closed, high_closed, verdict in segments:
        if low < at < high or (at == low and low_closed) or (at == high and high_closed):
            value = verdict.split(" ")[0]
    return value


def _judge(case: Case, spec: Any, diagnostic: Any, runs: list[list[dict]]) -> Iterable[str]:
    code, names = diagnostic.code, _named(diagnostic.message)
    for index, records in enumerate(runs):
        if code == "RMV500":
            state = names[0]
            if any(r["kind"] == "state" and r["state"] == state for r in records):
                yield f"recording {index} enters `{state}`"
        elif code == "RMV502":
            event = names[0]
            if any(r["kind"] == "event" and r["name"] == event and r["value"] is True
                   for r in records):  # fmt: skip
                yield f"`{event}` holds in recording {index}"
        elif code in ("RMV510", "RMV511"):
            if _during(records, names[0], "true"):
                yield f"`{names[0]}` is true in recording {index}"
        elif code == "RMV512":
            if _during(records, names[0], "false"):
                yield f"`{names[0]}` is false in recording {index}"
        elif code == "RMV514":
            together = _during(records, names[0], "true")
            for other in names[1:]:
                together = _intersect(together, _during(records, other, "true"))
            if together:
                yield f"all true on {together[0]} in recording {index}"
        elif code == "RMV515":
            implied, others = names[0], names[1:]
            together = _during(records, others[0], "true")
            for other in others[1:]:
                together = _intersect(together, _during(records, other, "true"))
            if _intersect(together, _during(records, implied, "false")):
                yield f"`{implied}` false where the others hold, recording {index}"
    if code in ("RMV505", "RMV506"):
        yield from _replay_witness(case, spec, diagnostic)
    if code == "RMV513":
        yield from _antecedent(case, names[1])


def _antecedent(case: Case, antecedent: str) -> Iterable[str]:
    """RMV513: the antecedent, monitored as a property of its own on the same
    recordings, is never true."""

    with tempfile.TemporaryDirectory() as folder:
        extra = Case(case.seed, case.text + f"property Antecedent: {antecedent}\n",
                     case.topics, case.variables, case.recordings)  # fmt: skip
        result = check_case(extra, Path(folder))
    spec = runnable(result)
    for index, recording in enumerate(case.recordings):
        if _during(run(spec, recording, early=index > 0), "Antecedent", "true"):
            yield f"`{antecedent}` holds in recording {index}"


def _replay_witness(case: Case, spec: Any, diagnostic: Any) -> Iterable[str]:
    """The witness values, one message each at 1 s: the events as the runtime
    computes them must do what the claim says."""
    help_text = diagnostic.help or ""
    text = diagnostic.message if diagnostic.code == "RMV506" else help_text
    match = re.search(r"when (.*?)(?:;|$)", text)
    if match is None or "any values" in match.group(1):
        return
    values = _parse_values(match.group(1))
    if values is None:
        return
    messages = []
    for name, value in values.items():
        topic = case.variables.get(name)
        if topic is None:
            return
        if value is not None:
            if case.topics[topic] == "UInt64" and value < 0:
                value += 2**64  # the bytes of a uint64 that the runtime reads as `value`
            messages.append((NS, topic, {"data": value}))
    records = run(spec, messages, end=2 * NS)
    last: dict[str, Any] = {}
    for record in records:
        if record["kind"] == "event":
            last[record["name"]] = record["value"]
    holding = {name for name, value in last.items() if value is True}  # at the values
    names = _named(diagnostic.message)
    if diagnostic.code == "RMV505":
        pair = names[2:4]
        if not set(pair) <= holding:
            yield f"at {match.group(1)} only {sorted(holding & set(pair))} of {pair} hold"
    else:
        state = names[1]
        transducer = next(t for t in spec.transducers if state in t.states)
        inputs = {t.input for t in transducer.transitions if t.source == state}
        if inputs & holding:
            yield f"at {match.group(1)} `{sorted(inputs & holding)}` holds in `{state}`"


def _parse_values(text: str) -> dict[str, Any] | None:
    values: dict[str, Any] = {}
    for part in text.split(", "):
        absent = re.fullmatch(r"(\w+) has no value", part)
        if absent:
            values[absent.group(1)] = None
            continue
        pair = re.fullmatch(r"(\w+) = (.+)", part)
        if pair is None:
            return None
        raw = pair.group(2)
        if raw in ("true", "false", "True", "False"):
            values[pair.group(1)] = raw.lower() == "true"
        elif raw == "NaN":
            values[pair.group(1)] = math.nan
        elif re.fullmatch(r"-?\d+", raw):
            values[pair.group(1)] = int(raw)
        else:
            try:
                values[pair.group(1)] = float(raw)
            except ValueError:
                return None
    return values


ANALYSIS_ERRORS = frozenset({"RMV500", "RMV505", "RMV510", "RMV511", "RMV514"})


@dataclass
class Outcome:
    seed: int
    checked: bool  # the spec had no errors of its own
    claims: int
    problems: list[str]


CLAIMS = frozenset({"RMV500", "RMV502", "RMV505", "RMV506", "RMV510", "RMV511", "RMV512",
                    "RMV513", "RMV514", "RMV515"})  # fmt: skip


def examine(seed: int, folder: Path) -> Outcome:
    case = make_case(seed)
    result = check_case(case, folder)
    own_errors = [d for d in result.errors if d.code not in ANALYSIS_ERRORS]
    if own_errors:
        return Outcome(seed, False, 0, [])
    claims = sum(1 for d in result.diagnostics if d.code in CLAIMS)
    facts = result.properties.facts.values() if result.properties else ()
    claims += sum(1 for f in facts for a in (f.satisfiable, f.valid) if a and a.witness)
    return Outcome(seed, True, claims, contradictions(case, result))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=200, help="how many seeds, from --first")
    parser.add_argument("--long", action="store_true", help="the long run: 10,000 seeds")
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--seed", type=int, help="one seed only")
    parser.add_argument("--show", action="store_true", help="print each spec and its findings")
    args = parser.parse_args(argv)
    if args.long:
        args.seeds = 10_000
    seeds = [args.seed] if args.seed is not None else range(args.first, args.first + args.seeds)
    failed, checked, claims = [], 0, 0
    with tempfile.TemporaryDirectory() as folder:
        for done, seed in enumerate(seeds, 1):
            outcome = examine(seed, Path(folder))
            checked += outcome.checked
            claims += outcome.claims
            if outcome.problems:
                failed.append(outcome)
            if args.show or outcome.problems:
                print(f"--- seed {seed}\n{make_case(seed).text}", *outcome.problems, sep="\n")
            if done % 100 == 0:
                print(f"{done} seeds, {checked} without errors, {claims} claims, "
                      f"{len(failed)} contradicted", file=sys.stderr)  # fmt: skip
    print(f"{len(seeds)} seeds: {checked} specs checked, {claims} claims tested, "
          f"{len(failed)} specs contradicted")  # fmt: skip
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
