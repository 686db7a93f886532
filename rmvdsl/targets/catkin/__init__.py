"""A catkin package that hosts the runtime on ROS 1, as the ros1 target's monitor
package and the kapacitor target's ROS 1 collector both are: package.xml,
CMakeLists.txt, setup.py (catkin_python_setup), one executable script per node,
the resolved spec (`src/NAME/spec.json`), and the runtime and the ROS 1 host
embedded (rmvdsl.targets.embed) under `src/NAME/`. Its scripts run under
rosrun from a workspace, and straight from the package's folder. Not a target
itself: the targets that write such a package import it; names reach its files
through the ament module's quoting functions and `cmake_name`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import jinja2

from rmvdsl.runtime import spec as ir
from rmvdsl.targets.ament import BuildError, environment
from rmvdsl.targets.embed import embedded

# What every such package's code imports from ROS: rospy, rosgraph (the master's
# address) and the messages the nodes publish. The spec's own message types need
# nothing: the nodes decode them from the connection header's definition, with
# rosbags from PyPI, which no ROS 1 package provides (docs/ros1.md).
BASE_DEPENDENCIES = ("rospy", "rosgraph", "std_msgs", "diagnostic_msgs")


@dataclass(frozen=True)
class Script:
    name: str  # scripts/NAME, the rosrun executable
    node: str  # the ROS node's default name
    main: str  # the function of rmv_host/ros1.py it calls


@dataclass(frozen=True)
class CatkinPackage:
    name: str
    spec: ir.Spec
    description: str
    target: str  # the `rmv build` target that writes it
    scripts: tuple[Script, ...]
    dependencies: tuple[str, ...] = BASE_DEPENDENCIES


def cmake_name(name: str) -> str:
    """A package name as CMake reads it: a REP 144 name is already safe; anything
    else is refused rather than quoted."""
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name):
        raise BuildError(f"`{name}` cannot be written into CMakeLists.txt")
    return name


def catkin_environment(*packages: str) -> jinja2.Environment:
    """The templates of `packages`, then this module's, then the ament ones, with
    every quoting filter."""
    env = environment(*packages, __name__)
    env.filters["cmake"] = cmake_name
    return env


def catkin_package(
    package: CatkinPackage, env: jinja2.Environment, templates: dict[str, str], **context: object
) -> dict[str, str]:
    """Every file of the package: its own `templates` (path -> template) beside
    what every catkin package of rmvdsl holds."""
    name = package.name
    context = {"package": package, "spec": package.spec, **context}
    rendered = {
        "package.xml": "package.xml.j2",
        "CMakeLists.txt": "CMakeLists.txt.j2",
        "setup.py": "setup.py.j2",
        f"src/{name}/__init__.py": "init.py.j2",
        **templates,
    }
    out = {path: env.get_template(t).render(**context) for path, t in rendered.items()}
    for script in package.scripts:
        text = env.get_template("scripts/node.j2").render(script=script, **context)
        out[f"scripts/{script.name}"] = text
    out[f"src/{name}/spec.json"] = ir.dump(package.spec) + "\n"
    out.update({f"src/{path}": text for path, text in embedded(name, ros_version=1).items()})
    return out


def make_executable(written: list[Path]) -> list[Path]:
    """The scripts are executable, as catkin_install_python and rosrun want them."""
    for path in written:
        if path.parent.name == "scripts":
            path.chmod(0o755)
    return written
