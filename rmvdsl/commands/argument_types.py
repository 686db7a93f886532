"""The values `rmv`'s options take: each a function argparse calls on the text,
giving the value or refusing it in words (argparse prints them after the option)."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def jobs(text: str) -> int:
    """A --jobs: a whole number of processes, 1 to 1024."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 1 <= value <= 1024:
        raise argparse.ArgumentTypeError(f"must be 1 to 1024, not {value}")
    return value


def seconds_up_to(most: float | None) -> Callable[[str], float]:
    """A --timeout's type: seconds, more than 0 (and at most `most`)."""
    bound = "" if most is None else f" and at most {most:g}"

    def seconds(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not 0 < value < float("inf") or (most is not None and value > most):
            raise argparse.ArgumentTypeError(f"{text}: give seconds, more than 0{bound}")
        return value

    return seconds


# The latest time a recording can hold: rosbags' times are int64 nanoseconds.
_LATEST = (2**63 - 1) // 10**9


def instant(flag: str) -> Callable[[str], str]:
    """--from/--to: seconds on the recording's clock or, with +, after its start:
    a decimal number from 0 to the latest time a recording holds (kept as text;
    the replay reads it against the recording)."""

    def instant(text: str) -> str:
        import re

        match = re.fullmatch(r"\+?(\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d{1,3})?", text.strip())
        if match is None or float(text.strip().lstrip("+")) > _LATEST:
            raise argparse.ArgumentTypeError(
                f"{text}: give seconds on the recording's clock (1700000012.5) or after its "
                f"start (+12.5), from 0 to {_LATEST:,}"
            )
        return text.strip()

    return instant


_UNITS = {"ms": 10**6, "s": 10**9, "m": 60 * 10**9, "h": 3600 * 10**9}


def chunk(text: str) -> int:
    """A --chunk: a duration (seconds, or with ms, s, m or h), at least 1 ms; in ns."""
    import re
    from fractions import Fraction

    match = re.fullmatch(r"(\d+(?:\.\d+)?)(ms|s|m|h)?", text.strip())
    value = Fraction(match.group(1)) * _UNITS[match.group(2) or "s"] if match else 0
    if value < 10**6:
        raise argparse.ArgumentTypeError(
            f"{text}: give a duration of at least 1 ms: seconds (600) or 500ms, 90s, 10m, 1h"
        )
    return int(value)


solver_seconds = seconds_up_to(3600)  # a solver call's
duration = seconds_up_to(None)  # one recording's
