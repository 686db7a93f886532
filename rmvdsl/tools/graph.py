"""`rmv graph`: a transducer drawn, with the analyses' findings highlighted.

Unreachable states are dashed red, states with no way out orange, transitions that
conflict (non-determinism) red; the initial state has an arrow from a dot, final
states a double border. DOT (Graphviz), Mermaid (GitHub renders it) and a
self-contained SVG (no Graphviz needed).
"""

from __future__ import annotations

import math
from html import escape

from rmvdsl.check.analysis import TransducerFacts
from rmvdsl.grammar import ast


def _label(transition: ast.Transition) -> str:
    text = transition.input.name
    if transition.output is not None:
        text += f" / {transition.output.name}"
    return text


def _conflicting(facts: TransducerFacts) -> set[int]:
    return {id(t) for pair in facts.conflicts for t in pair[:2]}


def to_dot(decl: ast.TransducerDecl, facts: TransducerFacts) -> str:
    finals = {f.name for f in decl.finals}
    lines = [
        f'digraph "{decl.name.name}" {{',
        "    rankdir=LR;",
        '    node [shape=circle, fontname="Helvetica"];',
    ]
    lines.append('    edge [fontname="Helvetica", fontsize=10];')
    if decl.initial is not None:
        lines.append('    "__start" [shape=point, width=0.15, label=""];')
        lines.append(f'    "__start" -> "{decl.initial.name}";')
    for state in decl.states:
        attributes = []
        if state.name in finals:
            attributes.append("shape=doublecircle")
        if state.name in facts.unreachable:
            attributes += ["style=dashed", "color=red", "fontcolor=red", 'xlabel="unreachable"']
        elif state.name in facts.dead_ends:
            attributes += ["color=orange", 'xlabel="no way out"']
        suffix = f" [{', '.join(attributes)}]" if attributes else ""
        lines.append(f'    "{state.name}"{suffix};')
    conflicting = _conflicting(facts)
    for transition in decl.transitions:
        attributes = [f'label="{_label(transition)}"']
        if id(transition) in conflicting:
            attributes += ["color=red", "fontcolor=red", "penwidth=2"]
        lines.append(
            f'    "{transition.source.name}" -> "{transition.dest.name}" [{", ".join(attributes)}];'
        )
    lines.append("}")
    return "\n".join(lines) + "\n"


def to_mermaid(decl: ast.TransducerDecl, facts: TransducerFacts) -> str:
    lines = ["stateDiagram-v2"]
    if decl.initial is not None:
        lines.append(f"    [*] --> {decl.initial.name}")
    for final in decl.finals:
        lines.append(f"    {final.name} --> [*]")
    for transition in decl.transitions:
        lines.append(
            f"    {transition.source.name} --> {transition.dest.name}: {_label(transition)}"
        )
    if facts.unreachable:
        lines.append("    classDef unreachable stroke:red,stroke-dasharray:5 5,color:red")
        lines.append(f"    class {','.join(sorted(facts.unreachable))} unreachable")
    if facts.dead_ends:
        lines.append("    classDef deadend stroke:orange")
        lines.append(f"    class {','.join(sorted(facts.dead_ends))} deadend")
    for first, second, values in facts.conflicts:
        lines.append(
            f"    note right of {first.source.name}: not deterministic: {first.input.name} "
            f"and {second.input.name} can hold together ({values})"
        )
    return "\n".join(lines) + "\n"


def _attribute(value: object) -> str:
    return f"{value:.1f}" if isinstance(value, float) else escape(str(value))


def _tag(name: str, text: str = "", /, **attributes: object) -> str:
    """An SVG element; `stroke_width` is written `stroke-width`."""
    rendered = " ".join(
        f'{key.replace("_", "-")}="{_attribute(value)}"' for key, value in attributes.items()
    )
    return f"<{name} {rendered}>{escape(text)}</{name}>" if text else f"<{name} {rendered}/>"


def to_svg(decl: ast.TransducerDecl, facts: TransducerFacts) -> str:
    """States on a circle, transitions as arrows (curved when both ways)."""
    states = [s.name for s in decl.states]
    count = max(1, len(states))
    radius = 60 + 28 * count
    size = 2 * radius + 160
    center = size / 2
    place = {
        name: (
            center + radius * math.cos(2 * math.pi * i / count - math.pi / 2),
            center + radius * math.sin(2 * math.pi * i / count - math.pi / 2),
        )
        for i, name in enumerate(states)
    }
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{size:.0f}" height="{size:.0f}" '
        f'viewBox="0 0 {size:.0f} {size:.0f}" font-family="Helvetica, sans-serif" font-size="12">',
        f"<title>transducer {escape(decl.name.name)}</title>",
        "<defs>",
        *(
            f'<marker id="{ident}" markerWidth="10" markerHeight="8" refX="9" refY="4" '
            f'orient="auto">{_tag("path", d="M0,0 L10,4 L0,8 z", fill=color)}</marker>'
            for ident, color in (("arrow", "#333"), ("arrow-red", "#c00"))
        ),
        "</defs>",
        _tag("rect", width="100%", height="100%", fill="white"),
    ]
    conflicting = _conflicting(facts)
    pairs = {(t.source.name, t.dest.name) for t in decl.transitions}
    for transition in decl.transitions:
        out.append(_edge(transition, place, id(transition) in conflicting, pairs))
    finals = {f.name for f in decl.finals}
    for name in states:
        out.extend(_state(name, place[name], facts, name in finals))
    if decl.initial is not None and decl.initial.name in place:
        x, y = place[decl.initial.name]
        out.append(_tag("circle", cx=x - _NODE - 30, cy=y, r=5, fill="#333"))
        out.append(_tag("line", x1=x - _NODE - 25, y1=y, x2=x - _NODE, y2=y, stroke="#333",
                        marker_end="url(#arrow)"))  # fmt: skip
    out.append("</svg>")
    return "\n".join(out) + "\n"


_NODE = 34.0  # the radius of a state


def _state(name: str, at: tuple[float, float], facts: TransducerFacts, final: bool) -> list[str]:
    x, y = at
    stroke, color, dash = "#333", "#000", {}
    note = ""
    if name in facts.unreachable:
        stroke, color, dash, note = "#c00", "#c00", {"stroke_dasharray": "6 4"}, "unreachable"
    elif name in facts.dead_ends:
        stroke, note = "#e69500", "no way out"
    parts = [f'<g class="state" id="state-{escape(name)}">']
    parts.append(
        _tag("circle", cx=x, cy=y, r=_NODE, fill="#f8f8ff", stroke=stroke, stroke_width=2, **dash)
    )
    if final:
        parts.append(_tag("circle", cx=x, cy=y, r=_NODE - 5, fill="none", stroke=stroke))
    parts.append(_tag("text", name, x=x, y=y + 4, text_anchor="middle", fill=color))
    if note:
        parts.append(_tag("text", note, x=x, y=y + _NODE + 14, text_anchor="middle", fill=stroke))
    parts.append("</g>")
    return parts


def _edge(
    transition: ast.Transition,
    place: dict[str, tuple[float, float]],
    conflict: bool,
    pairs: set[tuple[str, str]],
) -> str:
    color = "#c00" if conflict else "#333"
    style: dict[str, object] = {
        "fill": "none",
        "stroke": color,
        "stroke_width": 2 if conflict else 1.2,
        "marker_end": f"url(#{'arrow-red' if conflict else 'arrow'})",
    }
    source, dest = transition.source.name, transition.dest.name
    if source not in place or dest not in place:
        return ""
    (x1, y1), (x2, y2) = place[source], place[dest]
    if source == dest:
        top = y1 - _NODE
        path = (f"M{x1 - 12:.1f},{top + 2:.1f} C{x1 - 40:.1f},{top - 50:.1f} "
                f"{x1 + 40:.1f},{top - 50:.1f} {x1 + 12:.1f},{top + 2:.1f}")  # fmt: skip
        label_at = (x1, top - 42)
    else:
        length = math.hypot(x2 - x1, y2 - y1) or 1
        ux, uy = (x2 - x1) / length, (y2 - y1) / length
        bend = 30 if (dest, source) in pairs else 0
        sx, sy, ex, ey = x1 + ux * _NODE, y1 + uy * _NODE, x2 - ux * _NODE, y2 - uy * _NODE
        cx, cy = (sx + ex) / 2 - uy * bend, (sy + ey) / 2 + ux * bend
        path = f"M{sx:.1f},{sy:.1f} Q{cx:.1f},{cy:.1f} {ex:.1f},{ey:.1f}"
        label_at = (cx, cy - 4)
    label = _tag(
        "text", _label(transition), x=label_at[0], y=label_at[1], text_anchor="middle", fill=color
    )
    return f'<g class="transition">{_tag("path", d=path, **style)}{label}</g>'


RENDERERS = {"dot": to_dot, "mermaid": to_mermaid, "svg": to_svg}
