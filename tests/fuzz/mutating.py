"""The fuzzing engine where atheris does not install: hypothesis drawing seeds
with byte edits (flips, inserts, deletes, splices of another seed) and random
bytes. It is not coverage-guided; what it finds it shrinks and keeps as a
regression fixture, as atheris's artifacts are kept."""

from __future__ import annotations

import argparse
import hashlib
import resource
import time
from typing import Any

from fuzz.targets import REGRESSIONS, OneInput


class Hang(Exception):
    pass


def run_hypothesis(
    name: str, one: OneInput, seeds: list[bytes], args: argparse.Namespace
) -> dict[str, Any]:
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    pool = seeds or [b""]

    @st.composite
    def inputs(draw: Any) -> bytes:
        if draw(st.integers(0, 9)) == 0:
            return bytes(draw(st.binary(max_size=512)))
        data = bytearray(draw(st.sampled_from(pool)))
        for _ in range(draw(st.integers(0, 8))):
            at = draw(st.integers(0, len(data)))
            kind = draw(st.integers(0, 3))
            if kind == 0 and at < len(data):
                data[at] ^= 1 << draw(st.integers(0, 7))
            elif kind == 1:
                data[at:at] = draw(st.binary(min_size=1, max_size=16))
            elif kind == 2:
                del data[at : at + draw(st.integers(1, 16))]
            else:
                other = draw(st.sampled_from(pool))
                start = draw(st.integers(0, len(other)))
                data[at:at] = other[start : start + draw(st.integers(1, 64))]
        return bytes(data)

    counted = {"inputs": 0}
    deadline = time.monotonic() + args.seconds if args.seconds else None

    @settings(max_examples=args.runs, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))  # fmt: skip
    @given(inputs())
    def fuzz(data: bytes) -> None:
        if deadline is not None and time.monotonic() > deadline:
            return
        counted["inputs"] += 1
        started = time.monotonic()
        one(data)
        if time.monotonic() - started > args.timeout:
            raise Hang(f"{time.monotonic() - started:.2f} s")

    result = {"target": name, "engine": "hypothesis", "crashes": 0, "hangs": 0, "artifact": None,
              "output": ""}  # fmt: skip
    try:
        fuzz()
    except Exception as error:  # the shrunk failing input: kept as a fixture
        found = getattr(error, "__notes__", [])
        result["hangs" if isinstance(error, Hang) else "crashes"] = 1
        result["output"] = f"{type(error).__name__}: {error}\n" + "\n".join(found)[-3000:]
        result["artifact"] = _keep(name, error)
    result["inputs"] = counted["inputs"]
    result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    return result


def _keep(name: str, error: Exception) -> str | None:
    """The failing input hypothesis reported, written where atheris writes."""
    for note in getattr(error, "__notes__", []):
        if note.startswith("Falsifying example: fuzz("):
            text = note.split("data=", 1)[-1].rsplit(",", 1)[0].strip().rstrip(")")
            try:
                data = eval(text, {})  # a bytes literal hypothesis printed
            except Exception:
                return None
            folder = REGRESSIONS / name
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / f"crash-{hashlib.sha1(data).hexdigest()}"
            path.write_bytes(data)
            return str(path)
    return None
