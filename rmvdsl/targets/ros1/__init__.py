"""`rmv build --target ros1`: a catkin package whose rospy nodes host the runtime
(docs/ros1.md). The generator is `generate`, imported when first used."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted
from rmvdsl.targets import Built, Option, Target, folder_output


def _build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
    generate = importlib.import_module("rmvdsl.targets.ros1.generate")
    folder = folder_output("ros1", out)
    package = options.get("package")
    written = generate.build(spec, folder, package)
    name = generate.package_name(spec, package)
    summary = f"wrote the ros1 package `{name}` to {folder} ({counted(len(written), 'file')})"
    return Built(tuple(written), summary)


TARGET = Target(
    name="ros1",
    summary="a ROS 1 package (catkin): the monitor and intrusion nodes, rospy",
    docs="docs/ros1.md",
    output="folder",
    build=_build,
    options=(Option("package", "NAME", "the package's name (default: from `system`)"),),
)
