"""The streamed trace reader of `rmv eval` against the whole-file reader, on random
JSON Lines of any shape: keys in any order, extra fields, ints, floats, exact
quotients, times a float cannot hold, blank lines, bad lines, chunks cut anywhere."""

from __future__ import annotations

import io
import json
import threading
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rmvdsl.logic import trace_chunks, traces
from rmvdsl.logic.trace_chunks import scaled
from rmvdsl.logic.trace_lines import TraceError, read_trace
from rmvdsl.logic.traces import TraceStream

NAMES = st.sampled_from(["A", "B", "Brake_2", "x^{1}"])
BAD_NAMES = st.sampled_from(["A B", "", "A\n"])
TIMES = st.one_of(
    st.integers(-3, 40).map(str),
    st.integers(0, 4000).map(lambda k: f"{k / 100:.2f}"),
    st.sampled_from(["0.1000000000000000055", "1e1", "2.5E-1", '"1/3"', '"7"', "true", "-0.0"]),
    # times `exact` refuses (more than 100 digits, a magnitude out of 10^+-300),
    # some of which a float holds
    st.sampled_from(["1e305", "-1e305", "1e-400", "1e-305", "0e-500", "1." + "1" * 150]),
)


# Lines that are no record, or not one: msgspec reads `{...} "x"` as two values, and
# an object may span two lines.
ODD = ["", "  ", "{", "[]", '{"unit": "ms"}', '{"t": 99, "state": "A"}"end": true}',
       '{"t": 99, "state": "A"} {"t": 100, "state": "B"}', '{"t": 99,\n"state": "A"}',
       '{"t": 99, "state": "A"}, {"t": 100, "state": "B"}']  # fmt: skip


@st.composite
def records(draw: st.DrawFn, time: str, messy: bool, plain: str) -> str:
    kinds = [plain] * 5 + ["state", "props"] + (["end", "both", "none"] if messy else [])
    kind = draw(st.sampled_from(kinds))
    names = st.one_of(NAMES, BAD_NAMES) if messy else NAMES
    items = [("t", time)]
    if kind in ("state", "both"):
        items.append(("state", json.dumps(draw(names))))
    if kind in ("props", "both"):
        items.append(("props", json.dumps(draw(st.lists(names, max_size=3)))))
    if kind == "end":
        items.append(("end", "true"))
    for extra in draw(st.lists(st.sampled_from(["seq", "topic", "v", "unit"]), max_size=1)):
        items.append((extra, draw(st.sampled_from(["1", '"x"', "12.345678901234567", "[1]"]))))
    order = draw(st.permutations(items))
    return "{" + ", ".join(f'"{key}": {value}' for key, value in order) + "}"


@st.composite
def traces_text(draw: st.DrawFn) -> str:
    """Increasing times written as a logger might, most lines naming a `state` or
    most naming `props` (each a shape the reader takes a chunk at a time), a unit
    record first or not; in one trace of three, lines of every other kind among them."""
    lines = list(draw(st.sampled_from([(), (), ('{"unit": "ms"}',), ("", '{"unit": "s"}')])))
    hundredths, messy = 0, draw(st.integers(0, 2)) == 0
    plain = draw(st.sampled_from(["state", "props"]))
    for _ in range(draw(st.integers(1, 60))):
        hundredths += draw(st.sampled_from([1, 7, 100] + ([0, -3] if messy else [])))
        plain = f"{hundredths / 100:.2f}" if hundredths % 100 else str(hundredths // 100)
        time = draw(TIMES) if messy and draw(st.integers(0, 9)) == 0 else plain
        odd = messy and draw(st.integers(0, 9)) == 0
        line = draw(st.sampled_from(ODD)) if odd else draw(records(time, messy, plain))
        lines.append(line)
    if draw(st.booleans()):  # an end record, as most traces have, and lines after it or not
        lines.append(f'{{"t": {hundredths / 100 + 1}, "end": true}}')
        lines.extend(
            draw(st.lists(st.sampled_from([*ODD, '{"t": 1000, "state": "A"}']), max_size=2))
        )
    return "\n".join(lines) + draw(st.sampled_from(["\n", "", "\n\n"]))


def whole(text: str, path: str = "t.jsonl") -> tuple[str, object]:
    try:
        trace = read_trace(path, text)
    except TraceError as error:
        return "error", (error.line, error.args[0])
    changes, current = [], None
    for t, state in zip(trace.times, trace.states, strict=True):
        if state != current:
            changes.append((scaled(t), state))
            current = state
    return "ok", (changes, trace.end, trace.notes)


def streamed(text: str, path: str = "t.jsonl") -> tuple[str, object]:
    stream = TraceStream(path, io.BytesIO(text.encode()))
    try:
        changes = list(stream.changes())
    except TraceError as error:
        return "error", (error.line, error.args[0])
    return "ok", (changes, stream.end, stream.notes)


@settings(max_examples=150, deadline=None)
@given(text=traces_text(), chunk=st.integers(16, 400))
def test_the_stream_reads_what_the_whole_file_reader_reads(text, chunk):
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(traces, "CHUNK", chunk)
        assert streamed(text) == whole(text)


def test_a_time_no_float_holds_stays_exact():
    text = '{"t": 0.1000000000000000055, "state": "A"}\n{"t": 0.2, "state": "B"}\n'
    changes = list(TraceStream("t.jsonl", io.BytesIO(text.encode())).changes())
    assert changes[0][0] == Fraction("0.1000000000000000055") * 10**9
    assert changes[1][0] == 200_000_000


EPOCH = st.integers(0, 10**12).map(lambda k: f"{1_700_000_000 + k / 10**6:.6f}")
LONG_TIMES = st.one_of(
    EPOCH,  # 16 digits: a logger's Unix time in microseconds
    st.integers(0, 10**21).map(lambda k: f"1700000000.{k:021d}"),  # floats tie these
    st.integers(1, 10**6).map(lambda k: f"{k}e-3"),
    st.integers(1, 10**6).map(lambda k: f"{k}.0E2"),
)


STRING_TIMES = st.one_of(
    st.integers(0, 10**6).map(lambda k: f'"{k / 100:.2f}"'),
    st.integers(1, 10**4).map(lambda k: f'"{k}/3"'),
    st.integers(0, 10**4).map(lambda k: f'" {k}.5 "'),
    st.sampled_from(['"x"', '"nan"', '""', '"1/0"', '"1e400"', '"12"']),
)


@settings(max_examples=300, deadline=None)
@given(
    times=st.lists(st.one_of(LONG_TIMES, STRING_TIMES), min_size=1, max_size=40),
    names=st.lists(st.sampled_from(["A", "B"]), min_size=40, max_size=40),
    chunk=st.integers(16, 400),
)
def test_times_of_any_writing_are_read_exactly(times, names, chunk):
    """Times of 16 and more digits or with an exponent (two of them may be one
    float), decimals and quotients in strings, and strings that are no time, in
    increasing order: the stream reads (or refuses) them as the whole-file reader
    does, the change points exact."""

    def order(text: str) -> tuple[int, Fraction]:
        try:
            return 0, Fraction(text.strip('"').strip())
        except (ValueError, ZeroDivisionError):
            return 1, Fraction(0)  # no time: last, to be refused

    ordered = sorted(set(times), key=order)
    text = "".join(
        f'{{"t": {t}, "state": "{name}"}}\n' for t, name in zip(ordered, names, strict=False)
    )
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(traces, "CHUNK", chunk)
        assert streamed(text) == whole(text)


def test_a_chunk_of_times_written_as_strings_is_decoded_at_once():
    lines = "".join(f'{{"t": "{k / 4}", "state": "{"AB"[k // 3 % 2]}"}}\n' for k in range(30))
    decoded = trace_chunks.ChunkDecoder(traces.LineReader("t.jsonl")).decode(lines, 30, 0)
    assert decoded is not None and decoded[2] == [k / 4 for k in range(30)]
    assert streamed(lines) == whole(lines)


def test_a_logger_s_unix_times_are_decoded_a_chunk_at_a_time():
    """Unix times in microseconds (16 digits) take the fast path, exactly."""
    lines = "".join(
        f'{{"t": 1700000000.{k:06d}, "state": "{"AB"[k // 3 % 2]}"}}\n' for k in range(30)
    )
    decoded = trace_chunks.ChunkDecoder(traces.LineReader("t.jsonl")).decode(lines, 30, 0)
    assert decoded is not None and decoded[0] == "state"
    changes = streamed(lines)[1][0]  # type: ignore[index]
    assert [t for t, _ in changes] == [
        Fraction(f"1700000000.{k:06d}") * 10**9 for k in range(0, 30, 3)
    ]


@pytest.mark.parametrize("plain", ['"state": "A"', '"props": ["A"]'])
@pytest.mark.parametrize("blank", [False, True])
def test_plain_lines_before_a_record_of_another_shape_are_decoded_at_once(plain, blank):
    """Plain samples, then the end record (or a sample of the other shape): the
    decoder gives how many records came first, and the stream reads those at once,
    that line by record and on, as the whole-file reader reads the lines."""
    other = '"props": ["B"]' if plain.startswith('"state"') else '"state": "B"'
    rows = [f'{{"t": {k}, {plain if k % 7 else other}}}' for k in range(1, 30)]
    text = "\n".join([*rows, *([""] if blank else []), '{"t": 30, "end": true}', ""])
    decoder = trace_chunks.ChunkDecoder(traces.LineReader("t.jsonl"))
    decoded = decoder.decode(text, text.count("\n"), 0)
    assert decoded == 6  # the 7th record names its state the other way
    assert streamed(text) == whole(text)
    assert streamed(text)[1][1] == 30  # type: ignore[index]


@pytest.mark.parametrize(
    "text",
    [  # found by the fuzzer: it hung `rmv eval` (the split read the same lines again)
        '{"t": 0, "state": "a"}\n{"t": 1.5, "state": "b"}"end": trueend": true}\n',
        '{"t": 0, "state": "a"}\n{"t": 1, "state": "b"} {"t": 2, "end": true}\n',
        '{"t": 0, "state": "a"}\n{"t": 1, "state": "b"}\n{"t": 2,\n"end": true}\n{"t": 3}\n',
        '{"t": 0, "state": "a"} {"t": 1, "state": "b"}\n{"t": 2, "end": true}\n',
        # as many values as lines: read at once, these were taken, where the full
        # reader refuses them
        '{"t": 0, "state": "a"} {"t": 1, "state": "b"}\n{"t": 2,\n"state": "a"}\n'
        '{"t": 3, "end": true}\n',
        '{"t": 0, "state": "a"} {"t": 1, "state": "b"}\n\n{"t": 3, "end": true}\n',
        '{"t": 0, "state": "a"}\r\n {"t": 1, "state": "b"} \r\n{"t": 3, "end": true}',
        # two items of the chunk's array on a line, before and after the odd record
        '{"t": 0, "state": "a"}\n{"t": 1, "props": ["b"]}, {"t": 2, "state": "a"}\n'
        '{"t": 3, "end": true}\n',
        '{"t": 0, "state": "a"}, {"t": 1, "state": "b"}\n{"t": 2, "end": true}\n\n',
    ],
)
def test_records_that_are_not_lines_are_the_full_reader_s(text):
    """Plain samples, then values that are not one a line: the stream ends, as the
    whole-file reader does (here, with its error)."""
    results: list[object] = []
    worker = threading.Thread(target=lambda: results.append(streamed(text)), daemon=True)
    worker.start()
    worker.join(timeout=20)
    assert results, "the stream did not end"
    assert results[0] == whole(text)


def test_lines_of_both_shapes_in_one_chunk_keep_each_lines_state():
    """A chunk mixing `state` and `props` lines is read a record at a time: each
    line's state is its own, also when one `props` list begins as another does."""
    shapes = ['"state": "A"', '"props": ["A"]', '"props": ["A", "B"]', '"props": []',
              '"props": ["B", "A"]', '"state": "B"']  # fmt: skip
    text = "".join(f'{{"t": {k}, {shapes[(k * 5) % len(shapes)]}}}\n' for k in range(200))
    assert streamed(text) == whole(text)
    changes = streamed(text)[1][0]  # type: ignore[index]
    assert {state for _, state in changes} == {
        frozenset("A"),
        frozenset("AB"),
        frozenset(),
        frozenset("B"),
    }


CSV_NAMES = st.sampled_from(["A", "B", "Brake_2", "x^{1}", "", " A "])
# Times written otherwise: each as the full reader reads it, or refuses it.
CSV_TIMES = ["1/3", "1e1", ".5", "5.", "-0", "007", "-.25", "1-2", "1.2.3", "-", "", "+1",
             "1" + "0" * 320, "1." + "1" * 150, "nan", "1_0"]  # fmt: skip
BAD_CSV_NAMES = st.sampled_from(["A B", "1x"])


@st.composite
def csv_text(draw: st.DrawFn) -> str:
    """A CSV trace under a header of t and state or props (or both), with or
    without an end column, the columns in any order; in one trace of three, rows
    written otherwise among them (quoted, blank, a quotient, a name that is no
    proposition, a time not above the last, the end row)."""
    messy = draw(st.integers(0, 2)) == 0
    names = st.one_of(CSV_NAMES, BAD_CSV_NAMES) if messy else CSV_NAMES
    named = draw(st.sampled_from([["state"], ["props"], ["state", "props"]]))
    columns = draw(st.permutations(["t", *named, *draw(st.sampled_from([[], ["end"]]))]))
    lines, hundredths = [",".join(columns)], 0
    for _ in range(draw(st.integers(1, 50))):
        hundredths += draw(st.sampled_from([1, 7, 100] + ([0, -3] if messy else [])))
        time = f"{hundredths / 100:.2f}" if hundredths % 100 else str(hundredths // 100)
        if messy and draw(st.integers(0, 9)) == 0:
            time = draw(st.sampled_from([*CSV_TIMES, f" {time} ", f"{time}\t"]))
        end = draw(st.sampled_from(["", "", "", "true", "false"])) if messy else ""
        props = draw(st.lists(names, max_size=3))
        joined = draw(st.sampled_from([";", " ; "])).join(props)
        if messy and draw(st.booleans()):
            joined = f'"{joined}"'
        cells = {"t": time, "end": end, "state": draw(names), "props": joined}
        line = ",".join(cells[column] for column in columns)
        if messy and draw(st.integers(0, 14)) == 0:  # a row short of a cell, or one long
            line = draw(st.sampled_from([line.rpartition(",")[0], line + ",7"]))
        odd = messy and draw(st.integers(0, 9)) == 0
        lines.append(draw(st.sampled_from(["", line + "\r"])) if odd else line)
    return "\n".join(lines) + "\n"


@settings(max_examples=200, deadline=None)
@given(text=csv_text(), chunk=st.integers(16, 400))
def test_a_csv_stream_reads_what_the_whole_file_reader_reads(text, chunk):
    """Every header order is read a chunk at a time where its rows allow it, with
    the same changes, end, notes and errors as the whole-file reader."""

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(traces, "CHUNK", chunk)
        assert streamed(text, "t.csv") == whole(text, "t.csv")


@pytest.mark.parametrize("text", ["t,state\n\n,A\n", "t,state\n,A\n", "state,t\nA,\n"])
def test_a_csv_row_with_no_time_is_explained_as_the_whole_file_reader_explains_it(text):
    """A row whose time cell is empty, alone in its run: its one empty text read as
    an empty list of times, and the stream stopped on an IndexError (found by the
    random test above)."""
    assert streamed(text, "t.csv") == whole(text, "t.csv")


def _csv_row(columns: list[str], k: int) -> str:
    cells = {"t": f"{k / 10:.1f}", "state": "AB"[k // 3 % 2], "props": "A;B"[: 1 + k % 2 * 2]}
    return ",".join(cells.get(column, "") for column in columns)


@pytest.mark.parametrize(
    "header", ["t,state", "state,t", "t,props", "props,end,t", "state,props,t"]
)
def test_every_csv_header_is_read_a_chunk_at_a_time(header):
    """The rows of any header order take the fast path: the full reader reads the
    header alone, and a blank line and the end row, not the rows around them."""
    columns = header.split(",")
    rows = [_csv_row(columns, k) for k in range(60)]
    end = [",".join({"t": "6", "end": "true"}.get(c, "") for c in columns)]
    lines = [header, *rows[:30], "", *rows[30:], *(end if "end" in columns else [])]
    text = "\n".join(lines) + "\n"
    stream = TraceStream("t.csv", io.BytesIO(text.encode()))
    read_alone: list[int] = []
    full_line = stream._full_line

    def counted(number: int, raw: str):  # type: ignore[no-untyped-def]
        read_alone.append(number)
        return full_line(number, raw)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(stream, "_full_line", counted)
        list(stream.changes())
    assert read_alone == [1, 32, *([63] if "end" in columns else [])]
    assert stream.samples == 60 and stream.end == (6 if "end" in columns else Fraction(59, 10))


LONG = "1." + "1" * 150  # 151 digits: more than `exact` reads, a float holds it
REFUSED_JSONL = [
    '{"t": 0, "state": "A"}\n{"t": 1e305, "state": "A"}\n',  # the last time
    '{"t": 0, "state": "A"}\n{"t": 1e305, "state": "A"}\n{"t": 1e306, "state": "B"}\n',
    '{"t": -1, "state": "A"}\n{"t": 1e-400, "state": "A"}\n{"t": 2, "state": "A"}\n',
    '{"t": -1, "state": "A"}\n{"t": 1e-305, "state": "A"}\n{"t": 2, "state": "A"}\n',
    '{"t": 0, "state": "A"}\n{"t": 0.5, "state": "A"}\n{"t": ' + LONG + ', "state": "A"}\n'
    '{"t": 2, "state": "B"}\n',
    '{"t": 0, "props": ["A"]}\n{"t": 0.5, "state": "A", "v": 1}\n{"t": 1e-400, "state": "A"}\n'
    '{"t": 1, "state": "A"}\n',  # records taken one at a time
]
REFUSED_CSV = [
    f"t,state\n0,A\n0.5,A\n{LONG},A\n2,B\n",
    "t,state\n0,A\n1" + "0" * 320 + ",A\n",
    # a short row and a long one: the cells of the rows after would shift into place
    "t,state,props\n0,A,p\n1,A\n5,2,B,q\n3,A,r\n",
]


@pytest.mark.parametrize("text", REFUSED_JSONL + REFUSED_CSV)
@pytest.mark.parametrize("chunk", [1 << 20, 30])
def test_a_time_or_row_the_full_reader_refuses_is_refused_where_it_stands(text, chunk):
    """What the fast paths would read (a float holds the time, the cells fall into
    columns) but the full reader refuses gets the full reader's error, at its line:
    never taken silently, never an internal error."""
    path = "t.csv" if text.startswith("t,") else "t.jsonl"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(traces, "CHUNK", chunk)
        expected = whole(text, path)
        assert expected[0] == "error"
        assert streamed(text, path) == expected
