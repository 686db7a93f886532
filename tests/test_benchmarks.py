"""The benchmarks' own measuring: a figure is the measured process's alone."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))

import peak

MB = 2**20
GROW = "x = bytearray({size} * 2**20); x[::4096] = b'1' * len(x[::4096]); raise SystemExit({code})"


def test_a_process_s_peak_is_its_own_not_its_starter_s():
    """A child started the usual way (subprocess's vfork) reported the peak of the
    process that started it: 300 MB held here made `python -c pass` 300 MB."""
    held = bytearray(300 * MB)
    held[::4096] = b"1" * len(held[::4096])
    small = peak.run([sys.executable, "-c", "pass"])
    grown = peak.run([sys.executable, "-c", GROW.format(size=200, code=3)])
    assert small.peak_bytes < 100 * MB, small
    assert 200 * MB <= grown.peak_bytes < 290 * MB, grown
    assert (small.returncode, grown.returncode) == (0, 3)
    assert grown.cpu > 0
    assert peak.run(["/nonexistent/command"]).returncode == 127
    assert len(held) == 300 * MB
