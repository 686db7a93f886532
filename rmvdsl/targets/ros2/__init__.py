"""`rmv build --target ros2`: an ament_python package whose nodes host the runtime
(docs/ros2.md). The generator is `generate`; its names are read through this
package too (`ros2.build`, `ros2.py_string`), imported when first used."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rmvdsl.runtime import spec as ir
from rmvdsl.runtime.wording import counted
from rmvdsl.targets import Built, Option, Target, folder_output


def _build(spec: ir.Spec, out: Path | None, options: Mapping[str, str | None]) -> Built:
    generate = importlib.import_module("rmvdsl.targets.ros2.generate")
    folder = folder_output("ros2", out)
    package = options.get("package")
    written = generate.build(spec, folder, package)
    name = generate.package_name(spec, package)
    summary = f"wrote the ros2 package `{name}` to {folder} ({counted(len(written), 'file')})"
    return Built(tuple(written), summary)


TARGET = Target(
    name="ros2",
    summary="a ROS 2 package (ament_python): the monitor and intrusion nodes",
    docs="docs/ros2.md",
    output="folder",
    build=_build,
    options=(Option("package", "NAME", "the package's name (default: from `system`)"),),
)


def __getattr__(name: str) -> Any:
    # import_module, not `from . import generate`: that asks this very hook first.
    if name.startswith("__"):
        raise AttributeError(name)
    return getattr(importlib.import_module("rmvdsl.targets.ros2.generate"), name)
