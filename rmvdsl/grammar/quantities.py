"""A quantity as the lexer's QUANTITY terminal reads it (`3.6`, `1e-3`, `10s`,
`10Hz`): its number and its unit, and the units the language names. Without lark,
so that a formula read on its own (rmvdsl.grammar.formula_reader) loads none of it."""

from __future__ import annotations

import re
from fractions import Fraction

QUANTITY = re.compile(r"^((?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)([A-Za-z]*)$")
RATE_UNITS = {"Hz": Fraction(1), "kHz": Fraction(1000)}
# InfluxDB also writes microseconds as `u`.
TIME_UNIT_ALIASES = {"u": "us"}
