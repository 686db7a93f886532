#!/usr/bin/env bash
# What the tests run against: the wheel built from this checkout, installed (not
# editable) with its dev extra into a fresh venv. README's test command then
# activates that venv and runs its pytest, so the tests import the installed
# rmvdsl, never the checkout's rmvdsl/ (tests/conftest.py checks):
#
#     bash tests/install-wheel.sh && . .venv-installed/bin/activate && pytest
#
# The wheel stays in the venv's wheel/ folder: its presence tells the tests they
# run installed, and tests/test_install.py compares the install with it.
# RMV_TEST_VENV: where the venv goes (default .venv-installed).
# `--wheel-only DIR`: build the wheel into DIR and stop (tests/test_install.py).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="${RMV_TEST_VENV:-$root/.venv-installed}"
source="$(mktemp -d)"
trap 'rm -rf "$source"' EXIT
# Built from a copy of the files git tracks or would track (not ignored): what a
# clean clone holds plus uncommitted work, and no stale build/ folder.
if git -C "$root" rev-parse --git-dir >/dev/null 2>&1; then
    (cd "$root" && git ls-files -z --cached --others --exclude-standard \
        | tar --null --files-from=- --ignore-failed-read -cf - 2>/dev/null) | tar -xf - -C "$source"
else
    cp -r "$root/." "$source"
fi
if [ "${1:-}" = "--wheel-only" ]; then
    exec python3 -m pip wheel --quiet --no-deps --wheel-dir "$2" "$source"
fi
python3 -m venv --clear "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip wheel --quiet --no-deps --wheel-dir "$venv/wheel" "$source"
"$venv/bin/python" -m pip install --quiet "$(ls "$venv"/wheel/rmvdsl-*.whl)[dev]"
echo "installed $(ls "$venv"/wheel/rmvdsl-*.whl) into $venv"
