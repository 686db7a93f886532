"""`rmv build --target ros1`: a catkin package (the thesis's platform) whose rospy
nodes host the embedded runtime and host (rmvdsl.targets.embed, the same copies
the ros2 package carries). Its files are rendered from the templates beside
this module; names reach Python, XML and YAML only through the quoting functions
of rmvdsl.targets.ament, and CMake only through `cmake_name`."""

from __future__ import annotations

import re
from pathlib import Path

from rmvdsl.runtime import spec as ir
from rmvdsl.targets.ament import (
    BuildError,
    environment,
    package_name,
    py_string,
    write,
    xml_text,
    yaml_string,
)
from rmvdsl.targets.embed import embedded

__all__ = ["DEPENDENCIES", "NODES", "build", "files", "package_name"]

# What the nodes import from ROS: rospy and rosgraph (the master's address), the
# messages they publish. The spec's own message types need nothing: the nodes
# decode them from the connection header's definition (with rosbags, from PyPI,
# which no ROS 1 package provides: docs/ros1.md).
DEPENDENCIES = ("rospy", "rosgraph", "std_msgs", "diagnostic_msgs")
# The scripts, and the names their nodes take (the thesis's whitelists allow them).
NODES = (("monitor", "rmv_monitor"), ("intrusion", "rmv_intrusion"))


def cmake_name(name: str) -> str:
    """A package name as CMake reads it: a REP 144 name is already safe; anything
    else is refused rather than quoted."""
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name):
        raise BuildError(f"`{name}` cannot be written into CMakeLists.txt")
    return name


def files(spec: ir.Spec, package: str | None = None) -> dict[str, str]:
    """Every file of the package, by path relative to its folder."""
    name = package_name(spec, package)
    env = environment(__package__ or "")
    env.filters["cmake"] = cmake_name
    context = {"spec": spec, "name": name, "dependencies": DEPENDENCIES, "nodes": NODES}
    rendered = {
        "package.xml": "package.xml.j2",
        "CMakeLists.txt": "CMakeLists.txt.j2",
        "setup.py": "setup.py.j2",
        "README.md": "README.md.j2",
        "launch/monitor.launch": "launch/monitor.launch.j2",
        "config/params.yaml": "config/params.yaml.j2",
        f"src/{name}/__init__.py": "init.py.j2",
        **{f"scripts/{script}": "scripts/node.j2" for script, _ in NODES},
    }
    out = {}
    for path, template in rendered.items():
        node = dict(NODES).get(path.removeprefix("scripts/"))
        script = path.removeprefix("scripts/")
        out[path] = env.get_template(template).render(**context, script=script, node=node)
    out[f"src/{name}/spec.json"] = ir.dump(spec) + "\n"
    out.update({f"src/{path}": text for path, text in embedded(name, ros_version=1).items()})
    return out


def build(spec: ir.Spec, out: Path, package: str | None = None) -> list[Path]:
    """Write the package into `out` (created; files it writes are replaced); the
    scripts are executable, as catkin_install_python and rosrun want them."""
    written = write(files(spec, package), out)
    for path in written:
        if path.parent.name == "scripts":
            path.chmod(0o755)
    return written


# The quoting functions the templates use, named here for the hostile-input tests.
QUOTING = (py_string, xml_text, yaml_string, cmake_name)
