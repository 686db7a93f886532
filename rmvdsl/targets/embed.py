"""The runtime and the host inside a generated package: copies of
`rmvdsl/runtime/` (with `rmvdsl/lang/builtins.py`) as `PACKAGE/rmv_runtime/` and of
`rmvdsl/host/` as `PACKAGE/rmv_host/`, their imports made package-relative, so a
package runs the code the tests ran and needs nothing of rmvdsl. Shared by every
target that writes a ROS package (ros2, ros1, and the kapacitor target's
collector)."""

from __future__ import annotations

import re
from importlib import resources

from rmvdsl.targets import TargetError


class EmbedError(TargetError):
    """A runtime or host module imports rmvdsl in a way a copy cannot."""


def host_module_for(name: str, ros_version: int) -> bool:
    """Whether a package for ROS `ros_version` carries the host module `name`:
    `ros1*.py` speak ROS 1, `ros2*.py` ROS 2, the others neither."""
    other = "ros2" if ros_version == 1 else "ros1"
    return name.endswith(".py") and not name.startswith(other)


def embedded(package: str, ros_version: int) -> dict[str, str]:
    """The copies, by path relative to the package's folder of Python modules."""
    out = {}
    runtime = f"{package}/rmv_runtime"
    modules = resources.files("rmvdsl.runtime").iterdir()
    for module in sorted((m for m in modules if m.name.endswith(".py")), key=lambda m: m.name):
        out[f"{runtime}/{module.name}"] = _vendored(module.read_text(encoding="utf-8"))
    builtins = resources.files("rmvdsl.lang").joinpath("builtins.py")
    out[f"{runtime}/builtins.py"] = _vendored(builtins.read_text(encoding="utf-8"))
    host = [m for m in resources.files("rmvdsl.host").iterdir()
            if host_module_for(m.name, ros_version)]  # fmt: skip
    for module in sorted(host, key=lambda m: m.name):
        out[f"{package}/rmv_host/{module.name}"] = _vendored_host(
            module.read_text(encoding="utf-8")
        )
    return out


def _vendored(source: str) -> str:
    """A runtime module with its imports made relative to the embedded package."""
    text = re.sub(r"^from rmvdsl\.runtime import ", "from . import ", source, flags=re.M)
    text = re.sub(r"^from rmvdsl\.runtime\.(\w+) import ", r"from .\1 import ", text, flags=re.M)
    builtins = r"^from rmvdsl\.lang\.builtins import "
    text = re.sub(builtins, "from .builtins import ", text, flags=re.M)
    if re.search(r"^\s*(from|import) rmvdsl\b", text, flags=re.M):
        raise EmbedError("the runtime imports rmvdsl in a way a package cannot embed")
    return _RELATIVE_BLOCK.sub(_sorted_block, text)


def _vendored_host(source: str) -> str:
    """A host module with its imports made relative: the host's own (`.`) and the
    runtime's, beside it in the package (`..rmv_runtime`)."""
    text = re.sub(r"^from rmvdsl\.host import ", "from . import ", source, flags=re.M)
    text = re.sub(r"^from rmvdsl\.host\.(\w+) import ", r"from .\1 import ", text, flags=re.M)
    text = re.sub(r"^from rmvdsl\.runtime import ", "from ..rmv_runtime import ", text, flags=re.M)
    text = re.sub(
        r"^from rmvdsl\.runtime\.(\w+) import ", r"from ..rmv_runtime.\1 import ", text, flags=re.M
    )
    if re.search(r"^\s*(from|import) rmvdsl\b", text, flags=re.M):
        raise EmbedError("the host imports rmvdsl in a way a package cannot embed")
    return _RELATIVE_BLOCK.sub(_sorted_block, text)


# One relative import, on one line or parenthesised over several; a run of them.
_RELATIVE = r"^from \.\S* import (?:\([^)]*\)|.*)\n"
_RELATIVE_BLOCK = re.compile(f"(?:{_RELATIVE})+", re.M)


def _sorted_block(match: re.Match[str]) -> str:
    """Relative imports in isort's order: the furthest first (`..x` before `.`),
    then `from . import` before `from .x import`, as ruff orders them."""
    statements = re.findall(_RELATIVE, match.group(0), flags=re.M)
    return "".join(sorted(statements, key=_relative_order))


def _relative_order(line: str) -> tuple[int, str]:
    module = line.split(" import ")[0].removeprefix("from ")
    return -(len(module) - len(module.lstrip("."))), module
