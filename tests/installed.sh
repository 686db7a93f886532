#!/usr/bin/env bash
# The test suite against what a user installs: the wheel built from this checkout,
# installed (not editable) with its dev extra into a fresh venv, and pytest run
# from that venv, activated as a user would have it. The tests then import the
# installed rmvdsl, never the checkout's rmvdsl/ (tests/conftest.py checks).
# Arguments go to pytest. RMV_TEST_VENV: where the venv goes (default .venv-installed).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="${RMV_TEST_VENV:-$root/.venv-installed}"
dist="$(mktemp -d)"
trap 'rm -rf "$dist"' EXIT
# Built from a copy of the files git tracks or would track (not ignored): what a
# clean clone holds plus uncommitted work, and no stale build/ folder.
mkdir "$dist/src"
if git -C "$root" rev-parse --git-dir >/dev/null 2>&1; then
    (cd "$root" && git ls-files -z --cached --others --exclude-standard \
        | tar --null --files-from=- --ignore-failed-read -cf - 2>/dev/null) | tar -xf - -C "$dist/src"
else
    cp -r "$root/." "$dist/src"
fi
python3 -m pip wheel --quiet --no-deps --wheel-dir "$dist" "$dist/src"
wheel="$(ls "$dist"/rmvdsl-*.whl)"
python3 -m venv --clear "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "$wheel[dev]"
export VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" RMV_TEST_INSTALLED=1 RMV_WHEEL="$wheel"
unset PYTHONHOME PYTHONPATH
cd "$root"
# The venv's pytest script, not `python -m pytest`: -m would put the checkout first on sys.path.
"$venv/bin/pytest" "$@"
