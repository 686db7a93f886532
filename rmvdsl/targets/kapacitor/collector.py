"""The kapacitor target's collector (the thesis's rostopicmon): an ament_python package
for ROS 2, or a catkin package for ROS 1, carrying the runtime and the ROS host."""

from __future__ import annotations

import jinja2

from rmvdsl.targets import ament, catkin
from rmvdsl.targets.kapacitor.build import (
    Build,
    environment,
)

COLLECTOR = (ament.NodeEntry("collector", "collector_node", "rmv_collector"),)


# The collector's package carries the whole ROS 2 host, whose rmv_host/ros2.py imports
# std_msgs (the actions' String): the ros2 target's base, all of it.
COLLECTOR_DEPENDENCIES = ament.BASE_DEPENDENCIES


def collector_files(build: Build, env: jinja2.Environment | None = None) -> dict[str, str]:
    """The collector: an ament_python package, `collector/` in the build, sharing
    the ros2 target's host (rmv_host/) and embedding the runtime's reading of
    variables and its line protocol."""
    spec = build.spec
    name = f"{ament.package_name(spec)}_collector"
    package = ament.Package(
        name, spec, ament.dependencies(COLLECTOR_DEPENDENCIES, spec),
        "InfluxDB collector", "kapacitor", COLLECTOR, "launch/collector.launch.py",
    )  # fmt: skip
    templates = {
        "README.md": "collector_README.md.j2",
        f"{name}/collector_node.py": "collector_node.py.j2",
        "config/params.yaml": "collector_params.yaml.j2",
    }
    env = env or environment()
    found = ament.ament_package(package, env, templates, database=build.database)
    return {f"collector/{path}": text for path, text in found.items()}


COLLECTOR_SCRIPTS = (catkin.Script("collector", "rmv_collector", "collector_main"),)


def collector1_files(build: Build) -> dict[str, str]:
    """The collector on ROS 1: a catkin package, `collector/` in the build, with the
    ros1 target's host (rmv_host/ros1.py): any message type, decoded from the
    connection header's definition. (Its templates are the catkin ones, which
    share names with the ament ones: an environment of their own.)"""
    spec = build.spec
    package = catkin.CatkinPackage(
        f"{ament.package_name(spec)}_collector", spec, "InfluxDB collector", "kapacitor",
        COLLECTOR_SCRIPTS,
    )  # fmt: skip
    templates = {
        "README.md": "collector1_README.md.j2",
        "launch/collector.launch": "collector1.launch.j2",
        "config/params.yaml": "collector1_params.yaml.j2",
    }
    env = catkin.catkin_environment(__package__ or "")
    found = catkin.catkin_package(package, env, templates, database=build.database)
    return {f"collector/{path}": text for path, text in found.items()}
