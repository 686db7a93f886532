"""`rmv build --target ros2`: an ament_python package (rmvdsl.targets.ament) whose
monitor and intrusion nodes host the runtime; its own files are rendered from the
templates beside this module."""

from __future__ import annotations

from pathlib import Path

from rmvdsl.runtime import spec as ir
from rmvdsl.targets.ament import (
    BASE_DEPENDENCIES,
    BuildError,
    NodeEntry,
    Package,
    ament_package,
    dependencies,
    environment,
    message_packages,
    package_name,
    py_string,
    write,
    xml_text,
    yaml_string,
)

# The shared package's names, read through this target (`ros2.package_name`).
__all__ = [
    "BASE_DEPENDENCIES", "MONITOR_NODES", "BuildError", "NodeEntry", "Package", "ament_package",
    "build", "dependencies", "environment", "files", "message_packages", "package_name",
    "py_string", "write", "xml_text", "yaml_string",
]  # fmt: skip

MONITOR_NODES = (
    NodeEntry("monitor", "monitor_node", "rmv_monitor"),
    NodeEntry("intrusion", "intrusion_node", "rmv_intrusion"),
)


def files(spec: ir.Spec, package: str | None = None) -> dict[str, str]:
    """Every file of the package, by path relative to its folder."""
    name = package_name(spec, package)
    pkg = Package(
        name, spec, dependencies(BASE_DEPENDENCIES, spec),
        "Runtime monitor", "ros2", MONITOR_NODES, "launch/monitor.launch.py",
    )  # fmt: skip
    return ament_package(
        pkg,
        environment(__package__ or ""),
        {
            "README.md": "README.md.j2",
            f"{name}/monitor_node.py": "monitor_node.py.j2",
            f"{name}/intrusion_node.py": "intrusion_node.py.j2",
            "config/params.yaml": "config/params.yaml.j2",
        },
    )


def build(spec: ir.Spec, out: Path, package: str | None = None) -> list[Path]:
    """Write the package into `out` (created; files it writes are replaced)."""
    return write(files(spec, package), out)
