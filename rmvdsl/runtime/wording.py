"""How a count reads in a message: "1 error", "2 errors" (the one place that
chooses a noun's number; tests/test_wording.py finds counts written without it)."""

from __future__ import annotations


def counted(number: int, noun: str, plural: str | None = None, *, grouped: bool = False) -> str:
    """`number` and `noun`, plural unless number is 1 (`plural`: an irregular form;
    `grouped`: thousands separated by commas)."""
    shown = f"{number:,}" if grouped else str(number)
    return f"{shown} {noun if number == 1 else plural or noun + 's'}"
