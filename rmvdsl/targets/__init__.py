"""The targets of `rmv build`, by name (docs/targets.md).

Each target is a package of this folder whose `__init__` declares `TARGET`: its
name, a one-line summary, its options and its `build`. The package's own import is
light (the generator is imported when `build` runs), so the command line reads
every declaration for its `--help` without paying for jinja2. Adding a target is its
folder and one line of REGISTRY.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rmvdsl.runtime import spec as ir

# name -> the package that declares it
REGISTRY = {
    "ir": "rmvdsl.targets.ir",
    "ros2": "rmvdsl.targets.ros2",
    "ros1": "rmvdsl.targets.ros1",
    "kapacitor": "rmvdsl.targets.kapacitor",
    "c": "rmvdsl.targets.c",
}


class TargetError(ValueError):
    """A spec, an option or an output this target cannot build."""


@dataclass(frozen=True)
class Option:
    """A target's own option of `rmv build` (`--package NAME`)."""

    name: str  # the keyword `build` receives
    metavar: str
    help: str
    choices: tuple[str, ...] = ()  # the values it takes (none: any)

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


@dataclass(frozen=True)
class Built:
    """What a build wrote, and what it tells the user."""

    files: tuple[Path, ...]
    summary: str  # one line for standard output
    notes: tuple[str, ...] = ()  # lines for standard error: what it left out
    text: str | None = None  # the output itself, when it goes to standard output


Build = Callable[["ir.Spec", "Path | None", Mapping[str, "str | None"]], Built]


@dataclass(frozen=True)
class Deployed:
    """What `rmv deploy` did with a build: each change, and a summary; or why it
    stopped (exit 1)."""

    changes: tuple[str, ...]
    summary: str
    failed: str | None = None


Deploy = Callable[[Path, Mapping[str, "str | None"]], Deployed]


@dataclass(frozen=True)
class Finding:
    """What a target says of a spec before it builds anything (`rmv check --target`):
    an `error` it cannot build, or a `note` on a part it leaves to another target."""

    severity: str  # "error" or "note"
    origin: str  # "path:line:column" of the declaration; "" for the spec as a whole
    message: str
    help: str = ""


def no_findings(spec: ir.Spec) -> list[Finding]:
    return []


@dataclass(frozen=True)
class Target:
    name: str
    summary: str  # one line: what it writes
    docs: str  # the page that describes it
    output: str  # what -o names: "file" (default: standard output) or "folder" (required)
    build: Build
    options: tuple[Option, ...] = ()
    # What it cannot build, or leaves out, said with where the spec declares it.
    findings: Callable[[ir.Spec], list[Finding]] = no_findings
    # `rmv deploy --target NAME OUT`: apply a build to running services (None: no such step).
    deploy: Deploy | None = None
    deploy_options: tuple[Option, ...] = ()


def target(name: str) -> Target:
    """The target registered as `name` (KeyError if none is)."""
    declared: Target = importlib.import_module(REGISTRY[name]).TARGET
    return declared


def targets() -> list[Target]:
    return [target(name) for name in REGISTRY]


def folder_output(name: str, out: Path | None) -> Path:
    """The folder a folder target writes: -o is required."""
    if out is None:
        raise TargetError(f"--target {name} needs -o OUT, the folder to write")
    return out


def ros_package_build(name: str, generator: str) -> Build:
    """The build of a target that writes one ROS package: `generator` (imported on
    first use) has `build(spec, out, package)` and `package_name(spec, package)`;
    the option `package` names it."""

    def build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
        from rmvdsl.runtime.wording import counted

        generate = importlib.import_module(generator)
        folder = folder_output(name, out)
        package = options.get("package")
        written = generate.build(spec, folder, package)
        what = f"the {name} package `{generate.package_name(spec, package)}`"
        return Built(tuple(written), f"wrote {what} to {folder} ({counted(len(written), 'file')})")

    return build
