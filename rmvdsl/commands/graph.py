"""`rmv graph`: the transducers drawn, with what the analyses found."""

from __future__ import annotations

import argparse
import sys

from rmvdsl.commands import say, write_text
from rmvdsl.lang.errors import EXIT_ERRORS, EXIT_OK, UsageError
from rmvdsl.runtime.wording import counted


def run(args: argparse.Namespace) -> int:
    from rmvdsl.check import check
    from rmvdsl.check.analysis import TransducerFacts
    from rmvdsl.lang.diagnostics import did_you_mean
    from rmvdsl.lang.render import render_text
    from rmvdsl.tools.graph import RENDERERS

    result = check(args.spec)
    transducers = result.model.transducers
    if args.transducer is not None and args.transducer not in transducers:
        hint = did_you_mean(args.transducer, transducers) or "transducers: " + ", ".join(
            transducers
        )
        raise UsageError(f"{args.spec} has no transducer `{args.transducer}` ({hint})")
    if not transducers:
        raise UsageError(f"{args.spec} declares no transducer")
    # The analyses' findings (RMV5xx) are what the drawing shows; an error before
    # them (syntax, names, types) means the drawing would mislead: say what is wrong.
    broken = [d for d in result.errors if not d.code.startswith("RMV5")]
    if broken:
        sys.stderr.write(render_text(broken, result.model.sources, False))
        say(f"rmv graph: {args.spec}: {counted(len(broken), 'error')}: not drawn")
        return EXIT_ERRORS
    if result.errors:
        sys.stderr.write(render_text(result.errors, result.model.sources, False))
    chosen = [transducers[args.transducer]] if args.transducer else list(transducers.values())
    facts = result.analysis.transducers if result.analysis else {}
    render = RENDERERS[args.format]
    text = "\n".join(render(decl, facts.get(decl.name.name, TransducerFacts())) for decl in chosen)
    if args.output:
        write_text(args.output, text)
    else:
        sys.stdout.write(text)
    return EXIT_OK
