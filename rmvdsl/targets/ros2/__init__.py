"""`rmv build --target ros2`: an ament_python package whose nodes host the runtime
(docs/ros2.md). The generator is `generate`; its names are read through this
package too (`ros2.build`, `ros2.py_string`), imported when first used."""

from __future__ import annotations

import importlib
from typing import Any

from rmvdsl.targets import Option, Target, ros_package_build

TARGET = Target(
    name="ros2",
    summary="a ROS 2 package (ament_python): the monitor and intrusion nodes",
    docs="docs/ros2.md",
    output="folder",
    build=ros_package_build("ros2", "rmvdsl.targets.ros2.generate"),
    options=(Option("package", "NAME", "the package's name (default: from `system`)"),),
)


def __getattr__(name: str) -> Any:
    # import_module, not `from . import generate`: that asks this very hook first.
    if name.startswith("__"):
        raise AttributeError(name)
    return getattr(importlib.import_module("rmvdsl.targets.ros2.generate"), name)
