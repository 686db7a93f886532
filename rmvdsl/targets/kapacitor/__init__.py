"""`rmv build --target kapacitor`: InfluxDB's schema and continuous queries, one
TICKscript per alert, their handlers and the collector (docs/kapacitor.md). The
generator is `generate`; its names are read through this package too, imported
when first used."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rmvdsl.runtime.wording import counted
from rmvdsl.targets import (
    Built,
    Deployed,
    Finding,
    Option,
    Target,
    TargetError,
    folder_output,
)

if TYPE_CHECKING:
    from rmvdsl.runtime import spec as ir


def _build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
    generate = importlib.import_module("rmvdsl.targets.kapacitor.generate")
    folder = folder_output("kapacitor", out)
    written, report = generate.write(spec, folder, ros=options.get("collector") or "ros2")
    summary = (
        f"wrote the kapacitor target to {folder} ({counted(len(written), 'file')}; "
        f"{counted(len(report), 'part')} of the spec left to the ros2 or ros1 monitor, listed in "
        "README.md)"
    )
    return Built(tuple(written), summary, tuple(report))


def _findings(spec: ir.Spec) -> list[Finding]:
    generate = importlib.import_module("rmvdsl.targets.kapacitor.generate")
    try:
        build = generate.plan(spec, Path("handlers"))
    except TargetError as exc:
        return [Finding("error", getattr(exc, "origin", ""), str(exc))]
    return [Finding("note", line.origin, str(line)) for line in build.report]


def _deploy(out: Path, options: Mapping[str, str | None]) -> Deployed:
    deploy = importlib.import_module("rmvdsl.targets.kapacitor.deploy")
    if not (out / deploy.MANIFEST).is_file():
        raise TargetError(
            f"{out}: no {deploy.MANIFEST}: not a build of `rmv build --target kapacitor`"
        )
    try:
        report = deploy.deploy(out, options.get("influx"), options.get("kapacitor"))
    except deploy.DeployError as exc:
        return Deployed((), "", failed=str(exc))
    summary = (
        f"{counted(len(report.applied), 'change')}, "
        f"{counted(len(report.unchanged), 'part')} already as built"
    )
    return Deployed(tuple(report.applied), summary)


TARGET = Target(
    name="kapacitor",
    summary="InfluxDB queries, TICKscripts and their handlers, a collector node",
    docs="docs/kapacitor.md",
    output="folder",
    build=_build,
    options=(
        Option(
            "collector",
            "ROS",
            "the collector's ROS: ros2 (default) or ros1",
            choices=("ros2", "ros1"),
        ),
    ),
    findings=_findings,
    deploy=_deploy,
    deploy_options=(
        Option("influx", "URL", "InfluxDB (default: the spec's)"),
        Option("kapacitor", "URL", "Kapacitor (default: http://127.0.0.1:9092)"),
    ),
)


def __getattr__(name: str) -> Any:
    # import_module, not `from . import generate`: that asks this very hook first.
    if name.startswith("__"):
        raise AttributeError(name)
    return getattr(importlib.import_module("rmvdsl.targets.kapacitor.generate"), name)
