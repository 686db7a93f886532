"""`rmv lsp` end to end through a real client (pytest-lsp over stdio), in the
position encodings a client may negotiate: UTF-16 (the default) and UTF-8."""

from __future__ import annotations

import asyncio
import random
import time
from pathlib import Path

import pytest
import pytest_lsp
from conftest import EXAMPLES, RMV, ROOT
from lsprotocol import types
from pytest_lsp import ClientServerConfig, LanguageClient

from rmvdsl.editor.workspace import Workspace, formatted

ENCODINGS = [types.PositionEncodingKind.Utf16, types.PositionEncodingKind.Utf8]
WAIT = 120.0  # seconds for a check, solver stages included, on a loaded machine


@pytest_lsp.fixture(
    config=ClientServerConfig(server_command=[*RMV, "lsp"]),
    params=ENCODINGS,
)
async def client(lsp_client: LanguageClient, request: pytest.FixtureRequest):
    capabilities = pytest_lsp.client_capabilities("visual-studio-code")
    capabilities.general = types.GeneralClientCapabilities(position_encodings=[request.param])
    answer = await lsp_client.initialize_session(
        types.InitializeParams(capabilities=capabilities, root_uri=ROOT.as_uri())
    )
    assert answer.capabilities.position_encoding == request.param
    lsp_client.encoding = request.param  # type: ignore[attr-defined]
    lsp_client.server_capabilities = answer.capabilities  # type: ignore[attr-defined]
    yield
    await lsp_client.shutdown_session()


def _open(client: LanguageClient, path: Path, text: str | None = None) -> str:
    uri = path.resolve().as_uri()
    client.text_document_did_open(
        types.DidOpenTextDocumentParams(
            types.TextDocumentItem(
                uri=uri, language_id="rmv", version=1,
                text=path.read_text(encoding="utf-8") if text is None else text,
            )
        )
    )  # fmt: skip
    return uri


async def _diagnostics_until(client: LanguageClient, uri: str, wanted) -> list[types.Diagnostic]:
    """Wait for published diagnostics of `uri` for which `wanted` holds."""

    async def wait() -> list[types.Diagnostic]:
        while True:
            found = list(client.diagnostics.get(uri, []))
            if uri in client.diagnostics and wanted(found):
                return found
            await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)

    return await asyncio.wait_for(wait(), WAIT)


def _expected(path: Path) -> list[tuple[str, int, int]]:
    """`rmv check`'s diagnostics of the file: code, 0-based line and column."""
    result = Workspace().check(str(path.resolve()))
    source = result.model.sources.get(str(path.resolve()))
    assert source is not None
    out = []
    for found in result.diagnostics:
        if found.span.path == source.path:
            where = source.position(found.span.start)
            out.append((found.code, where.line - 1, where.column - 1))
    return sorted(out)


def _seen(diagnostics: list[types.Diagnostic]) -> list[tuple[str, int, int]]:
    return sorted((str(d.code), d.range.start.line, d.range.start.character) for d in diagnostics)


@pytest.mark.parametrize("name", ["syntax.rmv", "queries.rmv", "analysis.rmv", "properties.rmv"])
async def test_diagnostics_are_exactly_rmv_checks(client: LanguageClient, name: str):
    """Every severity included: properties.rmv's solver stage gives a note (shown as
    Information), which once ended its publication with a KeyError."""
    path = EXAMPLES / "errors" / name
    expected = _expected(path)
    uri = _open(client, path)
    found = await _diagnostics_until(client, uri, lambda d: _seen(d) == expected)
    assert _seen(found) == expected
    first = found[0]
    assert first.source == "rmv" and first.message
    assert first.code_description is not None
    assert first.code_description.href.endswith(f"#{str(first.code).lower()}")


async def test_a_change_is_checked_as_typed(client: LanguageClient, tmp_path: Path):
    path = tmp_path / "typed.rmv"
    text = 'system typed\ntopic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'
    text += "event High when x > 1\nproperty P: not High\n"
    path.write_text(text, encoding="utf-8")
    uri = _open(client, path)
    await _diagnostics_until(client, uri, lambda d: d == [])
    # rename the use of High on the last line, as a user types: incremental sync
    line = text.splitlines().index("property P: not High")
    edit = types.TextDocumentContentChangePartial(
        range=types.Range(types.Position(line, 16), types.Position(line, 20)), text="Hgih"
    )
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(uri=uri, version=2), [edit]
        )
    )
    found = await _diagnostics_until(client, uri, lambda d: any(x.code == "RMV200" for x in d))
    wrong = next(d for d in found if d.code == "RMV200")
    assert (wrong.range.start.line, wrong.range.start.character) == (line, 16)
    assert "did you mean `High`" in wrong.message
    fix = types.TextDocumentContentChangePartial(
        range=types.Range(types.Position(line, 16), types.Position(line, 20)), text="High"
    )
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(uri=uri, version=3), [fix]
        )
    )
    await _diagnostics_until(client, uri, lambda d: d == [])


async def test_positions_follow_the_negotiated_encoding(client: LanguageClient, tmp_path: Path):
    """Two cars (each one code point, two UTF-16 units, four UTF-8 bytes) before an
    undefined name on the same line."""
    path = tmp_path / "cars.rmv"
    text = (
        'system cars\ntopic t: std_msgs/msg/Float64 = "/t"\nvar x = t.data\n'
        'alert A { message "\U0001f697\U0001f697" warn when Nope > 1 }\n'
    )
    path.write_text(text, encoding="utf-8")
    uri = _open(client, path)
    found = await _diagnostics_until(client, uri, lambda d: any(x.code == "RMV200" for x in d))
    wrong = next(d for d in found if d.code == "RMV200")
    units = {types.PositionEncodingKind.Utf16: 2, types.PositionEncodingKind.Utf8: 4}
    before = 'alert A { message "'
    column = len(before) + 2 * units[client.encoding] + len('" warn when ')  # type: ignore[attr-defined]
    assert (wrong.range.start.line, wrong.range.start.character) == (3, column)
    assert wrong.range.end.character == column + len("Nope")


async def _checked(client: LanguageClient, path: Path) -> str:
    uri = _open(client, path)
    await _diagnostics_until(client, uri, lambda d: True)
    return uri


async def test_hover_definition_references(client: LanguageClient):
    path = EXAMPLES / "carla" / "abs.rmv"
    lines = path.read_text(encoding="utf-8").splitlines()
    uri = await _checked(client, path)
    use_line = next(i for i, s in enumerate(lines) if s.startswith("event HardBrake when"))
    column = lines[use_line].index("BrakePedal")
    where = types.Position(use_line, column + 2)
    document = types.TextDocumentIdentifier(uri)
    hover = await client.text_document_hover_async(types.HoverParams(document, where))
    assert hover is not None
    text = hover.contents.value  # type: ignore[union-attr]
    assert "**variable** `BrakePedal`" in text and "vehicle_status.control.brake" in text
    assert "type: float (ROS `float32`)" in text
    topic_line = next(i for i, s in enumerate(lines) if s.startswith("topic vehicle_status"))
    on_topic = types.Position(topic_line, len("topic ") + 2)
    hover = await client.text_document_hover_async(types.HoverParams(document, on_topic))
    assert hover is not None
    assert "message `carla_msgs/msg/CarlaEgoVehicleStatus`" in hover.contents.value  # type: ignore[union-attr]
    assert "`velocity: float32`" in hover.contents.value  # type: ignore[union-attr]
    property_line = next(i for i, s in enumerate(lines) if s.startswith("property ABSCheck"))
    on_property = types.Position(property_line, len("property ") + 1)
    hover = await client.text_document_hover_async(types.HoverParams(document, on_property))
    assert hover is not None and "horizon: 10 s ahead" in hover.contents.value  # type: ignore[union-attr]
    found = await client.text_document_definition_async(types.DefinitionParams(document, where))
    declared = next(i for i, s in enumerate(lines) if s.startswith("var BrakePedal"))
    assert isinstance(found, types.Location) and found.range.start.line == declared
    assert found.range.start.character == len("var ")
    spans = await client.text_document_references_async(
        types.ReferenceParams(
            text_document=document, position=where,
            context=types.ReferenceContext(include_declaration=True),
        )
    )  # fmt: skip
    uses = sum(s.count("BrakePedal") for s in lines if not s.lstrip().startswith("//"))
    assert spans is not None and len(spans) == uses
    state_line = next(i for i, s in enumerate(lines) if "Cruising -> HardBraking" in s)
    on_state = types.Position(state_line, lines[state_line].index("Cruising") + 1)
    hover = await client.text_document_hover_async(
        types.HoverParams(text_document=document, position=on_state)
    )
    assert hover is not None and "of transducer `Braking`" in hover.contents.value  # type: ignore[union-attr]


async def test_outline_and_formatting(client: LanguageClient, tmp_path: Path):
    path = EXAMPLES / "carla" / "abs.rmv"
    uri = await _checked(client, path)
    symbols = await client.text_document_document_symbol_async(
        types.DocumentSymbolParams(types.TextDocumentIdentifier(uri))
    )
    assert symbols is not None
    by_name = {s.name: s for s in symbols}  # type: ignore[union-attr]
    braking = by_name["Braking"]
    assert braking.kind == types.SymbolKind.Class  # type: ignore[union-attr]
    states = [c.name for c in braking.children or []]  # type: ignore[union-attr]
    assert states == ["Cruising", "HardBraking", "AntiLockBrake", "Stopped"]
    assert {"Velocity", "ABSCheck", "EVelocityinKMH", "MaxVelocity"} <= set(by_name)

    messy = tmp_path / "messy.rmv"
    text = 'system   messy\ntopic t:std_msgs/msg/Float64="/t"\nvar x=t.data\n'
    messy.write_text(text, encoding="utf-8")
    uri = await _checked(client, messy)
    edits = await client.text_document_formatting_async(
        types.DocumentFormattingParams(
            types.TextDocumentIdentifier(uri), types.FormattingOptions(4, True)
        )
    )
    assert edits is not None and len(edits) == 1
    assert edits[0].new_text == formatted(str(messy), text)
    assert edits[0].range.start == types.Position(0, 0)


async def test_the_server_survives_any_text(client: LanguageClient, tmp_path: Path):
    """Random edits of the CARLA spec (deletions, insertions of any character,
    surrogate-pair emoji included), each followed by requests at random places:
    every answer arrives and the server keeps publishing."""
    path = tmp_path / "fuzz.rmv"
    text = (EXAMPLES / "carla" / "abs.rmv").read_text(encoding="utf-8")
    text = text.replace('messages "msg"', f'messages "{EXAMPLES / "carla" / "msg"}"')
    path.write_text(text, encoding="utf-8")
    uri = await _checked(client, path)
    document = types.TextDocumentIdentifier(uri)
    pieces = ["{", "}", "(", '"', "\U0001f697", "é", "\n", "->", "event", "\\", "//", "\x00"]
    rng = random.Random(7)
    for version in range(2, 32):
        lines = text.split("\n")
        line = rng.randrange(len(lines))
        start = rng.randrange(len(lines[line]) + 1)
        end = min(len(lines[line]), start + rng.randrange(4))
        new = rng.choice(pieces) if rng.random() < 0.7 else ""
        lines[line] = lines[line][:start] + new + lines[line][end:]
        text = "\n".join(lines)
        change = types.TextDocumentContentChangeWholeDocument(text=text)
        client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(uri=uri, version=version), [change]
            )
        )
        where = types.Position(rng.randrange(len(lines) + 3), rng.randrange(120))
        await asyncio.wait_for(
            client.text_document_hover_async(types.HoverParams(document, where)),
            WAIT,
        )
        await asyncio.wait_for(
            client.text_document_definition_async(types.DefinitionParams(document, where)),
            WAIT,
        )
    await _diagnostics_until(client, uri, lambda d: True)


async def test_completion_offers_what_may_stand_there(client: LanguageClient, tmp_path: Path):
    path = tmp_path / "complete.rmv"
    text = (
        'system complete\ndatabase {\n    name = "db"\n    precision = \n}\n'
        'topic t: std_msgs/msg/Float64 = "/t" qos {\n    \n}\nvar Speed = t.data\n'
        "event Fast = \n\n"
    )
    path.write_text(text, encoding="utf-8")
    uri = await _checked(client, path)
    lines = text.split("\n")

    async def labels(line: int, character: int) -> dict[str, types.CompletionItem]:
        answer = await client.text_document_completion_async(
            types.CompletionParams(
                types.TextDocumentIdentifier(uri), types.Position(line, character)
            )
        )
        assert isinstance(answer, types.CompletionList)
        return {item.label: item for item in answer.items}

    values = await labels(3, len(lines[3]))  # after `precision = `
    assert set(values) == {"ns", "u", "us", "ms", "s", "m", "h"}
    qos = await labels(6, 4)  # an empty line inside `qos { }`
    assert {"depth", "reliability", "durability", "time"} <= set(qos)
    assert qos["depth"].kind == types.CompletionItemKind.Property
    top = await labels(len(lines) - 2, 0)  # an empty line at the top level
    assert {"topic", "event", "transducer", "property"} <= set(top)
    expression = await labels(9, len(lines[9]))  # after `event Fast = `
    assert expression["Speed"].detail == "a variable"
    assert expression["mean"].kind == types.CompletionItemKind.Function
    assert expression["mean"].documentation == "the arithmetic mean of the window"


async def test_rename_and_quick_fix(client: LanguageClient, tmp_path: Path):
    path = tmp_path / "rename.rmv"
    text = (
        'system rename\ntopic t: std_msgs/msg/Float64 = "/t"\nvar Speed = t.data\n'
        "event Fast when Speed > 1\nevent Slow when Sped < 1\nproperty P: not Fast\n"
    )
    path.write_text(text, encoding="utf-8")
    uri = _open(client, path)
    found = await _diagnostics_until(client, uri, lambda d: any(x.code == "RMV200" for x in d))
    document = types.TextDocumentIdentifier(uri)
    typo = next(d for d in found if d.code == "RMV200")
    actions = await client.text_document_code_action_async(
        types.CodeActionParams(
            text_document=document, range=typo.range,
            context=types.CodeActionContext(diagnostics=[typo]),
        )
    )  # fmt: skip
    assert actions is not None and len(actions) == 1
    fix = actions[0]
    assert isinstance(fix, types.CodeAction) and fix.title == "Replace with `Speed`"
    assert fix.edit is not None and fix.edit.changes is not None
    assert fix.edit.changes[uri][0].range == typo.range

    on_speed = types.Position(2, len("var ") + 1)
    answer = await client.text_document_rename_async(
        types.RenameParams(text_document=document, position=on_speed, new_name="Velocity")
    )
    assert answer is not None and answer.changes is not None
    edits = answer.changes[uri]
    assert len(edits) == 2 and {e.range.start.line for e in edits} == {2, 3}
    for refused in ("Fast", "event", "9lives"):
        with pytest.raises(Exception, match=r"already a boolean event|keyword|not a name"):
            await client.text_document_rename_async(
                types.RenameParams(text_document=document, position=on_speed, new_name=refused)
            )


async def test_folding_and_workspace_symbols(client: LanguageClient):
    path = EXAMPLES / "carla" / "abs.rmv"
    lines = path.read_text(encoding="utf-8").splitlines()
    uri = await _checked(client, path)
    ranges = await client.text_document_folding_range_async(
        types.FoldingRangeParams(types.TextDocumentIdentifier(uri))
    )
    assert ranges is not None
    transducer = next(i for i, s in enumerate(lines) if s.startswith("transducer Braking"))
    closing = next(i for i in range(transducer, len(lines)) if lines[i] == "}")
    assert (transducer, closing) in {(r.start_line, r.end_line) for r in ranges}
    assert all(r.end_line > r.start_line for r in ranges)
    found = await client.workspace_symbol_async(types.WorkspaceSymbolParams(query="brak"))
    assert found is not None
    names = {s.name for s in found}
    assert {"Braking", "HardBraking", "BrakePedal", "BrakeReleased"} <= names
    assert all("brak" in n.lower() for n in names)


MENTIONS = """system mentions
messages "msg"
database {
    name = "db"
    retention raw { duration = 1d }
    retention archive { duration = 30d }
    downsample wheel_1m {
        from = raw
        into = archive
        every = 1m
        aggregate = mean
        measurements = [Speed]
    }
}
topic Status: demo_msgs/Status = "/status"
var Speed = Status.wheel.speed
var Size = Status.wheel.radius
event Fast when Speed > 1
"""


def _mentions_folder(tmp_path: Path) -> Path:
    folder = tmp_path / "msg" / "demo_msgs" / "msg"
    folder.mkdir(parents=True)
    # A comment with characters outside the BMP: columns differ between encodings.
    (folder / "Status.msg").write_text("# état 🚗\nWheel wheel\nuint8 gear\n", encoding="utf-8")
    (folder / "Wheel.msg").write_text(
        "# rayon 🛞\nfloat32 radius\nfloat64 speed  # m/s\nuint8 LEFT=0\n", encoding="utf-8"
    )
    path = tmp_path / "mentions.rmv"
    path.write_text(MENTIONS, encoding="utf-8")
    return path


def _at(text: str, needle: str, inside: int = 1) -> types.Position:
    """The position of a character of the first `needle` (ASCII lines here)."""
    offset = text.index(needle) + inside
    line = text.count("\n", 0, offset)
    return types.Position(line, offset - (text.rfind("\n", 0, offset) + 1))


async def test_field_paths_message_types_and_policies(client: LanguageClient, tmp_path: Path):
    """Definition goes into the .msg file at the field's line, references find
    every use of a field, a message type or a retention policy, hover shows a
    message's definition."""
    path = _mentions_folder(tmp_path)
    uri = await _checked(client, path)
    document = types.TextDocumentIdentifier(uri)
    wheel_msg = (tmp_path / "msg" / "demo_msgs" / "msg" / "Wheel.msg").resolve().as_uri()

    async def definition(needle: str) -> types.Location:
        answer = await client.text_document_definition_async(
            types.DefinitionParams(document, _at(MENTIONS, needle))
        )
        assert isinstance(answer, types.Location), needle
        return answer

    speed = await definition("speed")
    assert speed.uri == wheel_msg and speed.range.start.line == 2  # `float64 speed`
    assert (await definition("radius")).range.start.line == 1
    message = await definition("demo_msgs/Status")
    assert message.uri.endswith("/Status.msg") and message.range.start.line == 0
    policy = await definition("raw\n        into")
    assert policy.uri == uri and policy.range.start == _at(MENTIONS, "raw {", 0)

    async def reference_lines(needle: str, declared: bool) -> list[int]:
        answer = await client.text_document_references_async(
            types.ReferenceParams(
                text_document=document,
                position=_at(MENTIONS, needle),
                context=types.ReferenceContext(include_declaration=declared),
            )
        )
        assert answer is not None
        return sorted(r.range.start.line for r in answer)

    assert await reference_lines("wheel.speed", False) == [15, 16]
    assert await reference_lines("archive\n", True) == [5, 8]

    hover = await client.text_document_hover_async(
        types.HoverParams(document, _at(MENTIONS, "demo_msgs/Status"))
    )
    assert hover is not None and isinstance(hover.contents, types.MarkupContent)
    assert "Wheel wheel" in hover.contents.value and "uint8 gear" in hover.contents.value
    field = await client.text_document_hover_async(
        types.HoverParams(document, _at(MENTIONS, "radius"))
    )
    assert field is not None and isinstance(field.contents, types.MarkupContent)
    assert "`float32`" in field.contents.value and "demo_msgs/msg/Wheel" in field.contents.value


async def test_completion_of_paths_types_and_grammar_words(client: LanguageClient, tmp_path: Path):
    path = _mentions_folder(tmp_path)
    uri = await _checked(client, path)
    document = types.TextDocumentIdentifier(uri)
    version = 1

    async def labels_after(typed: str) -> dict[str, types.CompletionItem]:
        """Type `typed` on a new last line, then ask at its end."""
        nonlocal version
        version += 1
        text = MENTIONS + typed
        client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(uri=uri, version=version),
                [types.TextDocumentContentChangeWholeDocument(text=text)],
            )
        )
        lines = text.split("\n")
        where = types.Position(len(lines) - 1, len(lines[-1]))
        params = types.CompletionParams(document, where)
        answer = await client.text_document_completion_async(params)
        assert isinstance(answer, types.CompletionList)
        return {item.label: item for item in answer.items}

    first = await labels_after("var Gear = Status.")
    assert set(first) == {"wheel", "gear"}
    assert first["wheel"].kind == types.CompletionItemKind.Field
    assert first["wheel"].detail == "demo_msgs/msg/Wheel"
    second = await labels_after("var Radius = Status.wheel.")
    assert set(second) == {"radius", "speed", "LEFT"}
    assert second["LEFT"].kind == types.CompletionItemKind.Constant
    kinds = await labels_after("topic Other: ")
    assert {"demo_msgs/Status", "demo_msgs/Wheel", "std_msgs/Float64"} <= set(kinds)
    assert kinds["demo_msgs/Status"].kind == types.CompletionItemKind.Struct
    # The grammar's words: inside a transducer after its states, no declarations.
    inside = await labels_after("transducer D {\n    states A, B\n    ")
    assert {"initial", "final"} <= set(inside) and "topic" not in inside
    condition = await labels_after("event Slow when Speed < 1 ")
    assert {"and", "or"} <= set(condition) and "Speed" not in condition
    operand = await labels_after("event Slow when Speed < 1 and ")
    assert "not" in operand and operand["Speed"].kind == types.CompletionItemKind.Variable
    assert "Status" not in operand  # a topic cannot stand in a condition
    formula = await labels_after("property Q: always ")
    assert "Fast" in formula and "Speed" not in formula and "mean" not in formula


async def test_semantic_tokens(client: LanguageClient, tmp_path: Path):
    path = _mentions_folder(tmp_path)
    uri = await _checked(client, path)
    answer = await client.text_document_semantic_tokens_full_async(
        types.SemanticTokensParams(types.TextDocumentIdentifier(uri))
    )
    assert answer is not None
    server = client.server_capabilities.semantic_tokens_provider  # type: ignore[attr-defined]
    assert isinstance(server, types.SemanticTokensOptions)
    names, modifiers = server.legend.token_types, server.legend.token_modifiers
    decoded, line, start = {}, 0, 0
    data = answer.data
    lines = MENTIONS.split("\n")
    for index in range(0, len(data), 5):
        delta_line, delta_start, length, kind, mods = data[index : index + 5]
        line += delta_line
        start = start + delta_start if delta_line == 0 else delta_start
        word = lines[line][start : start + length]
        declared = bool(mods & (1 << modifiers.index("declaration")))
        decoded.setdefault(word, set()).add((names[kind], declared))
    assert decoded["Speed"] == {("variable", True), ("variable", False)}
    assert decoded["Status"] == {("interface", True), ("interface", False)}
    assert decoded["wheel"] == {("property", False)}
    assert decoded["demo_msgs/Status"] == {("type", False)}
    assert decoded["raw"] == {("namespace", True), ("namespace", False)}
    assert decoded["Fast"] == {("event", True)}


async def _apply_first_fix(
    client: LanguageClient, uri: str, text: str, code: str, version: int
) -> str:
    """Ask for the fixes of the first diagnostic `code` and apply the first."""
    found = await _diagnostics_until(client, uri, lambda d: any(x.code == code for x in d))
    target = next(d for d in found if d.code == code)
    actions = await client.text_document_code_action_async(
        types.CodeActionParams(
            text_document=types.TextDocumentIdentifier(uri), range=target.range,
            context=types.CodeActionContext(diagnostics=[target]),
        )
    )  # fmt: skip
    assert actions, code
    action = actions[0]
    assert isinstance(action, types.CodeAction) and action.edit and action.edit.changes
    (edit,) = action.edit.changes[uri]
    lines = text.split("\n")
    start, end = edit.range.start, edit.range.end
    assert start.line == end.line  # these fixes stay on a line (ASCII: any encoding)
    line = lines[start.line]
    lines[start.line] = line[: start.character] + edit.new_text + line[end.character :]
    fixed = "\n".join(lines)
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(uri=uri, version=version),
            [types.TextDocumentContentChangeWholeDocument(text=fixed)],
        )
    )
    return fixed


async def test_fixes_add_a_missing_state_and_a_whitelisted_node(
    client: LanguageClient, tmp_path: Path
):
    text = (
        'system fixes\ntopic Cmd: std_msgs/Float64 = "/cmd"\nvar Command = Cmd.data\n'
        "event High when Command > 1\n"
        "transducer D {\n    states Idle, Busy\n    initial Idle\n"
        "    Idle -> Busy on High\n    Busy -> Stopped on High\n}\n"
        "property P: always[<=1s] not Busy\n"
        'whitelist Cmd { publishers: "/planner" }\nnode "/teleop" { publishes: "/cmd" }\n'
    )
    path = tmp_path / "fixes.rmv"
    path.write_text(text, encoding="utf-8")
    uri = _open(client, path, text)
    text = await _apply_first_fix(client, uri, text, "RMV210", 2)
    assert "    states Idle, Busy, Stopped\n" in text
    text = await _apply_first_fix(client, uri, text, "RMV222", 3)
    assert 'publishers: "/planner", "/teleop" }' in text
    rest = await _diagnostics_until(
        client, uri, lambda d: not any(x.code in ("RMV210", "RMV222") for x in d)
    )
    assert not [d for d in rest if d.severity == types.DiagnosticSeverity.Error]


class _Sink:
    def write(self, data: object) -> None:
        pass

    def close(self) -> None:
        pass


def test_the_server_keeps_no_finished_handler(tmp_path: Path):
    """pygls 2.1 kept every notification's future (two per didChange) for the life
    of the server; rmvdsl's protocol lets each go once it is done. Run in process,
    through the protocol's own message handling, to see its table."""
    from rmvdsl.editor.lsp.server import build

    async def edit(count: int) -> int:
        server = build()
        protocol = server.protocol
        protocol.set_writer(_Sink())

        def send(message: dict[str, object]) -> None:
            protocol.handle_message(protocol.structure_message({"jsonrpc": "2.0", **message}))

        send({"id": 1, "method": "initialize", "params": {"capabilities": {}}})
        send({"method": "initialized", "params": {}})
        uri = (tmp_path / "edited.rmv").as_uri()
        item = {"uri": uri, "languageId": "rmv", "version": 1, "text": "system s\n"}
        send({"method": "textDocument/didOpen", "params": {"textDocument": item}})
        for version in range(2, count + 2):
            change = {"text": f"system s{version}\n"}
            document = {"uri": uri, "version": version}
            send({"method": "textDocument/didChange",
                  "params": {"textDocument": document, "contentChanges": [change]}})  # fmt: skip
            await asyncio.sleep(0.002)
        # the last change's solver stages, after the debounce (in the solver
        # process, which the first of them starts): every handler ends
        deadline = time.monotonic() + 60
        while protocol._request_futures and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        return len(protocol._request_futures)

    assert asyncio.run(edit(100)) == 0
