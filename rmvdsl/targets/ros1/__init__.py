"""`rmv build --target ros1`: a catkin package whose rospy nodes host the runtime
(docs/ros1.md). The generator is `generate`, imported when first used."""

from __future__ import annotations

from rmvdsl.targets import Option, Target, ros_package_build

TARGET = Target(
    name="ros1",
    summary="a ROS 1 package (catkin): the monitor and intrusion nodes, rospy",
    docs="docs/ros1.md",
    output="folder",
    build=ros_package_build("ros1", "rmvdsl.targets.ros1.generate"),
    options=(Option("package", "NAME", "the package's name (default: from `system`)"),),
)
