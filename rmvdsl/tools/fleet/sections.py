"""`--chunk`: a long recording replayed in time chunks, each by a run of its own that
starts a lead-in before the chunk, the chunks' records joined into exactly what one
run over the whole recording gives (docs/fleet.md, "Long recordings").

A run that starts late can differ from the whole run: a transducer's state, a
variable last published long ago, a cumulative sum remember further back than any
lead-in. So each chunk's run notes its state's key where it enters its chunk
(rmvdsl.runtime.seams), and the run before notes its key where it leaves. Where the
two are equal, the later run continues the earlier one exactly. Where they are not,
the earlier run reads on (from where it started), past that seam and on to the first
later seam whose key it meets; its records stand in for the chunks it read through.
Nothing is ever guessed: the worst case reads the recording once more, in one run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rmvdsl.runtime import seams
from rmvdsl.runtime.engine import Runtime, to_json
from rmvdsl.runtime.records import Record, seconds
from rmvdsl.runtime.reporting import unread
from rmvdsl.tools.replay import Position

Key = str | None


@dataclass(frozen=True)
class Section:
    """A run over part of a recording: it reads from `read_from` (ns, the recording's
    clock), keeps its records from the seam `begin` (None: from the start) and
    stops at the first of `seams` where its key equals the one in `keys` (no keys:
    at the first seam; no seams: at the end of the recording)."""

    read_from: int | None
    begin: int | None
    seams: tuple[int, ...] = ()
    keys: tuple[Key, ...] = ()


@dataclass(frozen=True)
class Job:
    """What a worker is given: a recording, or a section of one."""

    path: str
    section: Section | None = None


def plan(
    path: str, spec: Any, chunk: int, start: str | None, stop: str | None,
    lead: int | None = None,
) -> list[Section]:  # fmt: skip
    """The sections of one recording, first wave: one per chunk of `chunk` ns (none
    when the recording is not longer than that, or cannot be opened: the whole run
    then reports it). `lead`: the lead-in, by default the spec's (any is exact)."""
    from rmvdsl.tools.recordings import open_reader, window_time

    try:
        reader = open_reader([Path(path)], spec)
    except Exception:
        return []
    try:
        low = window_time(start, reader.start_time) or reader.start_time
        high = window_time(stop, reader.start_time) or reader.end_time
    except (ValueError, ZeroDivisionError):
        return []  # the whole run says what is wrong with the window
    finally:
        reader.close()
    span = high - low
    if span <= chunk:
        return []
    count = math.ceil(span / chunk)
    cuts = [low + span * i // count for i in range(1, count)]
    lead = seams.lead_in(spec) if lead is None else lead
    sections = [Section(None, None, (cuts[0],))]
    for i, cut in enumerate(cuts):
        following = (cuts[i + 1],) if i + 1 < len(cuts) else ()
        sections.append(Section(max(low, cut - lead), cut, following))
    return sections


@dataclass
class _Run:
    """What a section's run collects, as its records come."""

    section: Section
    kept: bool = False
    texts: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(
        ("violations", "intrusions", "warnings"), 0))  # fmt: skip
    heads: dict[str, tuple[int, Record]] = field(default_factory=dict)
    enter: dict[str, Any] = field(default_factory=dict)
    leave: dict[str, Any] | None = None
    counters: dict[str, int] = field(default_factory=dict)

    def at_seam(self, time: int, runtime: Runtime, endpoints: set[Any], at: Position) -> bool:
        section = self.section
        if time == section.begin and not self.kept:
            self.kept = True
            self.enter = self._seam(time, runtime, endpoints, at)
            return False
        seam = self._seam(time, runtime, endpoints, at)
        index = section.seams.index(time)
        if section.keys and (seam["key"] is None or seam["key"] != section.keys[index]):
            return False
        self.leave = seam
        return True

    def _seam(
        self, time: int, runtime: Runtime, endpoints: set[Any], at: Position
    ) -> dict[str, Any]:
        return {
            "time": time, "key": seams.seam_key(runtime, endpoints),
            "pending": seams.pending_starts(runtime), "counters": dict(runtime.counters),
            "messages": at.fed, "read": at.read,
        }  # fmt: skip

    def add(self, record: Record) -> None:
        if not self.kept:
            return
        kind = record["kind"]
        if kind == "counter":  # the whole run's: the join adds up every section's
            self.counters[record["name"]] = record["value"]
            return
        if kind == "verdict" and record["property"] in self.enter.get("pending", {}):
            self.heads.setdefault(record["property"], (len(self.texts), record))
        tally(self.counts, self.texts, record)


def status_of(counts: dict[str, int]) -> str:
    if counts["violations"]:
        return "violations"
    if counts["intrusions"]:
        return "intrusions"
    return "incomplete" if counts["warnings"] else "pass"


def tally(counts: dict[str, int], texts: list[str], record: Record) -> None:
    """A record of a recording's result: counted where it decides the status, and
    kept as JSON (a variable's values are the report's alone)."""
    kind = record["kind"]
    if kind == "verdict" and record["verdict"] == "false":
        counts["violations"] += 1
    elif kind == "intrusion" and record["phase"] == "start":
        counts["intrusions"] += 1
    elif kind == "diagnostic":
        counts["warnings"] += 1
    if kind != "variable":
        texts.append(to_json(record))


def replay_section(spec: Any, path: str, section: Section, run_options: dict[str, Any],
                   read: list[int]) -> dict[str, Any]:  # fmt: skip
    """One section's run: its records between its seams, and what the join needs."""
    from rmvdsl.tools import replay

    run = _Run(section, kept=section.begin is None)
    order = ((section.begin,) if section.begin is not None else ()) + section.seams
    ended: dict[str, int] = {}
    for record in replay.replay(spec, [Path(path)], read_from=section.read_from, seams=order,
                                at_seam=run.at_seam, ended=ended, **run_options):  # fmt: skip
        run.add(record)
    entered = run.enter.get("counters", {})
    if run.leave is not None:
        after, messages, read_to = run.leave["counters"], run.leave["messages"], run.leave["read"]
    else:
        after, messages, read_to = run.counters, read[0], ended["read"]
    return {
        "texts": run.texts, "counts": run.counts, "heads": run.heads,
        "enter": run.enter, "leave": run.leave, "ended": ended,
        "counters": {k: v - entered.get(k, 0) for k, v in after.items()},
        "section_messages": messages - run.enter.get("messages", 0),
        "section_read": read_to - run.enter.get("read", 0),
    }  # fmt: skip


class Joined:
    """One recording's sections, joined as their results come: `add` a section's
    result; it returns the jobs to run next (a run reading on past a seam whose keys
    differ), and `result` is set when the recording is whole."""

    def __init__(self, path: str, sections: list[Section], windowed: bool = False) -> None:
        self.path = path
        self.sections = sections
        self.windowed = windowed  # read in a --from/--to window: its count is not listed
        self.first: list[dict[str, Any] | None] = [None] * len(sections)
        # Joined so far, in order: each run's section and its part of the result.
        self.pieces: list[tuple[Section, dict[str, Any]]] = []
        self.reading: Job | None = None  # a run reading on, not back yet
        self.joined = 0  # seams joined by equal keys
        self.result: dict[str, Any] | None = None
        self.seconds = 0.0

    def add(self, job: Job, result: dict[str, Any]) -> list[Job]:
        self.seconds += result["seconds"]
        if self.result is not None:
            return []
        if result["status"] in ("unreadable", "failed"):
            self.result = {**result, "path": self.path, "seconds": round(self.seconds, 3)}
            return []
        assert job.section is not None
        if job is self.reading:
            self.reading = None
            self.pieces.append((job.section, result["section"]))
        else:
            self.first[self.sections.index(job.section)] = result["section"]
        return self._advance()

    def _advance(self) -> list[Job]:
        """Join what can be joined; a job when a seam's keys differ."""
        if self.reading is not None:
            return []
        if not self.pieces:
            if self.first[0] is None:
                return []
            self.pieces.append((self.sections[0], self.first[0]))
        while True:
            leave = self.pieces[-1][1]["leave"]
            if leave is None:
                self.result = self._joined()
                return []
            index = next(i for i, s in enumerate(self.sections) if s.begin == leave["time"])
            if any(part is None for part in self.first[index:]):
                return []  # every later key is needed to know where reading on can stop
            following = self.first[index]
            assert following is not None
            if leave["key"] is not None and leave["key"] == following["enter"]["key"]:
                self.pieces.append((self.sections[index], following))
                self.joined += 1
                continue
            self.reading = Job(self.path, self._reading_on(index))
            return [self.reading]

    def _reading_on(self, index: int) -> Section:
        """The last piece's run again, from where it started, kept from the seam of
        section `index` and stopping at the first later seam whose key it meets."""
        later = range(index + 1, len(self.sections))
        return Section(
            self.pieces[-1][0].read_from, self.sections[index].begin,
            tuple(self.sections[i].begin for i in later),  # type: ignore[misc]
            tuple(self.first[i]["enter"]["key"] for i in later),  # type: ignore[index]
        )  # fmt: skip

    def _joined(self) -> dict[str, Any]:
        """The pieces as one result: each piece's first verdict of a property whose
        segment was open where it entered starts where the run before had it start."""
        texts: list[str] = []
        counts = dict.fromkeys(("violations", "intrusions", "warnings"), 0)
        counters: dict[str, int] = {}
        messages = 0
        carried: dict[str, tuple[Any, bool]] = {}
        for _, piece in self.pieces:
            patched = list(piece["texts"])
            for name, (index, record) in piece["heads"].items():
                if name in carried:
                    start, closed = carried[name]
                    record = {
                        **record,
                        "from": start,
                        "bounds": ("[" if closed else "(") + record["bounds"][1],
                    }
                    patched[index] = to_json(record)
            texts.extend(patched)
            for name in counts:
                counts[name] += piece["counts"][name]
            for name, value in piece["counters"].items():
                counters[name] = counters.get(name, 0) + value
            messages += piece["section_messages"]
            if piece["leave"] is not None:
                # An open segment the piece gave no record of is the one it entered with.
                carried = {
                    name: start if name in piece["heads"] or name not in carried
                    else carried[name]
                    for name, start in piece["leave"]["pending"].items()
                }  # fmt: skip
        self._check_count(texts, counts, counters)
        texts.extend(to_json({"kind": "counter", "name": name, "value": value})
                     for name, value in sorted(counters.items()))  # fmt: skip
        seams_read_past = len(self.sections) - 1 - self.joined
        return {"path": self.path, "status": status_of(counts), **counts, "messages": messages,
                "seconds": round(self.seconds, 3), "records": texts,
                "chunks": len(self.sections), "seams_read_past": seams_read_past}  # fmt: skip

    def _check_count(self, texts: list[str], counts: dict[str, int],
                     counters: dict[str, int]) -> None:  # fmt: skip
        """What one run over the whole recording says when the recording gave other
        than it lists (rmvdsl.tools.replay), said of the chunks' reads added up."""
        ended = self.pieces[-1][1]["ended"]
        read = sum(piece["section_read"] for _, piece in self.pieces)
        if read == ended["listed"] or self.windowed:
            return
        counter, text = unread(ended["listed"], read)
        counters[counter] = counters.get(counter, 0) + abs(ended["listed"] - read)
        texts.append(to_json({"kind": "diagnostic", "time": seconds(ended["end"]),
                              "origin": "", "message": text}))  # fmt: skip
        counts["warnings"] += 1
