"""`rmv build --target ros1`: a catkin package (rmvdsl.targets.catkin, the thesis's
platform) whose rospy monitor and intrusion nodes host the embedded runtime and
host, the same copies the ros2 package carries. Its own files (README, launch
file, parameters) are rendered from the templates beside this module."""

from __future__ import annotations

from pathlib import Path

from rmvdsl.runtime import spec as ir
from rmvdsl.targets.ament import package_name, write
from rmvdsl.targets.catkin import (
    CatkinPackage,
    Script,
    catkin_environment,
    catkin_package,
    make_executable,
)

__all__ = ["SCRIPTS", "build", "files", "package_name"]

# The nodes' default names are the ones the thesis's whitelists allow.
SCRIPTS = (
    Script("monitor", "rmv_monitor", "monitor_main"),
    Script("intrusion", "rmv_intrusion", "intrusion_main"),
)


def files(spec: ir.Spec, package: str | None = None) -> dict[str, str]:
    """Every file of the package, by path relative to its folder."""
    pkg = CatkinPackage(package_name(spec, package), spec, "Runtime monitor", "ros1", SCRIPTS)
    templates = {
        "README.md": "README.md.j2",
        "launch/monitor.launch": "launch/monitor.launch.j2",
        "config/params.yaml": "config/params.yaml.j2",
    }
    return catkin_package(pkg, catkin_environment(__package__ or ""), templates)


def build(spec: ir.Spec, out: Path, package: str | None = None) -> list[Path]:
    """Write the package into `out` (created; files it writes are replaced)."""
    return make_executable(write(files(spec, package), out))
