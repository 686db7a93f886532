"""The C target's builds (docs/c.md): hostile names compile and come back as
written, the monitor needs no libc but three functions and no floating point,
several monitors and systems share a program (C or C++), the generated Makefile
and CMakeLists.txt work, and what the target cannot compute is refused where the
spec declares it."""

from __future__ import annotations

import subprocess
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest
from c_harness import (
    STRICT as STRICT_FLAGS,
)
from c_harness import (
    compile_driver,
    compiler,
    end_line,
    monitor_segments,
    run_driver,
    sample_line,
    segments_by_property,
    write,
)

from rmvdsl.runtime.rmtld3 import merge
from rmvdsl.targets.c.generate import c_identifier, c_string, files, laid_out
from rmvdsl.targets.c.model import compile_formula, sized

pytestmark = pytest.mark.skipif(compiler() is None, reason="needs a C compiler (gcc)")

ROOT = Path(__file__).resolve().parent.parent
NS = 1_000_000_000


HOSTILE = [
    'say "hi"', "back\\slash", "*/ int x; /*", "??=trigraph??/", "new\nline", "tab\there",
    "ünïcödé", "𝄞 clef", "int", "PROPOSITIONS", "P_x", "a b", "a_x20b", "", "%s%n",
]  # fmt: skip


def test_hostile_names_compile_and_come_back_as_written(tmp_path: Path) -> None:
    """Property and proposition names no spec could hold still give C that compiles
    with -Werror (strings by c_string, identifiers told apart), and the driver
    prints each name back exactly."""
    compiled, lines_props = [], set()
    for k, name in enumerate(HOSTILE):
        formula = ("or", ("prop", name), ("prop", f"{name}#{k}"))
        compiled.append(
            (name or f"empty{k}", f"{name} */ text", sized(compile_formula(formula), 4), 0)
        )
        lines_props.add(name)
    write(files(laid_out("hostile system */", compiled), source="a */ path \n"), tmp_path)
    program = compile_driver(tmp_path, sanitize=True)
    status, records, errors = run_driver(
        program, [sample_line(Fraction(0), lines_props), end_line(Fraction(1))]
    )
    assert status == 0, errors
    got = segments_by_property(records)
    assert set(got) == {name or f"empty{k}" for k, name in enumerate(HOSTILE)}
    assert all(v == [(0, 1, True, False, "true")] for v in got.values())


@pytest.mark.parametrize("text", HOSTILE)
def test_c_string_is_one_literal_of_the_same_bytes(text: str, tmp_path: Path) -> None:
    source = tmp_path / "t.c"
    source.write_text(
        "#include <stdio.h>\n#include <string.h>\nint main(void) {\n"
        f"    static const char s[] = {c_string(text)};\n"
        "    fwrite(s, 1, sizeof s - 1, stdout);\n    return 0;\n}\n"
    )
    subprocess.run([compiler(), "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                    "-Wtrigraphs", "-o", str(tmp_path / "t"), str(source)], check=True)  # fmt: skip
    assert subprocess.run([str(tmp_path / "t")], capture_output=True).stdout == text.encode()
    assert c_identifier(text).isidentifier() and c_identifier(text).isascii()


def test_what_the_c_target_cannot_compute_is_refused_at_its_declaration(tmp_path: Path) -> None:
    spec = tmp_path / "s.rmv"
    spec.write_text(
        'system s\ntopic t: std_msgs/Float64 = "/t"\nvar X = t.data\n'
        "event A when X > 1\nevent B when X > 2\n"
        "property NoRate: A -> eventually[<=1s] B\n"
        "property TwoDurations: duration[5s](A) < duration[5s](B) { rate = 10Hz }\n"
        "property Scaled: 2 * duration[5s](A) < 3s { rate = 10Hz }\n"
        "property Fine: duration[5s](A) - 1s < 3s { rate = 10Hz }\n"
    )
    done = subprocess.run(
        ["rmv", "check", "--target", "c", str(spec)], capture_output=True, text=True
    )
    assert done.returncode == 1, done.stdout + done.stderr
    text = done.stdout + done.stderr
    for line, why in ((6, "--max-rate"), (7, "one duration"), (8, "a duration times 2")):
        assert f"s.rmv:{line}:" in text and why in text, text
    assert "RMV600]: property Fine" not in text
    build = ["rmv", "build", "--target", "c", str(spec), "-o", str(tmp_path / "out")]
    built = subprocess.run(build, capture_output=True, text=True)
    assert built.returncode == 2 and "NoRate" in built.stderr and "Traceback" not in built.stderr
    built = subprocess.run([*build, "--max-rate", "50Hz"], capture_output=True, text=True)
    assert built.returncode == 2 and "NoRate" not in built.stderr and "Scaled" in built.stderr
    built = subprocess.run([*build, "--max-rate", "0Hz"], capture_output=True, text=True)
    assert built.returncode == 2 and "--max-rate 0Hz: expected a positive rate" in built.stderr


def two_systems(folder: Path) -> None:
    """Two systems in one folder: `a` (P: eventually, Q: once) and `b` (P: not x)."""
    eventually = ("until", "<=", Fraction(2), ("const", True), ("prop", "x"))
    once = ("since", "<", Fraction(3), ("const", True), ("prop", "y"))
    first = [("P", "e", sized(compile_formula(eventually), 8), 0)]
    first.append(("Q", "o", sized(compile_formula(once), 8), 0))
    write(files(laid_out("a", first)), folder)
    write(files(laid_out("b", [("P", "n", sized(compile_formula(("not", ("prop", "x"))), 8), 0)])),
          folder)  # fmt: skip


def test_the_monitor_is_freestanding_and_integer_only(tmp_path: Path) -> None:
    """No libc but memcmp/memmove/memset, and no floating-point register used (on
    x86-64, -mgeneral-regs-only refuses any floating-point code)."""
    import platform

    two_systems(tmp_path)
    flags = ["-std=c99", "-O2", "-ffreestanding", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
    if platform.machine() in ("x86_64", "AMD64"):
        flags.append("-mgeneral-regs-only")
    objects = []
    for source in ("rmv_a.c", "rmv_b.c"):
        objects.append(tmp_path / source.replace(".c", ".o"))
        subprocess.run([compiler(), *flags, "-c", str(tmp_path / source), "-o", str(objects[-1])],
                       check=True)  # fmt: skip
    undefined = subprocess.run(["nm", "-u", *map(str, objects)], capture_output=True, text=True,
                               check=True).stdout.split()  # fmt: skip
    assert {u for u in undefined if not u.endswith(":") and u != "U"} <= {
        "memcmp", "memmove", "memset", "memcpy",
    }  # fmt: skip


PROGRAM = r"""
#include <stdio.h>
#include "rmv_a.h"
#include "rmv_b.h"

static void show(void *context, int32_t property, const rmv_segment *s) {
    printf("%s %d %lld %lld %d %d %d\n", (const char *)context, (int)property,
           (long long)s->from_ns, (long long)s->to_ns, s->from_closed, s->to_closed, (int)s->value);
}

int main(void) {
    static rmv_a_monitor first, second;
    static rmv_b_monitor other;
    rmv_a_input on = {{0}, {0}}, off = {{0}, {0}};
    rmv_b_input b_on = {{0}, {0}};
    static char first_name[] = "first", second_name[] = "second", other_name[] = "other";
    on.holds[RMV_A_P_x] = 1;
    on.holds[RMV_A_P_y] = 1;
    b_on.holds[RMV_B_P_x] = 1;
    rmv_a_init(&first, show, first_name);
    rmv_a_init(&second, show, second_name);
    rmv_b_init(&other, show, other_name);
    rmv_a_step(&first, &off, 0);
    rmv_a_step(&second, &on, 0);
    rmv_b_step(&other, &b_on, 0);
    rmv_a_step(&first, &on, 5000000000);
    rmv_a_step(&second, &off, 1000000000);
    rmv_a_end(&first, 9000000000);
    rmv_a_end(&second, 9000000000);
    rmv_b_end(&other, 9000000000);
    return 0;
}
"""


@pytest.mark.parametrize("language", ["c", "c++"])
def test_two_systems_and_two_monitors_share_one_program(language: str, tmp_path: Path) -> None:
    """Two generated systems link into one program (C, or C++ through the headers'
    extern "C"), and two monitors of one system keep their own state: each gives
    the Python monitor's verdicts for its own input."""
    two_systems(tmp_path)
    main = tmp_path / ("main.c" if language == "c" else "main.cpp")
    cast = "(const char *)context" if language == "c" else "static_cast<const char *>(context)"
    main.write_text(PROGRAM.replace("(const char *)context", cast))
    objects = []
    for source in ("rmv_a.c", "rmv_b.c"):
        objects.append(str(tmp_path / source.replace(".c", ".o")))
        subprocess.run([compiler(), *STRICT_FLAGS, "-c", str(tmp_path / source), "-o", objects[-1]],
                       check=True)  # fmt: skip
    cxx = [compiler()] if language == "c" else ["g++", "-std=c++11", "-Wall", "-Wextra", "-Werror"]
    program = tmp_path / "main"
    subprocess.run([*cxx, "-o", str(program), str(main), *objects], check=True)
    out = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout
    got: dict[tuple[str, int], list] = {}
    for line in out.splitlines():
        who, prop, a, b, ac, bc, v = line.split()
        segment = (Fraction(int(a), NS), Fraction(int(b), NS), ac == "1", bc == "1",
                   {"0": "false", "1": "unknown", "2": "true"}[v])  # fmt: skip
        got.setdefault((who, int(prop)), []).append(segment)
    eventually = ("until", "<=", Fraction(2), ("const", True), ("prop", "x"))
    once = ("since", "<", Fraction(3), ("const", True), ("prop", "y"))
    off, on = frozenset(), frozenset({"x", "y"})
    for who, samples in (("first", [(0, off), (5, on)]), ("second", [(0, on), (1, off)])):
        trace = [(Fraction(t), s) for t, s in samples]
        assert merge(got[(who, 0)]) == monitor_segments(eventually, trace, Fraction(9))
        assert merge(got[(who, 1)]) == monitor_segments(once, trace, Fraction(9))
    negation = monitor_segments(("not", ("prop", "x")), [(Fraction(0), on)], Fraction(9))
    assert merge(got[("other", 0)]) == negation


def test_the_generated_makefile_and_cmake_build_the_driver(tmp_path: Path) -> None:
    spec = ROOT / "examples" / "carla" / "abs.rmv"
    out = tmp_path / "out"
    subprocess.run(["rmv", "build", "--target", "c", str(spec), "-o", str(out)], check=True,
                   capture_output=True)  # fmt: skip
    line = sample_line(Fraction(0), {"Cruising"}) + "\n" + end_line(Fraction(30)) + "\n"
    # make, cmake and g++ are .ci/run's (ROS 2's message packages need them too)
    subprocess.run(["make", "-s", "-C", str(out)], check=True, capture_output=True)
    done = subprocess.run([str(out / "rmv_carla_abs_replay")], input=line, text=True,
                          capture_output=True)  # fmt: skip
    assert done.returncode == 0 and '"property": "ABSCheck"' in done.stdout, done.stderr
    build = tmp_path / "cmake"
    subprocess.run(["cmake", "-S", str(out), "-B", str(build)], check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True)
    assert (build / "rmv_carla_abs_replay").exists()


def test_a_formula_makes_one_table_whatever_its_objects_share(rmv, tmp_path: Path) -> None:
    """Equal subformulas share one node whether the formula shares their objects
    (a fresh check's does, here and there) or not (one loaded from its JSON, as a
    build from the stored spec reads it): a spec builds the same monitor either
    way, byte for byte."""
    from rmvdsl.runtime import formulas as f

    def window() -> Any:
        return f.temporal("until", "<=", 10, f.const(True), f.prop("p"))

    part = window()
    shared = f.binary("or", f.binary("and", part, part), f.not_(part))
    separate = f.binary("or", f.binary("and", window(), window()), f.not_(window()))
    assert compile_formula(shared) == compile_formula(separate)
    assert len(compile_formula(separate).nodes) == 6  # p, true, until, and, not, or
    loaded = f.from_lists(f.to_lists(shared))
    assert compile_formula(loaded) == compile_formula(shared)
    # The example built twice: the second build loads the spec the first stored.
    first, second = tmp_path / "first", tmp_path / "second"
    for out in (first, second):
        assert rmv("build", "--target", "c", "examples/carla/abs.rmv", "-o", str(out)).code == 0
    assert {p.name: p.read_bytes() for p in first.iterdir()} == {
        p.name: p.read_bytes() for p in second.iterdir()
    }
