"""An ament_python package that hosts the runtime, as the ros2 target's monitor
package and the kapacitor target's collector both are: package.xml, setup.py, the
launch file, the resolved spec as JSON (`spec.json`), and copies of
`rmvdsl/runtime/` and `rmvdsl/host/` with their imports made package-relative
(rmvdsl.targets.embed), so a package needs nothing beyond ROS 2. Every file is
rendered from templates; names reach Python, XML and YAML only through
`py_string`, `xml_text` and `yaml_string`. Not a target itself: the targets that
write such a package import it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import jinja2

from rmvdsl.host.packaged import DISCOVERY_PROFILE
from rmvdsl.runtime import spec as ir
from rmvdsl.targets import TargetError
from rmvdsl.targets.embed import embedded
from rmvdsl.targets.rendering import template_environment

# Run dependencies every package has; the spec adds its message packages. The
# launch file imports launch, launch_ros and ament_index_python.
BASE_DEPENDENCIES = (
    "rclpy", "std_msgs", "diagnostic_msgs", "launch", "launch_ros", "ament_index_python",
)  # fmt: skip


class BuildError(TargetError):
    """A spec or a package name an ament package cannot be built from."""


@dataclass(frozen=True)
class NodeEntry:
    executable: str  # the console script
    module: str  # the package's module with `main`
    name: str  # the ROS node's name


@dataclass(frozen=True)
class Package:
    name: str
    spec: ir.Spec
    dependencies: tuple[str, ...]
    description: str
    target: str  # the `rmv build` target that writes it
    nodes: tuple[NodeEntry, ...]
    launch: str  # the launch file, relative to the package


def package_name(spec: ir.Spec, override: str | None = None) -> str:
    """A ROS package name (REP 144: lower case letters, digits, underscores, a
    letter first) from the spec's system name."""
    name = override if override is not None else spec.system.name
    candidate = re.sub(r"[^a-z0-9_]", "_", name.lower()).strip("_")
    candidate = re.sub(r"_+", "_", candidate)
    if override is not None and candidate != override:
        raise BuildError(
            f"`{override}` is not a ROS package name: lower case letters, digits and "
            f"underscores, a letter first (`{candidate}` is)"
        )
    if not candidate or not candidate[0].isalpha():
        candidate = f"rmv_{candidate}".rstrip("_")
    return candidate


def message_packages(spec: ir.Spec) -> tuple[str, ...]:
    """The packages of every message type the topics carry (nested ones included),
    which the node imports at run time."""
    found = {m.name.split("/")[0] for m in spec.messages}
    found |= {t.message_type.split("/")[0] for t in spec.topics}
    found.discard("builtin_interfaces")  # comes with rclpy
    return tuple(sorted(found))


def dependencies(base: tuple[str, ...], spec: ir.Spec) -> tuple[str, ...]:
    """A package's exec_depends: what its code imports (`base`), then the message
    packages of the spec's topics not among them."""
    return (*base, *(p for p in message_packages(spec) if p not in base))


def py_string(value: str) -> str:
    """Any text as a Python string literal (the one quoting function for Python):
    `repr`, in double quotes where the text has no quote of either kind."""
    literal = repr(str(value))
    if literal.startswith("'") and '"' not in value:
        return f'"{literal[1:-1]}"'
    return literal


def xml_text(value: str) -> str:
    """Any text as XML character data (the one quoting function for XML)."""
    text = str(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return re.sub(r"[\x00-\x08\x0b\x0c\x0e-\x1f]", "", text)


def yaml_string(value: str) -> str:
    """Any text as a YAML double-quoted scalar (the one quoting function for YAML)."""
    return json.dumps(str(value), ensure_ascii=True)


def environment(*packages: str) -> jinja2.Environment:
    """The templates of each of `packages` (their `templates` folder, read as
    package data), then the ones every ament package shares (beside this module),
    with the quoting filters."""
    filters = {"py": py_string, "xml": xml_text, "yaml": yaml_string}
    return template_environment((*packages, __name__), filters)


def ament_package(
    package: Package, env: jinja2.Environment, templates: dict[str, str], **context: object
) -> dict[str, str]:
    """Every file of an ament_python package that hosts the runtime: the package's
    own `templates` (path -> template) beside what every such package holds
    (package.xml, setup.py, the launch file, the spec, and copies of the runtime
    and of the host)."""
    name = package.name
    context = {"package": package, "spec": package.spec, "profile": DISCOVERY_PROFILE, **context}
    rendered = {
        "package.xml": "package.xml.j2",
        "setup.py": "setup.py.j2",
        "setup.cfg": "setup.cfg.j2",
        f"resource/{name}": "resource.j2",
        f"{name}/__init__.py": "init.py.j2",
        f"{name}/{DISCOVERY_PROFILE}": "fastdds_discovery.xml.j2",
        package.launch: "launch/nodes.launch.py.j2",
        **templates,
    }
    out = {path: env.get_template(t).render(**context) for path, t in rendered.items()}
    out[f"{name}/spec.json"] = ir.dump(package.spec) + "\n"
    out.update(embedded(name, ros_version=2))
    return out


def write(files: dict[str, str], out: Path) -> list[Path]:
    """Write files (path relative to `out` -> text); the paths written."""
    written = []
    for relative, text in files.items():
        path = out / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written
